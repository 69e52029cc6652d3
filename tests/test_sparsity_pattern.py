"""csc_pattern's band table (rodsim/core/sparsity.py) gives the pattern and slots sorting
does, for banded entries with repeats, and a wide band falls back to sorting."""

from __future__ import annotations

import numpy as np
import pytest

from rodsim.core import sparsity


def by_sorting(rows, cols, size):
    keys, target = np.unique(cols * size + rows, return_inverse=True)
    return keys % size, keys // size, target.ravel()


@pytest.mark.parametrize(("size", "half_width"), [(50, 3), (200, 20), (30, 29), (7, 0)])
def test_band_table_matches_sorting(size, half_width):
    rng = np.random.default_rng(size)
    rows = rng.integers(0, size, 4000)
    cols = np.clip(rows + rng.integers(-half_width, half_width + 1, 4000), 0, size - 1)
    pattern = sparsity.csc_pattern(rows, cols, size)
    expected_rows, expected_cols, expected_target = by_sorting(rows, cols, size)
    assert np.array_equal(pattern.rows, expected_rows)
    assert np.array_equal(pattern.cols, expected_cols)
    assert np.array_equal(pattern.target, expected_target)
    dense = np.zeros((size, size))
    dense[rows, cols] = 1.0
    assert np.array_equal(pattern.matrix.toarray(), dense)


def test_wide_sparse_entries_use_sorting(monkeypatch):
    calls = []
    monkeypatch.setattr(sparsity, "_banded_unique", lambda *a: calls.append(a))
    size = 1000
    rows, cols = np.array([0, 999, 5]), np.array([999, 0, 5])
    pattern = sparsity.csc_pattern(rows, cols, size)
    assert not calls and pattern.band == (999, 999) and pattern.nnz == 3


def _block_entries(blocks, size):
    """Rows, columns (row-major within each element) and kept mask of every block entry."""
    rows, cols = [], []
    for free in blocks:
        k = free.shape[1]
        rows.append(np.repeat(free, k, axis=1).ravel())
        cols.append(np.tile(free, (1, k)).ravel())
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    return rows, cols, (rows < size) & (cols < size)


@pytest.mark.parametrize(("size", "spread", "band_table"),
                         [(60, 4, True), (300, 12, True), (400, 399, False), (9, 0, True)])
def test_block_pattern_matches_sorting_every_entry(size, spread, band_table, monkeypatch):
    """block_pattern (the model's pattern from element blocks) against np.unique of every
    entry's key: the same sorted keys, each entry's position (the number of keys, a dump
    slot, on a fixed index ≥ size), the diagonal's positions; blocks of several shapes,
    repeated indices inside an element, identical blocks, and the sorting fallback for a
    wide band."""
    rng = np.random.default_rng(size + spread)
    blocks = []
    for elements, k in ((size, 4), (size // 4, 7), (1, 3), (0, 5)):
        start = rng.integers(0, size, (elements, 1))
        free = np.clip(start + rng.integers(0, spread + 1, (elements, k)), 0, size - 1)
        free[rng.random((elements, k)) < 0.1] = size  # fixed coordinates
        blocks.append(free)
    blocks.append(blocks[0].copy())
    used = []
    monkeypatch.setattr(sparsity, "_sorted_block_pattern",
                        lambda *a, f=sparsity._sorted_block_pattern: used.append(1) or f(*a))
    keys, positions, diagonal = sparsity.block_pattern(blocks, size)
    assert bool(used) != band_table
    rows, cols, kept = _block_entries(blocks, size)
    everything = np.concatenate([np.arange(size) * (size + 1), (cols * size + rows)[kept]])
    expected, inverse = np.unique(everything, return_inverse=True)
    assert np.array_equal(keys, expected)
    assert np.array_equal(diagonal, inverse.ravel()[:size])
    expected_positions = np.full(len(rows), len(keys))
    expected_positions[kept] = inverse.ravel()[size:]
    assert np.array_equal(np.concatenate(positions), expected_positions)
    assert [len(p) for p in positions] == [f.size * f.shape[1] for f in blocks]


@pytest.mark.parametrize("wider", [0, 5])
def test_merged_pattern_matches_sorting_the_placed_and_the_new_blocks(wider):
    """merged_pattern (a re-registration: kept blocks placed once, new blocks merged) against
    np.unique of every entry of both; in a table wider than the blocks need as well (a
    table kept from an earlier registration), and the placed blocks left unchanged."""
    size, spread = 120, 6
    rng = np.random.default_rng(wider)

    def blocks(count, k):
        start = rng.integers(0, size - spread, (count, 1))
        free = start + rng.integers(0, spread + 1, (count, k))
        free[rng.random((count, k)) < 0.1] = size
        return free

    kept, new = [blocks(size, 4), blocks(30, 6)], [blocks(40, 5), blocks(3, 2)]
    placed = sparsity.band_blocks(kept, size, spread + wider)
    marks = placed.marks.copy()
    keys, kept_positions, new_positions, diagonal = sparsity.merged_pattern(placed, new)
    assert np.array_equal(placed.marks, marks)
    rows, cols, kept_mask = _block_entries(kept + new, size)
    everything = np.concatenate([np.arange(size) * (size + 1), (cols * size + rows)[kept_mask]])
    expected, inverse = np.unique(everything, return_inverse=True)
    assert np.array_equal(keys, expected)
    assert np.array_equal(diagonal, inverse.ravel()[:size])
    expected_positions = np.full(len(rows), len(keys))
    expected_positions[kept_mask] = inverse.ravel()[size:]
    assert np.array_equal(np.concatenate(kept_positions + new_positions), expected_positions)
