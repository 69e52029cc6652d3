"""A Jacobian sparsity pattern built from (row, column) entries, in CSC order.

The model, the CVODE first-order system and IDA's constrained system each assemble their
Jacobian from blocks whose entries may repeat; this is the one place that turns such a list
of entries into a CSC pattern and says where each entry lands in the CSC data.
"""

from __future__ import annotations

from collections.abc import Callable
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


#: Sorted unique keys of a banded set of entries are found through a (size × band width)
#: table of slots when that table is at most this many times the number of entries;
#: otherwise by sorting (np.unique).
BAND_TABLE_RATIO = 4


def csc_pattern(rows: np.ndarray, cols: np.ndarray, size: int) -> Pattern:
    """The pattern of the entries (rows[k], cols[k]) of a ``size`` × ``size`` matrix."""
    keys, target = unique_keys(np.asarray(cols) * size + np.asarray(rows), size)
    return pattern_of_keys(keys, target, size)


def unique_keys(keys: np.ndarray, size: int,
                tick: Callable[[], None] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(the sorted unique column-major keys ``col * size + row`` of ``keys``, each key's
    position among them) — ``np.unique(keys, return_inverse=True)``.

    Where the entries lie in a band whose table (one slot per column and offset) is small
    against the entries (:data:`BAND_TABLE_RATIO`), the positions are found by marking and
    numbering that table: the same answer with two entry-sized arrays instead of sorting's
    five or so (the model's assembly at N = 40 000 peaked at 794 MiB, mostly np.unique's
    temporaries; see docs/benchmarks.md).

    ``tick`` is called between the steps (each a pass over the entries): the assembly's
    wall-time budget (rodsim/core/assembly_budget.py)."""
    tick = tick or _no_tick
    keys = np.asarray(keys)
    if len(keys):
        rows = keys % size
        tick()
        cols = keys // size
        tick()
        lower = max(int((rows - cols).max()), 0)
        upper = max(int((cols - rows).max()), 0)
        tick()
        width = lower + upper + 1
        if size * width <= BAND_TABLE_RATIO * len(keys):
            return _banded_unique(rows, cols, size, upper, width, tick)
    unique, target = np.unique(keys, return_inverse=True)
    return unique, target.ravel()


def _no_tick() -> None:
    """No budget to check."""


def _banded_unique(rows: np.ndarray, cols: np.ndarray, size: int, upper: int,
                   width: int, tick: Callable[[], None]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`unique_keys` through the band table: slot (column c, row r) at
    c × width + r − c + upper, which increases along CSC order (column, then row)."""
    slot = cols * width
    slot += rows
    slot -= cols
    slot += upper
    tick()
    table = np.zeros(size * width, dtype=np.int64)
    table[slot] = 1
    tick()
    present = np.flatnonzero(table)
    table[present] = np.arange(len(present))
    tick()
    target = table[slot]
    del table, slot
    columns = present // width
    return columns * size + (present % width + columns - upper), target


def pattern_of_keys(keys: np.ndarray, target: np.ndarray, size: int) -> Pattern:
    """The pattern whose stored entries have the sorted unique column-major keys
    ``col * size + row``; ``target`` as in :class:`Pattern`."""
    pattern_rows, pattern_cols = keys % size, keys // size  # column-major keys: CSC order
    indptr = np.searchsorted(pattern_cols, np.arange(size + 1))
    matrix = sp.csc_matrix((np.ones(len(keys)), pattern_rows, indptr), shape=(size, size))
    offsets = pattern_rows - pattern_cols
    band = (int(max(offsets.max(initial=0), 0)), int(max(-offsets.min(initial=0), 0)))
    return Pattern(matrix, pattern_rows, pattern_cols, target, band)
