"""The physical-time step's sparse assembly, built from structures found once, gives the
same arrays as scipy's construction from (row, column) entries — what makes the speed-ups
of rodsim/solvers/physical bit-identical (docs/dynamics.md)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from rodsim.solvers.physical.coordinates import block_diagonal


def test_block_diagonal_is_scipys_matrix_entry_for_entry():
    """Seeded placements (4×3, 3×3, 3×4 blocks; rows and columns in any order) and blocks
    with exact zeros of both signs: the same indices, pointers and data (signs of zero
    included, explicit zeros kept) as ``csr_matrix((data, (rows, cols)))``, twice (the
    second from the remembered structure)."""
    rng = np.random.default_rng(33)
    for trial in range(60):
        s = int(rng.integers(1, 25))
        a, b = [(4, 3), (3, 3), (3, 4)][trial % 3]
        n = 4 * s + 7
        rows = rng.permutation(n)[:s * a].reshape(s, a)
        cols = rng.permutation(n)[:s * b].reshape(s, b)
        r = np.repeat(rows[:, :, None], b, axis=2).ravel()
        c = np.repeat(cols[:, None, :], a, axis=1).ravel()
        for _ in range(2):
            blocks = rng.standard_normal((s, a, b))
            blocks[rng.random(blocks.shape) < 0.3] = 0.0
            blocks[rng.random(blocks.shape) < 0.1] = -0.0
            expected = sp.csr_matrix((blocks.ravel(), (r, c)), shape=(n, n))
            built = block_diagonal(blocks, rows, cols, (n, n))
            assert built.indices.dtype == expected.indices.dtype
            assert np.array_equal(built.indices, expected.indices)
            assert np.array_equal(built.indptr, expected.indptr)
            assert np.array_equal(built.data, expected.data)
            assert np.array_equal(np.signbit(built.data), np.signbit(expected.data))
            assert built.has_canonical_format
