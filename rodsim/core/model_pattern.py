"""The structure of a model: the free-coordinate maps, the band order of the free
coordinates (reverse Cuthill–McKee when it narrows the band), the Jacobian's sparsity
pattern as the union of the terms' element blocks, and where each term's force and
Jacobian entries land (rodsim/core/sparsity.py builds the pattern). Fixed when the model
is built; a re-registration of the tendons rebuilds only the dynamic terms' share."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee

from rodsim.core.model_base import ModelBase
from rodsim.core.sparsity import (
    BandBlocks,
    band_blocks,
    band_table_fits,
    block_pattern,
    block_spread,
    merge_placed,
    pattern_of_keys,
)
from rodsim.core.terms import Term

__all__ = ["Band", "ModelPattern"]


@dataclass(frozen=True)
class Band:
    """Lower and upper bandwidth of the Jacobian of the free coordinates."""

    lower: int
    upper: int


@dataclass
class _FixedBlocks:
    """The Jacobian pattern's part that a re-registration keeps (``Model._build_pattern``):
    the element blocks of the non-dynamic terms, and what was computed from them — filled
    when first needed and shared by the models that keep it."""

    #: The non-dynamic terms with a Jacobian, and the free-coordinate map of their blocks.
    terms: tuple[Term, ...]
    free_of: np.ndarray
    #: The distinct blocks (free indices, (E, k)) and each term's among them.
    blocks: list[np.ndarray]
    which: list[int]
    #: :func:`~rodsim.core.sparsity.block_spread` of the blocks.
    spread: int
    count: int
    #: The blocks in a band table (a model with dynamic terms), or None.
    band: BandBlocks | None = None
    #: :func:`~rodsim.core.sparsity.block_pattern` of the blocks (sorted keys, each block's
    #: positions among them, the diagonal's), or None.
    keys: tuple[np.ndarray, list[np.ndarray], np.ndarray] | None = None


@dataclass
class _DynamicBlock:
    """A dynamic term's element blocks as ``Model._build_pattern`` uses them, kept by the
    model re-registered from it while the term is the same object (at a re-registration,
    only the terms whose parents changed are new): the free-coordinate map of its blocks and
    their ``rodsim.core.sparsity.block_spread``, and their slots in the band table
    ``placed_in`` once placed."""

    term: Term
    free_of: np.ndarray
    free: np.ndarray
    spread: int
    count: int
    placed_in: BandBlocks | None = None
    slots: np.ndarray | None = None

    def slots_in(self, placed: BandBlocks) -> np.ndarray:
        """The blocks' slots in ``placed``'s table (placed once per table)."""
        if self.placed_in is not placed or self.slots is None:
            self.slots, self.placed_in = placed.place(self.free), placed
        return self.slots


class ModelPattern(ModelBase):
    """The structure part of ``rodsim.core.model.Model`` (module docstring)."""

    #: Jacobian sparsity pattern of the free coordinates (CSC, ones where J may be ≠ 0),
    #: its rows and columns, its stored entries and its bandwidths.
    pattern: sp.csc_matrix
    nnz: int
    band: Band

    def _build_maps(self) -> None:
        self._memo = []
        self._free_of = np.full(self.full_size, self.n)  # fixed -> dump slot n
        self._free_of[self.free] = np.arange(self.n)
        self._build_force_scatter()
        self._tick()
        self._build_pattern()
        self._kernel_calls = None
        self._kept_calls = None
        self._kernel_units = None

    def _order_for_band(self) -> None:
        """Reorder the free coordinates (reverse Cuthill–McKee) when that narrows the band.

        Coupled rods concatenated as in Eq. (30) give a wide band (a tendon point couples to
        catheter coordinates far away in the vector); interleaving them keeps the system
        banded. The order is fixed once, from the pattern at rest (``_rest_structure``,
        the structure of ``pattern`` in the scene's order), before the index maps are
        built: they are built once, in the order kept.
        """
        structure = self._rest_structure()
        order = reverse_cuthill_mckee(structure, symmetric_mode=True)
        rows = structure.indices
        cols = np.repeat(np.arange(self.n), np.diff(structure.indptr))
        offsets = rows - cols
        current = max(offsets.max(), -offsets.min())
        inverse = np.empty_like(order)
        inverse[order] = np.arange(self.n)
        new_offsets = inverse[rows] - inverse[cols]
        if max(new_offsets.max(), -new_offsets.min()) < current:
            self.free = self.free[order]

    def _rest_structure(self) -> sp.csc_matrix:
        """The Jacobian's structure at rest in the current order of ``free`` (canonical
        CSC, the structure ``_build_pattern`` gives): the diagonal and, for every term
        with a Jacobian, each element's coordinates coupled pairwise — BᵀB of the incidence
        matrix B (one row per element and one per coordinate, ones where it holds the
        coordinate), without the targets the pattern's build computes."""
        n = self.n
        free_of = np.full(self.full_size, n)
        free_of[self.free] = np.arange(n)
        elements, coordinates = [np.arange(n)], [np.arange(n)]
        count = n
        for term in self.terms:
            if not term.has_jacobian:
                continue
            free = free_of[term.dofs]
            kept = free < n
            elements.append(np.broadcast_to(
                np.arange(count, count + len(free))[:, None], free.shape)[kept])
            coordinates.append(free[kept])
            count += len(free)
        incidence = sp.csr_matrix((np.ones(sum(len(c) for c in coordinates)),
                                   (np.concatenate(elements), np.concatenate(coordinates))),
                                  shape=(count, n))
        structure = (incidence.T @ incidence).tocsc()
        structure.sum_duplicates()
        structure.sort_indices()
        return structure

    def _build_force_scatter(self) -> None:
        self._loads = [t for t in self.terms if t.is_load]
        self._force_targets = np.concatenate([self._free_of[t.dofs.ravel()]
                                              for t in self.terms])

    def _build_pattern(self) -> None:
        """The Jacobian pattern: the diagonal (always stored) and every element entry of the
        terms with a Jacobian (entries on fixed coordinates dropped), in CSC order.

        A re-registration (``reregistered``) changes only the dynamic terms' elements:
        what the diagonal and the other terms give is kept from the model it came from
        (``_fixed_blocks``) and merged with the dynamic ones — in a band table where it
        is small against the entries (``rodsim.core.sparsity.merged_pattern``),
        otherwise as sorted keys merged with the dynamic terms' by sorting. The pattern and
        the targets are those a sort of all entries gives
        (``rodsim.core.sparsity.csc_pattern``)."""
        n = self.n
        self._jac_terms = [t for t in self.terms if t.has_jacobian]
        fixed = self._fixed_blocks()
        dynamic = [index for index, term in enumerate(self._jac_terms) if term.dynamic]
        blocks = self._dynamic_blocks_of(dynamic)
        spread = max([fixed.spread, *(block.spread for block in blocks)])
        count = fixed.count + sum(block.count - n for block in blocks)
        entries = None
        if dynamic and band_table_fits(n, spread, count):
            if fixed.band is None or fixed.band.spread < spread:
                fixed.band = band_blocks(fixed.blocks, n, spread, self._tick)
            merged = merge_placed(fixed.band, [block.slots_in(fixed.band) for block in blocks],
                                  self._tick)
            stored, dynamic_positions, diagonal = merged.keys, merged.extra, merged.diagonal
            entries = merged.rows, merged.cols
            fixed_targets = [merged.positions[index] for index in fixed.which]
        else:
            stored, fixed_targets, dynamic_positions, diagonal = self._sorted_merge(
                fixed, dynamic)
        nnz = len(stored)
        targets = []
        fixed_iter, dynamic_iter = iter(fixed_targets), iter(dynamic_positions)
        for index in range(len(self._jac_terms)):
            self._tick()
            targets.append(next(dynamic_iter) if self._jac_terms[index].dynamic
                           else next(fixed_iter))
        self._tick()
        # The targets stay per term (below), not joined into the pattern's.
        pattern = pattern_of_keys(stored, np.zeros(0, dtype=np.int64), n, entries)
        #: Jacobian sparsity pattern of the free coordinates (CSC, ones where J may be ≠ 0).
        self.pattern = pattern.matrix
        self.pattern_rows, self.pattern_cols = pattern.rows, pattern.cols
        self.nnz = nnz
        # Where each term's element entries land in the CSC data (nnz: a dump slot for
        # entries on fixed coordinates), one array per term with a Jacobian (terms on the
        # same coordinates share one).
        self._term_targets = targets
        self._jac_targets_joined: np.ndarray | None = None
        self.band = Band(*pattern.band)
        # Where the diagonal entries lie in the CSC data (one per column, in column order).
        self._diagonal_slots = diagonal
        self._fixed_pattern = fixed
        self._dynamic_blocks = blocks

    def _dynamic_blocks_of(self, dynamic: list[int]) -> list[_DynamicBlock]:
        """The blocks of the dynamic terms (indices in ``_jac_terms``), kept from the model
        this one was copied from for every term that is the same object on the same
        free-coordinate map."""
        kept = getattr(self, "_dynamic_blocks", [])
        blocks = []
        for position, index in enumerate(dynamic):
            term = self._jac_terms[index]
            old = kept[position] if position < len(kept) else None
            if old is not None and old.term is term and old.free_of is self._free_of:
                blocks.append(old)
                continue
            free = self._free_of[term.dofs]
            blocks.append(_DynamicBlock(term, self._free_of, free,
                                        *block_spread([free], self.n)))
        return blocks

    def _sorted_merge(self, fixed: _FixedBlocks, dynamic: list[int]) -> tuple[
            np.ndarray, list[np.ndarray], list[np.ndarray], np.ndarray]:
        """``_build_pattern``'s merge by sorting: the fixed terms' sorted keys (kept in
        ``fixed``) and the dynamic terms' keys. Returns (the stored keys, each fixed term's
        targets, each dynamic term's, the diagonal's slots)."""
        n = self.n
        if fixed.keys is None:
            fixed.keys = block_pattern(fixed.blocks, n, self._tick)
        fixed_keys, slots, diagonal = fixed.keys
        keys = [self._entry_keys(self._jac_terms[index]) for index in dynamic]
        if not keys:
            return fixed_keys, [slots[index] for index in fixed.which], [], diagonal
        stored = np.sort(np.concatenate([fixed_keys, *(k[k >= 0] for k in keys)]))
        stored = stored[np.concatenate([[True], stored[1:] != stored[:-1]])]
        nnz = len(stored)
        moved = np.append(np.searchsorted(stored, fixed_keys), nnz)  # a fixed key's slot
        self._tick()
        targets = [moved[slot] for slot in slots]
        return (stored, [targets[index] for index in fixed.which],
                [np.where(k >= 0, np.searchsorted(stored, k), nnz) for k in keys],
                moved[diagonal])

    @property
    def _jac_targets(self) -> np.ndarray:
        """Where every element entry of the terms with a Jacobian lands in the CSC data, in
        term order (nnz: the dump); joined from the terms' arrays when first asked for (the
        numpy path): the compiled path reads each term's own array."""
        if self._jac_targets_joined is None:
            self._jac_targets_joined = np.concatenate([np.zeros(0, dtype=np.int64),
                                                       *self._term_targets])
        return self._jac_targets_joined

    def _entry_keys(self, term: Term) -> np.ndarray:
        """Column-major keys ``col * n + row`` of every entry of a term's element blocks
        (row-major within each block), −1 for an entry on a fixed coordinate."""
        n = self.n
        k = term.dofs.shape[1]
        free = self._free_of[term.dofs]
        rows = np.repeat(free, k, axis=1).ravel()
        cols = np.tile(free, (1, k)).ravel()
        keys = cols * n + rows
        keys[(rows >= n) | (cols >= n)] = -1
        return keys

    def _fixed_blocks(self) -> _FixedBlocks:
        """The element blocks of the non-dynamic terms with a Jacobian, kept from the model
        this one was copied from when its terms and free-coordinate map are the same."""
        fixed_terms = tuple(t for t in self._jac_terms if not t.dynamic)
        cached = getattr(self, "_fixed_pattern", None)
        if (cached is not None and len(cached.terms) == len(fixed_terms)
                and all(a is b for a, b in zip(cached.terms, fixed_terms, strict=True))
                and (cached.free_of is self._free_of
                     or np.array_equal(cached.free_of, self._free_of))):
            return cached
        # Terms on the same coordinates (the tendons of one segment) share one computation.
        blocks: list[np.ndarray] = []
        which = []
        for term in fixed_terms:
            free = self._free_of[term.dofs]
            for index, seen in enumerate(blocks):
                if seen.shape == free.shape and np.array_equal(seen, free):
                    which.append(index)
                    break
            else:
                which.append(len(blocks))
                blocks.append(free)
            self._tick()
        return _FixedBlocks(fixed_terms, self._free_of, blocks, which,
                            *block_spread(blocks, self.n))

    def pattern_matrix(self, data: np.ndarray) -> sp.csc_matrix:
        """A CSC matrix with ``pattern``'s structure and the given data."""
        return sp.csc_matrix((data, self.pattern.indices, self.pattern.indptr),
                             shape=(self.n, self.n))
