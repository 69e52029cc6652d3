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
