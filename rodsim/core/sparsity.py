"""A Jacobian sparsity pattern built from (row, column) entries, in CSC order.

The model, the CVODE first-order system and IDA's constrained system each assemble their
Jacobian from blocks whose entries may repeat; this is the one place that turns such a list
of entries into a CSC pattern and says where each entry lands in the CSC data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

__all__ = ["Pattern", "csc_pattern"]


@dataclass(frozen=True)
class Pattern:
    """A square CSC sparsity pattern.

    Attributes
    ----------
    matrix
        The pattern as a CSC matrix of ones.
    rows, cols
        Row and column of every stored entry, in CSC data order.
    target
        For each input entry, the index of its slot in the CSC data (repeats share a slot).
    band
        (lower, upper) bandwidth, each ≥ 0.
    """

    matrix: sp.csc_matrix
    rows: np.ndarray
    cols: np.ndarray
    target: np.ndarray
    band: tuple[int, int]

    @property
    def nnz(self) -> int:
        return len(self.rows)


#: A banded pattern is built through a (size × band width) table of slots when that table
#: is at most this many times the number of entries; otherwise by sorting (np.unique).
BAND_TABLE_RATIO = 4


def csc_pattern(rows: np.ndarray, cols: np.ndarray, size: int) -> Pattern:
    """The pattern of the entries (rows[k], cols[k]) of a ``size`` × ``size`` matrix.

    Where the entries lie in a band whose table (one slot per column and offset) is small
    against the entries (:data:`BAND_TABLE_RATIO`), each entry's CSC slot is found by marking
    and numbering that table — the same pattern and slots as sorting the entries, with two
    entry-sized arrays instead of sorting's five or so (the model's assembly at N = 40 000
    peaked at 794 MiB, mostly np.unique's temporaries; see docs/benchmarks.md)."""
    rows, cols = np.asarray(rows), np.asarray(cols)
    if len(rows):
        lower = max(int((rows - cols).max()), 0)
        upper = max(int((cols - rows).max()), 0)
        width = lower + upper + 1
        if size * width <= BAND_TABLE_RATIO * len(rows):
            return _banded(rows, cols, size, upper, width)
    keys, target = np.unique(cols * size + rows, return_inverse=True)
    pattern_rows, pattern_cols = keys % size, keys // size  # column-major keys: CSC order
    indptr = np.searchsorted(pattern_cols, np.arange(size + 1))
    matrix = sp.csc_matrix((np.ones(len(keys)), pattern_rows, indptr), shape=(size, size))
    offsets = pattern_rows - pattern_cols
    band = (int(max(offsets.max(initial=0), 0)), int(max(-offsets.min(initial=0), 0)))
    return Pattern(matrix, pattern_rows, pattern_cols, target.ravel(), band)


def _banded(rows: np.ndarray, cols: np.ndarray, size: int, upper: int, width: int) -> Pattern:
    """:func:`csc_pattern` through the band table: slot (column c, row r) at
    c × width + r − c + upper, which increases along CSC order (column, then row)."""
    key = cols * width
    key += rows
    key -= cols
    key += upper
    table = np.zeros(size * width, dtype=np.int64)
    table[key] = 1
    present = np.flatnonzero(table)
    table[present] = np.arange(len(present))
    target = table[key]
    del table, key
    pattern_cols = present // width
    pattern_rows = present % width + pattern_cols - upper
    indptr = np.searchsorted(pattern_cols, np.arange(size + 1))
    matrix = sp.csc_matrix((np.ones(len(present)), pattern_rows, indptr), shape=(size, size))
    offsets = pattern_rows - pattern_cols
    band = (int(max(offsets.max(initial=0), 0)), int(max(-offsets.min(initial=0), 0)))
    return Pattern(matrix, pattern_rows, pattern_cols, target, band)
