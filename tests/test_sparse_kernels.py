"""scipy's sparse operators run as their kernels (rodsim/solvers/physical/sparse_kernels.py)
give scipy's own arrays — indices, pointers and values, signs of zero included — on seeded
random matrices with exact zeros and cancelling entries (which scipy's sums and products
drop): what keeps the physical-time steps' trajectories bit-identical (docs/dynamics.md,
"What a step costs")."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from rodsim.solvers.physical.sparse_kernels import (
    INDEX,
    Csr,
    arrays,
    congruent,
    csr_of,
    minus,
    plus,
    product,
    scaled,
    transpose,
)


def _random(rng: np.random.Generator, rows: int, cols: int) -> sp.csr_matrix:
    a = sp.random(rows, cols, density=0.3, format="csr", random_state=rng)
    a.data = np.round(4.0 * (a.data - 0.5))  # small integers: exact zeros and cancellations
    return a


def _same(built: sp.csr_matrix, expected: sp.csr_matrix) -> None:
    assert built.shape == expected.shape
    assert np.array_equal(built.indptr, expected.indptr)
    assert np.array_equal(built.indices, expected.indices)
    assert np.array_equal(built.data, expected.data)
    assert np.array_equal(np.signbit(built.data), np.signbit(expected.data))


def test_kernel_chains_are_scipys_operators():
    rng = np.random.default_rng(14)
    for _ in range(40):
        n, m = int(rng.integers(3, 30)), int(rng.integers(3, 30))
        g, p, extra = _random(rng, n, m), _random(rng, n, m), _random(rng, m, m)
        jac = _random(rng, n, n).tocsc()
        # a step's stiffness derivative: (g.T @ J @ p + extra) weighted and summed, tocsr
        expected = 0.5 * ((g.T @ jac @ p) + extra)
        expected = (expected + 0.5 * ((g.T @ jac @ g) + extra)).tocsr()
        added = transpose(m, m, arrays(extra))
        one = scaled(plus(m, m, congruent(n, m, arrays(g), arrays(jac), arrays(p)), added), 0.5)
        two = scaled(plus(m, m, congruent(n, m, arrays(g), arrays(jac), arrays(g)), added), 0.5)
        _same(csr_of(transpose(m, m, plus(m, m, one, two)), (m, m), sorted_indices=True),
              expected)
        # the Newton matrix: masses − stiffness + damping @ diags(scale)
        masses, stiffness, damping = _random(rng, m, m), expected, _random(rng, m, m)
        scale = rng.choice([0.5, 2.0, 1e3], m)
        diagonal = Csr(np.arange(m + 1, dtype=INDEX), np.arange(m, dtype=INDEX), scale)
        built = plus(m, m, minus(m, m, arrays(masses), arrays(stiffness)),
                     product(m, m, arrays(damping), diagonal))
        _same(csr_of(built, (m, m)),
              (masses - stiffness + damping @ sp.diags(scale)).tocsr())
