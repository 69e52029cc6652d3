"""The physical-time step's sparse assembly, built from structures found once, gives the
same arrays as scipy's construction from (row, column) entries — what makes the speed-ups
of rodsim/solvers/physical bit-identical (docs/dynamics.md)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from rodsim.solvers.physical.coordinates import block_diagonal, block_entries, placed


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


def test_one_placement_is_the_sum_and_the_block_diag_it_replaces():
    """A map's identity part plus its blocks, placed at once with ``prune``: the arrays of
    scipy's sum of the two (which drops exact zeros); the Newton matrix's masses, placed at
    once: the arrays of ``sp.block_diag`` of the mass and the rotation blocks."""
    rng = np.random.default_rng(38)
    for trial in range(40):
        s, p = int(rng.integers(1, 20)), int(rng.integers(0, 30))
        n, m = p + 4 * s + 3, p + 3 * s
        positions = rng.permutation(n)[:p]
        quaternions = np.setdiff1d(np.arange(n), positions)[:4 * s].reshape(s, 4)
        angles = p + np.arange(3 * s).reshape(-1, 3)
        blocks = rng.standard_normal((s, 4, 3))
        blocks[rng.random(blocks.shape) < 0.3] = 0.0 if trial % 2 else -0.0
        factor = float(rng.uniform(0.1, 1.0))
        expected = sp.csr_matrix((np.full(p, factor), (positions, np.arange(p))),
                                 shape=(n, m)) + block_diagonal(blocks, quaternions, angles,
                                                                (n, m))
        r, c = block_entries(quaternions, angles, 4, 3)
        built = placed(np.concatenate([np.full(p, factor), blocks.ravel()]),
                       np.concatenate([positions, r]), np.concatenate([np.arange(p), c]),
                       (n, m), prune=True)
        for name in ("indices", "indptr", "data"):
            assert np.array_equal(getattr(built, name), getattr(expected, name)), name
        mass = sp.random(p, p, density=0.3, random_state=trial, format="csr") + sp.eye(p)
        mass.data[:: 5] = 0.0  # explicit zeros stay
        rotation = rng.standard_normal((s, 3, 3))
        expected = sp.block_diag([mass, block_diagonal(rotation, angles - p, angles - p,
                                                       (3 * s, 3 * s))]).tocsr()
        r, c = block_entries(angles, angles, 3, 3)
        built = placed(np.concatenate([mass.data, rotation.ravel()]),
                       np.concatenate([np.repeat(np.arange(p), np.diff(mass.indptr)), r]),
                       np.concatenate([mass.indices, c]), (m, m))
        for name in ("indices", "indptr", "data"):
            assert np.array_equal(getattr(built, name), getattr(expected, name)), name
