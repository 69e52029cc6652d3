"""A Jacobian sparsity pattern built from (row, column) entries, in CSC order.

The model, the CVODE first-order system and IDA's constrained system each assemble their
Jacobian from blocks whose entries may repeat; this is the one place that turns such a list
of entries into a CSC pattern and says where each entry lands in the CSC data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

__all__ = ["Pattern", "csc_pattern", "pattern_of_keys"]


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


def csc_pattern(rows: np.ndarray, cols: np.ndarray, size: int) -> Pattern:
    """The pattern of the entries (rows[k], cols[k]) of a ``size`` × ``size`` matrix."""
    keys, target = np.unique(np.asarray(cols) * size + np.asarray(rows), return_inverse=True)
    return pattern_of_keys(keys, target.ravel(), size)


def pattern_of_keys(keys: np.ndarray, target: np.ndarray, size: int) -> Pattern:
    """The pattern whose stored entries have the sorted unique column-major keys
    ``col * size + row``; ``target`` as in :class:`Pattern`."""
    pattern_rows, pattern_cols = keys % size, keys // size  # column-major keys: CSC order
    indptr = np.searchsorted(pattern_cols, np.arange(size + 1))
    matrix = sp.csc_matrix((np.ones(len(keys)), pattern_rows, indptr), shape=(size, size))
    offsets = pattern_rows - pattern_cols
    band = (int(max(offsets.max(initial=0), 0)), int(max(-offsets.min(initial=0), 0)))
    return Pattern(matrix, pattern_rows, pattern_cols, target, band)
