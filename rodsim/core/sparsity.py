"""A Jacobian sparsity pattern built from (row, column) entries, in CSC order.

The model, the CVODE first-order system and IDA's constrained system each assemble their
Jacobian from blocks whose entries may repeat; this is the one place that turns such a list
of entries into a CSC pattern and says where each entry lands in the CSC data.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

__all__ = ["Pattern", "BandBlocks", "MergedPattern", "band_blocks", "block_pattern",
           "block_spread", "csc_pattern", "merge_placed", "merged_pattern", "pattern_of_keys"]


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
    against the entries (``BAND_TABLE_RATIO``), the positions are found by marking and
    numbering that table: the same answer with two entry-sized arrays instead of sorting's
    five or so (the model's assembly at N = 40 000 peaked at 794 MiB, mostly np.unique's
    temporaries; see docs/benchmark-history.md).

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
    """``unique_keys`` through the band table: slot (column c, row r) at
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


def block_pattern(blocks: list[np.ndarray], size: int,
                  tick: Callable[[], None] | None = None) -> tuple[
        np.ndarray, list[np.ndarray], np.ndarray]:
    """The pattern of the diagonal and of dense element blocks, as ``unique_keys``
    gives it for their entries, without forming the entries' keys.

    ``blocks`` are integer arrays f of shape (E, k): element e couples every pair of its
    indices, entry (i, j) at row f[e, i] and column f[e, j], row-major within the element
    (``Model._entry_keys``'s order); an index ≥ ``size`` (a fixed coordinate) drops the
    entries on its row and column. Returns (the sorted unique column-major keys ``col * size
    + row`` of the diagonal and of every kept entry; for each array of ``blocks``, each of
    its entries' position among those keys, the number of keys where dropped (a dump slot
    past the end), shape (E k k,); the diagonal's positions).

    Where the band table is small against the entries (``BAND_TABLE_RATIO``), an entry's
    slot in it is the sum of a row part and a column part read per index (``f`` is E × k,
    the entries E × k × k), so the entries are never divided back into rows and columns:
    on tdcr-two-segment this made the assembly's pattern ~4× cheaper (docs/benchmark-history.md,
    "Model assembly"). Otherwise: the keys, sorted (``unique_keys``).

    ``tick`` is called between the passes over a block's entries: the assembly's wall-time
    budget."""
    tick = tick or _no_tick
    spread, count = block_spread(blocks, size)
    if not band_table_fits(size, spread, count):
        return _sorted_block_pattern(blocks, size, tick)
    keys, positions, _, diagonal = merged_pattern(band_blocks(blocks, size, spread, tick), [],
                                                  tick)
    return keys, positions, diagonal


def block_spread(blocks: list[np.ndarray], size: int) -> tuple[int, int]:
    """(the largest distance between two kept indices of one element of ``blocks``, the
    number of kept entries plus ``size`` for the diagonal): the band half-width the blocks
    need (each block is symmetric: lower = upper) and what a band table is weighed
    against."""
    spread = 0
    count = size
    for free in blocks:
        if free.size:
            kept = free < size
            spread = max(spread, int((np.where(kept, free, -1).max(axis=1)
                                      - free.min(axis=1)).max()))
            count += int(np.sum(np.sum(kept, axis=1) ** 2))
    return spread, count


def band_table_fits(size: int, spread: int, count: int) -> bool:
    """Whether a band table of half-width ``spread`` is small against ``count`` entries
    (``BAND_TABLE_RATIO``)."""
    return size * (2 * spread + 1) <= BAND_TABLE_RATIO * count


@dataclass(frozen=True)
class BandBlocks:
    """Element blocks placed in a band table of half-width ``spread`` (``band_blocks``):
    kept by a model whose terms re-register, so that their new blocks are merged
    (``merged_pattern``) without placing these again.

    Slot (column c, row r) of the table is c × width + r − c + spread (width = 2 spread + 1),
    increasing in CSC order; slot ``end`` = size × width takes every entry on a fixed
    coordinate."""

    size: int
    spread: int
    #: Each block's entries' slots, shape (E k k,).
    slots: list[np.ndarray]
    #: True at the diagonal's slots and the blocks' entries', shape (end + 1,); False at end.
    marks: np.ndarray

    @property
    def width(self) -> int:
        return 2 * self.spread + 1

    @property
    def end(self) -> int:
        return self.size * self.width

    def place(self, free: np.ndarray) -> np.ndarray:
        """The slots of the entries of one block (E, k), row-major within each element: the
        sum of a row part and a column part read per index, never the entries' keys."""
        width, end = self.width, self.end
        column_part = np.append(np.arange(self.size) * (width - 1) + self.spread, end)
        row_part = np.append(np.arange(self.size), end)
        slot = (row_part[free][:, :, None] + column_part[free][:, None, :]).reshape(-1)
        np.minimum(slot, end, out=slot)  # one fixed index or two: the dump
        return slot


def band_blocks(blocks: list[np.ndarray], size: int, spread: int,
                tick: Callable[[], None] | None = None) -> BandBlocks:
    """``blocks`` (as in ``block_pattern``, each element's kept indices at most
    ``spread`` apart) and the diagonal placed in a band table."""
    tick = tick or _no_tick
    placed = BandBlocks(size, spread, [], np.zeros(size * (2 * spread + 1) + 1, dtype=bool))
    placed.marks[np.arange(size) * placed.width + spread] = True
    for free in blocks:
        slot = placed.place(free)
        placed.marks[slot] = True
        placed.slots.append(slot)
        tick()
    placed.marks[placed.end] = False
    return placed


def merged_pattern(placed: BandBlocks, blocks: list[np.ndarray],
                   tick: Callable[[], None] | None = None) -> tuple[
        np.ndarray, list[np.ndarray], list[np.ndarray], np.ndarray]:
    """The pattern of ``placed`` and further ``blocks`` (whose elements' kept indices are at
    most ``placed.spread`` apart), as ``block_pattern`` gives it for all of them: (the
    sorted unique keys; the positions of ``placed``'s blocks' entries among them; those of
    ``blocks``' entries; the diagonal's) — a dropped entry's position is the number of keys.
    ``placed`` is not changed."""
    tick = tick or _no_tick
    slots = []
    for free in blocks:
        slots.append(placed.place(free))
        tick()
    merged = merge_placed(placed, slots, tick)
    return merged.keys, merged.positions, merged.extra, merged.diagonal


class MergedPattern(NamedTuple):
    """``merge_placed``'s answer: the pattern's sorted unique column-major keys and
    their rows and columns (CSC order), the positions among them of the placed blocks'
    entries and of the further ones (the number of keys where dropped), the diagonal's."""

    keys: np.ndarray
    rows: np.ndarray
    cols: np.ndarray
    positions: list[np.ndarray]
    extra: list[np.ndarray]
    diagonal: np.ndarray


def merge_placed(placed: BandBlocks, slots: list[np.ndarray],
                 tick: Callable[[], None] | None = None) -> MergedPattern:
    """``merged_pattern`` of further blocks already placed in ``placed``'s table
    (``slots``: ``BandBlocks.place`` of each), with the stored entries' rows and columns
    (one integer division of the slots, where the keys were divided back into rows and
    columns in two more).
    ``placed`` is not changed."""
    tick = tick or _no_tick
    marks = placed.marks
    if slots:
        marks = marks.copy()
        for slot in slots:
            marks[slot] = True
        marks[placed.end] = False
        tick()
    width, size, upper = placed.width, placed.size, placed.spread
    present = np.flatnonzero(marks)
    columns = present // width
    rows = present - columns * (width - 1) - upper  # offset + column − upper
    count = len(present)
    table = np.full(placed.end + 1, count, dtype=np.int64)
    table[present] = np.arange(count)
    tick()
    positions = []
    for slot in placed.slots:
        positions.append(table[slot])
        tick()
    extra = []
    for slot in slots:
        extra.append(table[slot])
        tick()
    keys = columns * size + rows
    return MergedPattern(keys, rows, columns, positions, extra,
                         table[np.arange(size) * width + upper])


def _sorted_block_pattern(blocks: list[np.ndarray], size: int,
                          tick: Callable[[], None]) -> tuple[
        np.ndarray, list[np.ndarray], np.ndarray]:
    """``block_pattern`` by sorting every entry's key (a wide band)."""
    keys = [np.arange(size) * (size + 1)]
    for free in blocks:
        k = free.shape[1]
        rows = np.repeat(free, k, axis=1).ravel()
        cols = np.tile(free, (1, k)).ravel()
        entry = cols * size + rows
        entry[(rows >= size) | (cols >= size)] = -1
        keys.append(entry)
        tick()
    everything = np.concatenate(keys)
    keep = everything >= 0
    tick()
    unique, inverse = unique_keys(everything[keep], size, tick)
    tick()
    position = np.full(len(everything), len(unique))
    position[keep] = inverse.ravel()
    bounds = np.cumsum([len(k) for k in keys])
    return unique, [position[start:stop] for start, stop in zip(bounds[:-1], bounds[1:],
                                                                strict=True)], position[:size]


def pattern_of_keys(keys: np.ndarray, target: np.ndarray, size: int,
                    entries: tuple[np.ndarray, np.ndarray] | None = None) -> Pattern:
    """The pattern whose stored entries have the sorted unique column-major keys
    ``col * size + row``; ``target`` as in ``Pattern``. ``entries``: the keys' (rows,
    columns) when the caller has them (``MergedPattern``), else divided out of the
    keys."""
    if entries is None:
        pattern_rows, pattern_cols = keys % size, keys // size  # column-major: CSC order
    else:
        pattern_rows, pattern_cols = entries
    indptr = np.searchsorted(pattern_cols, np.arange(size + 1))
    matrix = sp.csc_matrix((np.ones(len(keys)), pattern_rows, indptr), shape=(size, size))
    offsets = pattern_rows - pattern_cols
    band = (int(max(offsets.max(initial=0), 0)), int(max(-offsets.min(initial=0), 0)))
    return Pattern(matrix, pattern_rows, pattern_cols, target, band)
