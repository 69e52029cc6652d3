"""Assemble a scene's rods and terms into F(x), its sparse Jacobian J(x) and the pattern.

The *full* state holds every coordinate of every rod (Eqs. 18 and 30); the supports
(rodsim/core/supports.py) fix some of them. Integrators only see the *free* coordinates
``x``: ``Model.force(x)`` and ``Model.jacobian(x)`` return the generalised force
F(x) = −∂E/∂x (plus non-conservative penalty forces) and ∂F/∂x on those. The sparsity
pattern is the union of the terms' element blocks, fixed when the model is built; the
Jacobian values are scattered into it with precomputed index maps.

Two evaluation paths compute the same numbers (``solver.kernels``): ``compiled`` (what
``auto``, the default, means for a model) calls each term's numba kernel
(:mod:`rodsim.core.kernels`), which accumulates straight into the force vector and the CSC
data; ``numpy`` calls the terms' vectorised numpy methods and scatters their element blocks —
the readable reference. ``tiered`` starts on numpy and moves to the compiled kernels once the
process's numpy evaluations have cost, nominally (never by the clock), what loading the
kernels would (:mod:`rodsim.core.kernel_tier`; what ``rodsim run`` uses for ``auto``).

A model never changes once built. What a solver varies is passed in or returned as a new
model: the load fraction is an argument of every evaluation; a penalty continuation scale is
a model built by :meth:`Model.with_term_scales`; a tendon registration that changes gives a
new model from :meth:`Model.reregistered` (new element coordinates, so a new pattern); the
anchors of friction (the last converged equilibrium: contact's node positions,
rodsim/core/terms/contact.py; a string tendon's chord tensions,
rodsim/core/tendon_friction.py) give a new model from :meth:`Model.anchored` (same elements
and pattern).
"""

from __future__ import annotations

import copy
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, Literal, NamedTuple, overload

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee

from rodsim.core.anchors import joined_support, joint_depth, scene_joints
from rodsim.core.assembly_budget import AssemblyBudget
from rodsim.core.kernel_tier import PROCESS_TIER, nominal_cost
from rodsim.core.rod.layout import RodLayout
from rodsim.core.rod.retraction import turn_segments
from rodsim.core.rod.rod import Rod
from rodsim.core.scene import Scene
from rodsim.core.sparsity import (
    BandBlocks,
    band_blocks,
    band_table_fits,
    block_pattern,
    block_spread,
    merge_placed,
    pattern_of_keys,
)
from rodsim.core.supports import base_support, node_supports, quaternion_product, rigid_motion
from rodsim.core.tendon import Tendon, tendon_support
from rodsim.core.terms import Term, registered_terms
from rodsim.core.terms.base import RodTerm
from rodsim.core.terms.tendon_string import split_at_breaks

if TYPE_CHECKING:
    from rodsim.core.kernels import Kernel

__all__ = ["Model", "Band", "EVALUATION_PATHS", "KERNELS", "KernelCall", "scene_rod"]

#: The two evaluation paths.
EVALUATION_PATHS = ("compiled", "numpy")
#: What ``solver.kernels`` may ask a model for (``auto`` is ``compiled`` for a model).
KERNELS = (*EVALUATION_PATHS, "tiered")
#: States whose evaluation a model remembers (:meth:`Model.evaluate`).
MEMO_STATES = 2
#: Largest Jacobian (stored entries) a model remembers (:meth:`Model.evaluate`): 8 MB each;
#: above, one evaluation's time matters less than the memory (F is always kept).
MEMO_ENTRIES = 1 << 20
#: Jacobians (stored entries) from this size on are accumulated into the array of the last
#: such evaluation once no one holds it any more (:func:`_jacobian_zeros`).
REUSE_ENTRIES = 1 << 20

#: The array of the last large Jacobian evaluation (:func:`_jacobian_zeros`).
_KEPT_JACOBIAN: np.ndarray | None = None


def _jacobian_zeros(size: int) -> np.ndarray:
    """Zeros of ``size`` for a Jacobian evaluation to accumulate into. From
    :data:`REUSE_ENTRIES` on, the array of the last such evaluation when nothing outside
    this function refers to it any more (its data, or any view of it, dropped by whoever
    got it): zeroing warm memory instead of faulting in fresh pages. On table1-50g at
    N = 100 000 (12.3 million entries, 98 MB) the first kernel writing into a fresh array
    took 25–267 ms in a static solve, where zeroing the kept one takes 14 ms and the kernel
    then 16 ms."""
    global _KEPT_JACOBIAN
    if size < REUSE_ENTRIES:
        return np.zeros(size)
    kept = _KEPT_JACOBIAN
    # References to a free array: the global, ``kept`` and getrefcount's argument. Any
    # other (a caller's array or view, another thread's ``kept``) means it is in use.
    if kept is not None and kept.size == size and sys.getrefcount(kept) == 3:
        kept.fill(0.0)
        return kept
    _KEPT_JACOBIAN = out = np.zeros(size)
    return out


@dataclass(frozen=True)
class Band:
    """Lower and upper bandwidth of the Jacobian of the free coordinates."""

    lower: int
    upper: int


def scene_rod(scene: Scene, name: str, layout: RodLayout, rods: Mapping[str, Rod],
              joints: Mapping[str, Any] | None = None) -> Rod:
    """Rod ``name`` of ``scene`` at ``layout``, held by its base support (at its catheter's
    lumen for a tendon rod, at its joint for a joined rod: ``rods`` must hold that catheter
    or parent), with its sections; without the supports at other nodes. ``joints``:
    :func:`~rodsim.core.anchors.scene_joints` of the scene (read when None)."""
    options = scene.rods[name]
    tendons = scene.data["tendons"]
    joints = scene_joints(scene) if joints is None else joints
    if name in tendons:
        tendon = scene.tendons[name]
        support = tendon_support(rods[tendon.catheter], tendon, options.clamp)
    elif name in joints:
        support = joined_support(rods[joints[name].rod], joints[name].s)
    else:
        support = base_support(options.clamp, scene.base_options(name),
                               np.asarray(options.origin, dtype=float))
    sections = tuple(scene.data["rods"][name].get("sections", ()))
    return Rod(name, options, layout, support, sections=sections)


def _registered_as(term: Term, other: Term) -> Term:
    """The dynamic ``term`` with the registration of ``other`` (the same term of another
    model of the same layout)."""
    state = other.registration_state()
    if state is None:
        raise ValueError(f"dynamic term {other.name!r} has no registration state")
    return term.registered(state)


def _anchored_as(term: Term, other: Term) -> Term:
    """``term`` with the friction anchors of ``other`` (the same term of another model of
    the same layout) when both hold anchors; else ``term``."""
    mine, theirs = term.anchor_positions(), other.anchor_positions()
    if mine is None or theirs is None or mine.shape != theirs.shape:
        return term
    return term.anchored(theirs)


class KernelCall(NamedTuple):
    """How the compiled path evaluates one term (:meth:`Model._build_kernel_calls`)."""

    #: The term's index in :attr:`Model.terms` (its continuation scale's index).
    term_index: int
    term: Term
    #: The compiled kernel (rodsim/core/kernels/), its ``evaluate`` and ``energy``.
    kernel: Kernel
    #: The term's constants in the kernel's signature order
    #: (:meth:`rodsim.core.kernels.Kernel.bind`).
    arguments: tuple[Any, ...]
    #: Free-coordinate index of each element's force entry, shape (n_elem, k); n: a dump.
    force_target: np.ndarray
    #: CSC data slot of each element's Jacobian entry, shape (n_elem, k, k); nnz: a dump.
    jacobian_target: np.ndarray

    @property
    def evaluate(self) -> Any:
        """The kernel's ``evaluate``."""
        return self.kernel.evaluate

    @property
    def energy(self) -> Any:
        """The kernel's ``energy``, or None when the module has none."""
        return self.kernel.energy

    def with_term(self, term: Term) -> KernelCall:
        """This call for another term of the same kind and elements (new constants)."""
        return self._replace(term=term, arguments=self.kernel.bind(term.kernel_arguments()))


@dataclass
class _FixedBlocks:
    """The Jacobian pattern's part that a re-registration keeps (:meth:`Model._build_pattern`):
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
    """A dynamic term's element blocks as :meth:`Model._build_pattern` uses them, kept by the
    model re-registered from it while the term is the same object (at a re-registration,
    only the terms whose parents changed are new): the free-coordinate map of its blocks and
    their :func:`~rodsim.core.sparsity.block_spread`, and their slots in the band table
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


class Model:
    """The discretised rod system of one scene.

    Parameters
    ----------
    scene
        A validated scene; only the terms it lists are built.
    kernels
        ``"compiled"``, ``"numpy"`` or ``"tiered"`` (default: the scene's
        ``solver.kernels``; its ``"auto"`` is ``"compiled"`` here).
    budget
        A wall-time budget for the assembly (rodsim/core/assembly_budget.py), checked between
        its phases and between the terms of its per-term loops: once spent,
        :class:`~rodsim.core.assembly_budget.AssemblyBudgetExceeded` is raised. None: no limit.
    """

    #: How the compiled path calls each term's kernel; built at the first compiled call.
    _kernel_calls: list[KernelCall] | None
    #: The calls of the model a re-registration came from (:meth:`with_terms`), with the
    #: index map they were built on, for :meth:`_build_kernel_calls` to keep.
    _kept_calls: tuple[np.ndarray, list[KernelCall]] | None
    #: The last evaluations, newest first: (state, load, F or None, ∂F/∂x data or None);
    #: see evaluate().
    _memo: list[tuple[np.ndarray, float, np.ndarray | None, np.ndarray | None]]

    def __init__(self, scene: Scene, kernels: str | None = None,
                 budget: AssemblyBudget | None = None) -> None:
        requested = kernels or scene.solver.kernels
        self.kernels = "compiled" if requested == "auto" else requested
        if self.kernels not in KERNELS:
            raise ValueError(f"kernels {self.kernels!r}: allowed {', '.join(KERNELS)}")
        self._budget = budget
        try:
            self._assemble(scene)
            self._tick()
            if len(self.rods) > 1:
                self._order_for_band()
                self._tick()
            self._build_maps()
            self._tick()
            self._build_scales()
        finally:
            self._budget = None  # the budget covers this assembly only, not later copies

    def _tick(self) -> None:
        """Check the assembly's wall-time budget, if any (see ``budget``)."""
        budget = getattr(self, "_budget", None)
        if budget is not None:
            budget.check()

    def _assemble(self, scene: Scene) -> None:
        """Rods, terms, tendons, the rest state and the free coordinates (in full-state order)
        of ``scene``."""
        self.scene = scene
        tendons = scene.tendons
        self.rods: dict[str, Rod] = {}
        offset = 0
        # Catheters first, so a tendon's base can be placed in its catheter's lumen; a rod
        # joined to another after it, so its base can be placed at the joint.
        rods = scene.rods
        joints = scene_joints(scene)
        for name in sorted(rods, key=lambda n: (n in tendons, joint_depth(n, joints))):
            options = rods[name]
            layout = RodLayout(options.nodes, offset)
            rod = scene_rod(scene, name, layout, self.rods, joints)
            tables = scene.support_tables(name)
            if tables:
                rod = Rod(name, options, layout, rod.support, node_supports(
                    options.nodes, options.length, rod.rest_positions(),
                    rod.base_quaternion, tables),
                    rod.sections)
            self.rods[name] = rod
            offset += layout.size
            self._tick()
        self.rods = {name: self.rods[name] for name in rods}
        self.full_size = offset
        catalogue = registered_terms()
        self.terms: list[Term] = []
        #: (``"rods"``, ``"tendons"`` or a term's ``scene_table``, owner's name, term key) of
        #: each term, in order.
        self.term_keys: list[tuple[str, str, str]] = []
        for rod in self.rods.values():
            for term_name in rod.options.terms:
                kind = scene.term_type("rods", rod.name, term_name)
                self.terms.append(kind(rod, scene.term_options("rods", rod.name, term_name),
                                       *((self.rods,) if kind.joins_rods else ())))
                self.term_keys.append(("rods", rod.name, term_name))
                self._tick()
        #: The scene's tendons (lumen geometry shared by their coupling terms).
        self.tendons = {name: Tendon.of(name, self.rods, table)
                        for name, table in tendons.items()}
        for name, table in tendons.items():
            for term_name in table.terms:
                self.terms.append(scene.term_type("tendons", name, term_name)(
                    self.tendons[name], scene.term_options("tendons", name, term_name)))
                self.term_keys.append(("tendons", name, term_name))
                self._tick()
        for kind in catalogue.values():  # terms built from a top-level table (obstacles)
            if not kind.scene_table:
                continue
            for name, table in scene.data.get(kind.scene_table, {}).items():
                for key, term in kind.from_table(name, table, self.rods):
                    self.terms.append(term)
                    self.term_keys.append((kind.scene_table, name, key))  # changes: new model
        split_at_breaks(self.terms)
        for term in self.terms:
            if term.penalty and not (isinstance(getattr(term, "penalty_ratio", None), float)
                                     and 0.0 < term.penalty_ratio < np.inf):
                raise TypeError(f"penalty term {term.name!r} must set a finite positive float "
                                "penalty_ratio (rodsim/core/terms/base.py)")
        #: Factor on each term's output: 1, or a penalty continuation scale.
        self._memo = []
        self.term_scales = np.ones(len(self.terms))
        self._scale_list = self.term_scales.tolist()  # as floats, for the evaluation loops

        self.rest_full = np.zeros(self.full_size)
        #: The rest state the free coordinates are offsets from (docs/model.md, "The offset
        #: state and the residual floor"): every rod's rest positions and rest quaternions.
        self.reference = np.zeros(self.full_size)
        fixed = []
        for rod in self.rods.values():
            self.rest_full[rod.layout.position_index] = rod.held_positions()
            self.rest_full[rod.layout.quaternion_index] = rod.rest_quaternions()
            self.reference[rod.layout.position_index] = rod.rest_positions()
            self.reference[rod.layout.quaternion_index] = rod.rest_quaternions()
            fixed.append(rod.fixed_index())
        #: :attr:`rest_full` as offsets from :attr:`reference` (non-zero only where a node
        #: support holds its node away from its rest place).
        self.rest_offsets = self.rest_full - self.reference
        is_free = np.ones(self.full_size, dtype=bool)
        is_free[np.concatenate(fixed)] = False
        #: Full-state index of every free coordinate, in the integrators' order.
        self.free = np.flatnonzero(is_free)
        self.n = len(self.free)

    def with_scene(self, scene: Scene) -> Model:
        """The model of ``scene`` — other parameter values on this model's discretisation —
        with this model's order of the free coordinates and the registration of its dynamic
        terms (tendon points keep their parents).

        Cheaper than ``Model(scene)`` followed by a re-registration: the band ordering is
        not recomputed, and the Jacobian pattern is reused when every term keeps its element
        coordinates (a changed load, modulus, penalty or tendon force). A tracking step's
        model (rodsim/app/inverse/track.py). Raises ValueError when ``scene`` changes the free
        coordinates (node counts, supports, rods or terms).
        """
        other = copy.copy(self)
        other._assemble(scene)
        names = [term.name for term in self.terms]
        if (other.full_size != self.full_size or other.n != self.n
                or not np.array_equal(other.free, np.sort(self.free))
                or [term.name for term in other.terms] != names):
            raise ValueError("the scene changes the model's layout (nodes, supports, rods or "
                             "terms): build a new Model")
        other.free = self.free
        other.terms = [_anchored_as(_registered_as(term, mine) if term.dynamic else term, mine)
                       for term, mine in zip(other.terms, self.terms, strict=True)]
        other.__dict__.pop("conservative", None)  # cached from this model's terms
        if all(np.array_equal(a.dofs, b.dofs)
               for a, b in zip(other.terms, self.terms, strict=True)):
            other._kernel_calls = None  # same pattern and index maps, new term constants
            other._build_force_scatter()
        else:
            other._build_maps()
        other._build_scales()
        return other

    @overload
    def with_values(self, scene: Scene, fallback: Literal[True] = True) -> Model: ...

    @overload
    def with_values(self, scene: Scene, fallback: bool) -> Model | None: ...

    def with_values(self, scene: Scene, fallback: bool = True) -> Model | None:
        """The model of ``scene`` when ``scene`` differs from this model's only in the
        options of some terms (a load, a tendon force, a penalty: a tracking or fitting
        step): those terms alone are rebuilt, with this model's registration; the rods,
        tendons, free-coordinate order, Jacobian pattern, index maps and loaded kernels are
        shared, and the scales are recomputed as :meth:`Model.__init__` computes them (the
        same numbers as :meth:`with_scene`), the rest stiffness from the changed terms'
        shares alone (:meth:`_rest_diagonal`); a term that only takes new constants is
        made by :meth:`Term.with_options` (a string tendon's tension: its routing kept).
        Any other difference (rods, sections, supports, tendons' geometry, the evaluation
        path ``solver.kernels``, a term whose elements move) falls back to
        :meth:`with_scene` — or gives None when ``fallback`` is False. The other solver
        settings are the integrators', not the model's."""
        changed = self._changed_terms(scene)
        if changed is None:
            return self.with_scene(scene) if fallback else None
        other = copy.copy(self)
        other.scene = scene
        if not changed:
            return other
        terms = list(self.terms)
        for index in changed:
            owner, name, term_name = self.term_keys[index]
            kind = scene.term_type(owner, name, term_name)
            options = scene.term_options(owner, name, term_name)
            known = self.terms[index]
            made = known.with_options(options) if type(known) is kind else None
            if made is not None:
                term = made  # its elements and registration kept
            elif owner == "rods":
                term = kind(self.rods[name], options,
                            *((self.rods,) if kind.joins_rods else ()))
            else:
                term = kind(self.tendons[name], options)
            if made is None and term.dynamic:
                term = _registered_as(term, self.terms[index])
            if (type(term) is not type(self.terms[index])
                    or term.has_jacobian != self.terms[index].has_jacobian
                    or term.is_load != self.terms[index].is_load
                    or term.conservative != self.terms[index].conservative
                    or not np.array_equal(term.dofs, self.terms[index].dofs)):
                return self.with_scene(scene) if fallback else None
            terms[index] = term
        other._replace_terms(terms, changed)
        other._build_scales(layout=False)
        return other

    def _replace_terms(self, terms: list[Term], changed: list[int]) -> None:
        """Take ``terms`` (this model's, those at ``changed`` rebuilt with the same elements:
        new constants or anchors), with the same kernels and targets (this model is a fresh
        copy of the one the terms came from)."""
        self.terms = terms
        self._loads = [t for t in terms if t.is_load]
        self._jac_terms = [t for t in terms if t.has_jacobian]
        if self._kernel_calls is not None:
            calls = list(self._kernel_calls)
            for index in changed:
                calls[index] = calls[index].with_term(terms[index])
            self._kernel_calls = calls

    def _changed_terms(self, scene: Scene) -> list[int] | None:
        """Indices of the terms whose options differ between this model's scene and
        ``scene``; None when anything else differs. Tables shared by the two scenes (a
        scene changed along one path, :func:`rodsim.app.inverse.parameter_keys.scene_with`)
        are skipped without comparing them."""
        mine, theirs = self.scene.data, scene.data
        if mine is theirs:
            return []
        if mine.keys() != theirs.keys():
            return None
        changed: set[tuple[str, str, str]] = set()
        for key in mine:
            if mine[key] is theirs[key]:
                continue
            if key == "solver":  # the model reads only the evaluation path
                if self.scene.solver.kernels != scene.solver.kernels:
                    return None
                continue
            if key not in ("rods", "tendons"):
                if mine[key] != theirs[key]:
                    return None
                continue
            owners, others = mine[key], theirs[key]
            if owners.keys() != others.keys():
                return None
            for name in owners:
                table, other = owners[name], others[name]
                if table is other:
                    continue
                if table.keys() != other.keys() or table.get("terms") != other.get("terms"):
                    return None
                listed = set(table.get("terms", ()))
                for entry in table:
                    if table[entry] is other[entry] or table[entry] == other[entry]:
                        continue
                    if entry not in listed:
                        return None  # a rod's or a tendon's own value
                    changed.add((key, name, entry))
        return [index for index, key in enumerate(self.term_keys) if key in changed]

    # ------------------------------------------------------------------ setup
    def __copy__(self) -> Model:
        """A shallow copy without the memo of the last evaluation (:meth:`evaluate`): every
        derived model (other values, scales or registration) is a copy."""
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__)
        other._memo = []
        return other

    def _build_maps(self) -> None:
        self._memo = []
        self._free_of = np.full(self.full_size, self.n)  # fixed -> dump slot n
        self._free_of[self.free] = np.arange(self.n)
        self._build_force_scatter()
        self._tick()
        self._build_pattern()
        self._kernel_calls = None
        self._kept_calls = None

    def _order_for_band(self) -> None:
        """Reorder the free coordinates (reverse Cuthill–McKee) when that narrows the band.

        Coupled rods concatenated as in Eq. (30) give a wide band (a tendon point couples to
        catheter coordinates far away in the vector); interleaving them keeps the system
        banded. The order is fixed once, from the pattern at rest (:meth:`_rest_structure`,
        the structure of :attr:`pattern` in the scene's order), before the index maps are
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
        """The Jacobian's structure at rest in the current order of :attr:`free` (canonical
        CSC, the structure :meth:`_build_pattern` gives): the diagonal and, for every term
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

    def reregistered(self, x: np.ndarray, exact: bool = False) -> Model | None:
        """The model with every dynamic term (tendon registration, §4.1) re-registered from
        the state ``x`` (``exact``: without hysteresis, as at equilibrium), or None when no
        registration changes.

        The new model has new element coordinates and so a new Jacobian pattern; the order
        of the free coordinates, the scales and everything else are shared.
        """
        full = self.full(x)
        terms = list(self.terms)
        changed = False
        compiled = self._compiled()
        for k, term in enumerate(terms):
            if term.dynamic:
                state = term.registration(full, exact, compiled)
                if state is not None:
                    terms[k] = term.registered(state)
                    changed = True
        return self.with_terms(terms) if changed else None

    def anchored(self, x: np.ndarray) -> Model:
        """The model with every path-dependent term's anchors (friction: contact,
        rodsim/core/terms/contact.py; a string tendon, rodsim/core/tendon_friction.py) set
        from the state ``x`` (free coordinates): what a
        track, a fit or a reach applies to the model of a converged equilibrium before it
        solves the next step (rodsim/app/inverse/continuation.py), so that friction opposes
        the slip since that equilibrium. The elements, the Jacobian pattern and the scales
        are unchanged; this model itself when no term holds anchors (no friction)."""
        full = None
        terms = list(self.terms)
        changed = []
        for index, term in enumerate(terms):
            if term.anchor_positions() is None:
                continue
            if full is None:
                full = self.full(x)
            anchors = term.anchors_at(full)
            assert anchors is not None
            terms[index] = term.anchored(anchors)
            changed.append(index)
        if not changed:
            return self
        other = copy.copy(self)
        other._replace_terms(terms, changed)
        return other

    @cached_property
    def support_displacements(self) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], ...]:
        """(full-state indices of its node's position, the rest place, the prescribed place)
        of every node support that moves its node from its rest place
        (``[rods.<rod>.supports.<name>] displacement`` ≠ 0, rodsim/core/supports.py): a
        prescribed displacement, which ``static`` applies in increments with the loads
        (:meth:`with_supports_moved`)."""
        moved = []
        for rod in self.rods.values():
            rest = rod.rest_positions()
            for support in rod.node_supports:
                if np.any(support.position != rest[support.node]):
                    moved.append((rod.layout.position_index[support.node], rest[support.node],
                                  support.position))
        return tuple(moved)

    def with_supports_moved(self, fraction: float) -> Model:
        """The model with every node support's prescribed displacement (the scene's) scaled
        by ``fraction`` (0: the nodes held at their rest places; 1: at their prescribed
        places, exactly). A support's displacement enters the model only as the value its
        fixed coordinates keep (:attr:`rest_full`), so everything else is shared
        (tests/test_supports.py checks F and J against the model built from the scaled
        scene)."""
        other = copy.copy(self)
        other.rest_full = self.rest_full.copy()
        other.rest_offsets = self.rest_offsets.copy()
        for index, rest, held in self.support_displacements:
            other.rest_full[index] = held if fraction == 1.0 else rest + fraction * (held - rest)
            other.rest_offsets[index] = fraction * (held - rest)
        return other

    def with_terms(self, terms: list[Term]) -> Model:
        """The model with ``terms`` (same names and order; a dynamic term may carry another
        registration) in place of :attr:`terms`.

        The order of the free coordinates is this model's, so its index map is shared, and
        so are the blocks of the terms that are the same objects (:meth:`_build_pattern`)
        and their kernel calls, which take the new pattern's targets
        (:meth:`_build_kernel_calls`)."""
        other = copy.copy(self)
        other.terms = list(terms)
        other._memo = []
        other._build_force_scatter()
        other._tick()
        other._build_pattern()
        if self._kernel_calls is not None:
            other._kept_calls = self._free_of, self._kernel_calls
        other._kernel_calls = None
        return other

    def with_term_scales(self, scales: Mapping[int, float]) -> Model:
        """The model with the output of the terms ``scales`` names (by index in
        :attr:`terms`) multiplied by the given factors — a penalty continuation step.

        Only penalty terms may be scaled: they are linear in their constant."""
        factors = self.term_scales.copy()
        for index, scale in scales.items():
            if not self.terms[index].penalty:
                raise ValueError(f"term {self.terms[index].name!r} is not a penalty")
            factors[index] = scale
        other = copy.copy(self)
        other.term_scales = factors
        other._scale_list = factors.tolist()
        return other

    @cached_property
    def conservative(self) -> bool:
        """True when every term is −∇ of its energy (F = −∇E: the Jacobian is symmetric and
        Newton may line-search on the energy)."""
        return all(term.conservative for term in self.terms)

    @cached_property
    def has_registration(self) -> bool:
        """True when some term registers its elements to the state (a tendon's lumen)."""
        return any(term.dynamic for term in self.terms)

    def _build_force_scatter(self) -> None:
        self._loads = [t for t in self.terms if t.is_load]
        self._force_targets = np.concatenate([self._free_of[t.dofs.ravel()]
                                              for t in self.terms])

    def _build_pattern(self) -> None:
        """The Jacobian pattern: the diagonal (always stored) and every element entry of the
        terms with a Jacobian (entries on fixed coordinates dropped), in CSC order.

        A re-registration (:meth:`reregistered`) changes only the dynamic terms' elements:
        what the diagonal and the other terms give is kept from the model it came from
        (:meth:`_fixed_blocks`) and merged with the dynamic ones — in a band table where it
        is small against the entries (:func:`rodsim.core.sparsity.merged_pattern`),
        otherwise as sorted keys merged with the dynamic terms' by sorting. The pattern and
        the targets are those a sort of all entries gives
        (:func:`rodsim.core.sparsity.csc_pattern`)."""
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
        """:meth:`_build_pattern`'s merge by sorting: the fixed terms' sorted keys (kept in
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

    def _build_scales(self, layout: bool = True) -> None:
        """F_ref, L_ref, the residual weights and the round-off floor (below); ``layout``
        False keeps :attr:`is_quaternion` (a model of the same layout)."""
        x0 = self.x0
        full = self.full(x0)
        load = 0.0
        for term in self._loads:
            load += term.load_scale(full)
        rods = list(self.rods.values())
        fallback = max(r.bending_stiffness / r.length**2 for r in rods)
        moved = sum(rod.support_reaction_scale() for rod in rods)
        #: Force scale F_ref [N]: total external load, or max EI/L² for an unloaded scene;
        #: with node supports moved from their rest places, the larger of the loads plus
        #: their displacements' reaction scale (:meth:`Rod.support_reaction_scale`) and
        #: max EI/L².
        if moved > 0.0:
            self.force_scale = max(load + moved, fallback)
        else:
            self.force_scale = load if load > 0 else fallback
        #: Length scale L_ref [m]: the longest rod.
        self.length_scale = max(r.length for r in rods)
        if layout:
            is_quat = np.zeros(self.full_size, dtype=bool)
            for rod in rods:
                is_quat[rod.layout.quaternion_index] = True
            self.is_quaternion = is_quat[self.free]
        #: Per-coordinate weights of :meth:`residual`: 1/F_ref, or 1/(F_ref L_ref) for
        #: quaternion coordinates.
        self.residual_weight = np.where(
            self.is_quaternion, 1.0 / (self.force_scale * self.length_scale),
            1.0 / self.force_scale)
        self._tick()
        stiffness = np.abs(self._rest_diagonal(full, self.rest_offsets))
        #: |∂F_i/∂x_i| at rest, the stiffness of each coordinate on its own.
        self.rest_stiffness = stiffness
        #: Smallest scaled residual the model reliably reaches in double precision
        #: (:meth:`_roundoff`).
        self.residual_floor = float(32.0 * np.finfo(float).eps
                                    * np.max(self._roundoff() * self.residual_weight))

    def _roundoff(self) -> np.ndarray:
        """Per free coordinate, the round-off of F_i over eps: each term's |∂F_i/∂x_i| at
        rest (its share of :attr:`rest_stiffness`) times the size of the numbers its force
        is a difference of (docs/model.md, "The offset state and the residual floor").

        A term on the full state (springs and penalties between positions of size ~L) takes
        L_ref for positions and 1 for quaternions. A term on offsets (:attr:`Term.offsets`)
        takes the size of the offsets the loads make: on its rod, the displacement
        D = min(L, F_ref L³ / (3 E I)) (a cantilever's tip under F_ref, E I the least along
        the rod: a bound for loads that bend by a moment) and the quaternion change
        min(1, 1.5 D / L). The residual floor is 32 eps times the largest of these, weighted
        as the residual: the margin makes it reliably attainable (noise measured at
        converged states is below it; Newton iterations asked to go lower only stall)."""
        noise = np.zeros(self.n)
        for term, _scale, share in self._diagonal_shares.values():
            if term.offsets and isinstance(term, RodTerm):
                rod = term.rod
                displacement = min(rod.length, self.force_scale * rod.length**3
                                   / (3.0 * rod.smallest_bending_stiffness))
                turn = min(1.0, 1.5 * displacement / rod.length)
            else:
                displacement, turn = self.length_scale, 1.0
            noise += np.abs(share) * np.where(self.is_quaternion, turn, displacement)
        return noise

    def _rest_diagonal(self, full: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """The diagonal of ∂F/∂x at the full state ``full`` (the rest state), as the sum of
        the terms' shares in term order (a term on offsets, :attr:`Term.offsets`, evaluated
        at ``offsets``). Each term's share is kept with the term and its
        scale (:attr:`_diagonal_shares`) and recomputed only for a term or a scale that
        changed: a model of other values (:meth:`with_values`) evaluates the changed terms
        alone. (Summed by term, not accumulated in one pass, so that every model of the
        same terms gets the same numbers whichever terms it recomputed.)"""
        kept = getattr(self, "_diagonal_shares", None) or {}
        shares: dict[int, tuple[Term, float, np.ndarray]] = {}
        total = np.zeros(self.n)
        buffer = None
        targets = iter(self._term_targets)
        compiled = self._compiled()
        tiered = self._tiered_numpy()
        recomputed: list[Term] = []
        if compiled and self._kernel_calls is None:
            self._kernel_calls = self._build_kernel_calls()
        for index, term in enumerate(self.terms):
            if not term.has_jacobian:
                continue
            target = next(targets)
            scale = self._scale(index, term, 1.0)
            known = kept.get(index)
            if known is not None and known[0] is term and known[1] == scale:
                share = known[2]
            elif compiled:
                assert self._kernel_calls is not None
                call = self._kernel_calls[index]
                if buffer is None:
                    buffer = np.zeros(self.nnz + 1)
                if scale != 0.0:
                    call.kernel.evaluate(offsets if term.offsets else full,
                                         *call.arguments, scale, False, np.zeros(1),
                                         call.force_target, True, buffer,
                                         call.jacobian_target)
                share = buffer[self._diagonal_slots]
                buffer[call.jacobian_target.ravel()] = 0.0
                buffer[-1] = 0.0
            else:
                values = scale * term.element_jacobians(
                    offsets if term.offsets else full).ravel()
                share = np.bincount(target, weights=values,
                                    minlength=self.nnz + 1)[self._diagonal_slots]
                recomputed.append(term)
            shares[index] = term, scale, share
            total += share
            self._tick()
        if tiered:  # the numpy shares count toward the move to the compiled kernels
            PROCESS_TIER.charge(nominal_cost(recomputed, force=False, jacobian=True))
        self._diagonal_shares = shares
        return total

    # ------------------------------------------------------------- state maps
    @property
    def x0(self) -> np.ndarray:
        """The undeformed rest state (free coordinates): every simulation starts here.

        The free coordinates are offsets from the rest state (:attr:`reference`): a
        position's displacement from its rest place, a quaternion's difference from its rest
        quaternion (docs/model.md, "The offset state and the residual floor"); the rest
        state is zero. :meth:`full` gives the positions and quaternions themselves."""
        return self.rest_offsets[self.free].copy()

    def full(self, x: np.ndarray) -> np.ndarray:
        """Full state (fixed coordinates included) from the free coordinates: the
        positions [m] and quaternions themselves (:attr:`reference` plus the offsets)."""
        out = self.rest_full.copy()
        out[self.free] = self._reference_free() + x
        return out

    def _reference_free(self) -> np.ndarray:
        """:attr:`reference` at the free coordinates, kept for this model's ``free``."""
        kept = self.__dict__.get("_kept_reference")
        if kept is None or kept[0] is not self.free or kept[1] is not self.reference:
            kept = (self.free, self.reference, self.reference[self.free])
            self._kept_reference = kept
        return kept[2]

    def offsets(self, x: np.ndarray) -> np.ndarray:
        """The full state as offsets from :attr:`reference` (fixed coordinates included):
        what the terms with :attr:`Term.offsets` are evaluated on."""
        out = self.rest_offsets.copy()
        out[self.free] = x
        return out

    def state_of(self, full: np.ndarray) -> np.ndarray:
        """The free coordinates (offsets) of the full state ``full`` (positions and
        quaternions themselves, as :meth:`full` gives them): a warm start from a stored
        shape."""
        return full[self.free] - self._reference_free()

    def carried(self, x: np.ndarray, previous: Model) -> np.ndarray:
        """The state ``x`` of ``previous`` (a model of the same layout) with each rod moved
        rigidly as its base support moved from ``previous`` to this model (an inserted or
        turned base, rodsim/core/supports.py): the warm start of a step that moves the
        base. ``x`` itself when no support moved and both models have the same rest state
        (:attr:`reference`); otherwise the same positions and quaternions as offsets from
        this model's rest state."""
        full = None
        for name, rod in self.rods.items():
            motion = rigid_motion(previous.rods[name].support, rod.support)
            if motion is None:
                continue
            if full is None:
                full = previous.full(x)
            turn, q_turn, before, after = motion
            index = rod.layout.position_index
            full[index] = after + (full[index] - before) @ turn.T
            index = rod.layout.quaternion_index
            full[index] = quaternion_product(q_turn, full[index])
        if full is None:
            if previous.reference is self.reference or np.array_equal(previous.reference,
                                                                      self.reference):
                return x
            full = previous.full(x)
        return self.state_of(full)

    def positions(self, x: np.ndarray, rod: str) -> np.ndarray:
        """Control points of one rod, shape (N, 3) [m]."""
        return self.full(x)[self.rods[rod].layout.position_index]

    def pseudo_time_masses(self) -> np.ndarray:
        """Diagonal mass matrix M of the free coordinates for the pseudo-dynamics (Eq. 17)
        [kg or kg·m²]: the integrators' way to equilibrium, not the physical inertia
        (that is :mod:`rodsim.core.inertia`)."""
        full = np.zeros(self.full_size)
        for rod in self.rods.values():
            full[rod.layout.position_index] = rod.node_masses()[:, None]
            full[rod.layout.quaternion_index] = (
                rod.pseudo_time_quaternion_masses()[:, None])
        return full[self.free]

    def latent_stiffness(self) -> np.ndarray:
        """Per free coordinate [N/m or N·m], the stiffness the terms may add away from the
        rest state that :attr:`rest_stiffness` does not show (a contact that appears:
        :meth:`rodsim.core.terms.base.Term.latent_stiffness`), each term's times its scale;
        zeros for a model without such terms."""
        full = np.zeros(self.full_size)
        for index, term in enumerate(self.terms):
            latent = term.latent_stiffness()
            if latent is not None:
                coordinates, stiffness = latent
                np.add.at(full, coordinates, self._scale(index, term, 1.0) * stiffness)
        return full[self.free]

    # ------------------------------------------------------------ evaluation
    def _scale(self, index: int, term: Term, load: float) -> float:
        """Factor on one term's output: its continuation scale, times ``load`` for loads."""
        scale = self._scale_list[index]
        return scale * load if term.is_load else scale

    def energy(self, x: np.ndarray, load: float = 1.0) -> float:
        """Total potential energy [J] (raises if a term is not conservative)."""
        full = self.full(x)
        offsets = self.offsets(x)
        compiled = {}
        tiered = self._tiered_numpy()
        if self._compiled():
            if self._kernel_calls is None:
                self._kernel_calls = self._build_kernel_calls()
            compiled = {call.term_index: call for call in self._kernel_calls
                        if call.energy is not None and call.term.conservative}
        total = 0.0
        for index, term in enumerate(self.terms):
            if index in compiled:
                call = compiled[index]
                value = call.energy(offsets if term.offsets else full, *call.arguments)
            else:
                value = term.energy(offsets if term.offsets else full)
            if value is None:
                raise ValueError(f"term {term.name!r} is not conservative: no energy")
            total += self._scale(index, term, load) * value
        if tiered:
            PROCESS_TIER.charge(nominal_cost(self.terms, force=True, jacobian=False))
        return total

    def _compiled(self) -> bool:
        """Whether evaluations run the compiled kernels now: always on the ``compiled``
        path, on the ``tiered`` path once the process has moved to them."""
        return self.kernels == "compiled" or (self.kernels == "tiered"
                                              and PROCESS_TIER.compiled)

    def _tiered_numpy(self) -> bool:
        """Whether this evaluation is a ``tiered`` model's numpy evaluation, whose CPU counts
        toward the move to the compiled kernels (:mod:`rodsim.core.kernel_tier`)."""
        return self.kernels == "tiered" and not PROCESS_TIER.compiled

    def force(self, x: np.ndarray, load: float = 1.0) -> np.ndarray:
        """Generalised force F(x) on the free coordinates; loads are scaled by ``load``."""
        return self.evaluate(x, load, jacobian=False)[0]

    def jacobian_data(self, x: np.ndarray, load: float = 1.0) -> np.ndarray:
        """∂F/∂x as the data array of a CSC matrix with the pattern :attr:`pattern`."""
        return self.evaluate(x, load, force=False)[1]

    def evaluate(self, x: np.ndarray, load: float = 1.0, *, force: bool = True,
                 jacobian: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """F(x) and ∂F/∂x (CSC data in :attr:`pattern` order) in one pass; the one not asked
        for comes back empty.

        The last :data:`MEMO_STATES` evaluated states are remembered (∂F/∂x up to
        :data:`MEMO_ENTRIES`): asked again at the same state and load — a solve's checks
        after it converged evaluate F at the state its last Newton step reached (before a
        rejected polishing trial), the correction residual and the stability verdict ∂F/∂x
        at the same state — it returns copies of the same numbers instead of evaluating
        again."""
        same = None
        for entry in self._memo:
            if entry[1] == load and np.array_equal(entry[0], x):
                known_f, known_j = entry[2], entry[3]
                if (known_f is not None or not force) and (known_j is not None or not jacobian):
                    return (known_f.copy() if known_f is not None and force else np.zeros(0),
                            known_j.copy() if known_j is not None and jacobian else np.zeros(0))
                same = entry  # this state, without the part asked for now
                break
        f, j = self._evaluate(x, load, force, jacobian)
        kept_f, kept_j = (same[2], same[3]) if same is not None else (None, None)
        entry = (np.array(x, dtype=float), load, f.copy() if force else kept_f,
                 j.copy() if jacobian and self.nnz <= MEMO_ENTRIES else kept_j)
        self._memo = [entry] + [e for e in self._memo if e is not same][:MEMO_STATES - 1]
        return f, j

    def _evaluate(self, x: np.ndarray, load: float, force: bool,
                  jacobian: bool) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`evaluate` without the memo."""
        full = self.full(x)
        offsets = self.offsets(x)
        if self._compiled():
            return self._evaluate_compiled(full, offsets, load, force, jacobian)
        tiered = self._tiered_numpy()
        f: np.ndarray = np.zeros(0)
        j: np.ndarray = np.zeros(0)
        if force:
            values = [self._scale(k, term, load)
                      * term.element_forces(offsets if term.offsets else full).ravel()
                      for k, term in enumerate(self.terms)]
            f = np.bincount(self._force_targets, weights=np.concatenate(values),
                            minlength=self.n + 1)[:-1]
        if jacobian:
            blocks = [self._scale(k, term, load)
                      * term.element_jacobians(offsets if term.offsets else full).ravel()
                      for k, term in enumerate(self.terms) if term.has_jacobian]
            j = (np.bincount(self._jac_targets, weights=np.concatenate(blocks),
                             minlength=self.nnz + 1)[:-1] if blocks else np.zeros(self.nnz))
        if tiered:
            PROCESS_TIER.charge(nominal_cost(self.terms, force=force, jacobian=jacobian))
        return f, j

    def _evaluate_compiled(self, full: np.ndarray, offsets: np.ndarray, load: float,
                           force: bool, jacobian: bool) -> tuple[np.ndarray, np.ndarray]:
        if self._kernel_calls is None:
            self._kernel_calls = self._build_kernel_calls()
        f = np.zeros(self.n + 1 if force else 1)
        j = _jacobian_zeros(self.nnz + 1) if jacobian else np.zeros(1)
        for call in self._kernel_calls:
            scale = self._scale(call.term_index, call.term, load)
            if scale == 0.0:
                continue  # a load at load fraction 0 (or a term scaled away): adds only zeros
            call.kernel.evaluate(offsets if call.term.offsets else full, *call.arguments,
                                 scale, force, f, call.force_target, jacobian, j,
                                 call.jacobian_target)
        return (f[:-1] if force else np.zeros(0)), (j[:-1] if jacobian else np.zeros(0))

    def element_forces(self, index: int, full: np.ndarray) -> np.ndarray:
        """The forces on the elements of term ``index`` at the full state ``full``, shaped
        as its ``dofs`` (clamped coordinates included), with its continuation scale: by its
        compiled kernel on the compiled path, by its numpy reference otherwise (the same
        numbers to round-off, tests/test_kernels.py). A term evaluated on offsets
        (:attr:`Term.offsets`) gets ``full`` minus :attr:`reference`."""
        term = self.terms[index]
        scale = self._scale(index, term, 1.0)
        if term.offsets:
            full = full - self.reference
        if not self._compiled():
            return scale * term.element_forces(full)
        if self._kernel_calls is None:
            self._kernel_calls = self._build_kernel_calls()
        call = self._kernel_calls[index]
        slots = np.arange(term.dofs.size, dtype=np.int64).reshape(term.dofs.shape)
        out = np.zeros(term.dofs.size + 1)
        call.kernel.evaluate(full, *call.arguments, scale, True, out, slots, False,
                             np.zeros(1), call.jacobian_target)
        return out[:-1].reshape(term.dofs.shape)

    def _build_kernel_calls(self) -> list[KernelCall]:
        """The :class:`KernelCall` of every term: its kernel, its constants bound by name to
        the kernel's signature, and where each element's force and Jacobian entries land
        (slot n and nnz are dumps for clamped coordinates)."""
        from rodsim.core.kernels import load_kernel

        # A re-registered model (with_terms: the same index map) keeps the calls of the terms
        # that are the same objects, with the new pattern's targets.
        kept = None
        if self._kept_calls is not None and self._kept_calls[0] is self._free_of:
            kept = self._kept_calls[1]
        self._kept_calls = None
        calls = []
        targets = iter(self._term_targets)
        for index, term in enumerate(self.terms):
            elements, k = term.dofs.shape
            if term.has_jacobian:
                jacobian_target = np.ascontiguousarray(next(targets).reshape(elements, k, k))
            else:
                jacobian_target = np.zeros((0, 0, 0), dtype=np.int64)
            if kept is not None and kept[index].term is term:
                calls.append(kept[index]._replace(jacobian_target=jacobian_target))
                continue
            force_target = np.ascontiguousarray(self._free_of[term.dofs])
            kernel = load_kernel(term)
            calls.append(KernelCall(index, term, kernel, kernel.bind(term.kernel_arguments()),
                                    force_target, jacobian_target))
        return calls

    def jacobian(self, x: np.ndarray, load: float = 1.0) -> sp.csc_matrix:
        """∂F/∂x as a sparse CSC matrix (n × n)."""
        return self.pattern_matrix(self.jacobian_data(x, load))

    def pattern_matrix(self, data: np.ndarray) -> sp.csc_matrix:
        """A CSC matrix with :attr:`pattern`'s structure and the given data."""
        return sp.csc_matrix((data, self.pattern.indices, self.pattern.indptr),
                             shape=(self.n, self.n))

    @cached_property
    def _step_maps(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(full position indices of every rod's nodes, rod k in rows starts[k]:starts[k+1];
        those starts; free indices of the two points of every stiff link a term declares
        (:meth:`Term.rigid_links`: the endpoint coupling's catheter and tendon tips) whose
        six coordinates are all free)."""
        couplings = []
        for term in self.terms:
            for link in term.rigid_links():
                free = self._free_of[link]
                if np.all(free < self.n):
                    couplings.append(free)
        chains = [rod.layout.position_index for rod in self.rods.values()]
        starts = np.cumsum([0] + [len(index) for index in chains])
        return (np.ascontiguousarray(np.concatenate(chains), dtype=np.int64),
                starts.astype(np.int64),
                np.array(couplings, dtype=np.int64).reshape(-1, 6))

    @cached_property
    def _quaternion_chains(self) -> np.ndarray:
        """Full quaternion indices (segment, 4) of every rod, in the order of
        ``_step_maps``' chains: rod k in rows starts[k] − k:starts[k+1] − k − 1."""
        return np.ascontiguousarray(np.concatenate(
            [rod.layout.quaternion_index for rod in self.rods.values()]), dtype=np.int64)

    def _absolute(self, x: np.ndarray) -> np.ndarray:
        """The full state from free coordinates that hold the positions and quaternions
        themselves (not offsets): the retractions' own arithmetic."""
        out = self.rest_full.copy()
        out[self.free] = x
        return out

    def _retracted(self, method: Callable[[np.ndarray, np.ndarray], np.ndarray],
                   x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """A retraction ``method`` (on positions and quaternions themselves) applied to the
        offset state ``x``: x + dx plus the retraction's correction, or x + dx alone when
        the whole correction is within the round-off of the retraction's own arithmetic on
        positions (each rod walked from its base: ~N eps L). Taken there, it would put that
        round-off into offsets that resolve far below it; the correction is O(dx²) and that
        small only once the steps are (a Newton solve's last ones)."""
        absolute = self._reference_free() + x
        linear = absolute + dx
        correction = method(absolute, dx) - linear
        chain = max(rod.nodes for rod in self.rods.values())
        noise = (4.0 * chain * np.finfo(float).eps
                 * float(np.max(np.abs(absolute), initial=0.0) + np.max(np.abs(dx), initial=0.0)))
        if float(np.max(np.abs(correction), initial=0.0)) <= noise:
            return x + dx
        return x + dx + correction

    def turned_step(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """:meth:`step` with each rod's segments turned as rigid frames instead of their
        lengths kept (rodsim/core/rod/retraction.py; ``solver.static.retraction =
        "frames"``); the endpoint couplings as in :meth:`step`. Equal to x + dx to first
        order in dx (on the offset state: :meth:`_retracted`)."""
        return self._retracted(self._turned_absolute, x, dx)

    def _turned_absolute(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """:meth:`turned_step` on free coordinates that are positions and quaternions
        themselves. Compiled (``turn`` of rodsim/core/kernels/_retraction.py) with
        ``kernels = "compiled"``; this numpy code is the reference."""
        if self._compiled():
            from rodsim.core.kernels._retraction import turn

            chains, starts, couplings = self._step_maps
            y = x + dx
            turn(x, dx, y, self.rest_full, self._free_of, chains, starts,
                 self._quaternion_chains, couplings)
            return y
        before, after = self._absolute(x), self._absolute(x + dx)
        for rod in self.rods.values():
            position, quaternion = rod.layout.position_index, rod.layout.quaternion_index
            r, q = before[position], before[quaternion]
            after[position], after[quaternion] = turn_segments(
                r, q, after[position] - r, after[quaternion] - q,
                np.all(self._free_of[position] >= self.n, axis=1))
        y = after[self.free]
        for free in self._step_maps[2]:  # the endpoint couplings, as in step()
            tip, tendon_tip = free[:3], free[3:]
            edge = x[tendon_tip] - x[tip]
            length = float(np.linalg.norm(edge))
            if length > 0.0:
                predicted = length + float(edge @ (dx[tendon_tip] - dx[tip])) / length
                new_edge = y[tendon_tip] - y[tip]
                y[tendon_tip] = y[tip] + predicted * new_edge / np.linalg.norm(new_edge)
        return y

    def step(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """The state a Newton step ``dx`` from ``x`` reaches, with stiff lengths kept to first
        order (a retraction: equal to x + dx to first order in dx; on the offset state:
        :meth:`_retracted`, the arithmetic below on positions: :meth:`_step_absolute`)."""
        return self._retracted(self._step_absolute, x, dx)

    def _step_absolute(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """:meth:`step` on free coordinates that are positions and quaternions themselves.

        A linear step that turns a stiff link of fixed length stretches it by O(δ²), which the
        link's stiffness turns into a force far above the loads: on the paper's coupling the
        endpoint spring (K_C, rest length r_L, no tension at rest) and the catheter's segments
        (stretch and centerline penalty). Here each rod's segments, walked from its base, and
        then each endpoint coupling (the tendon tip about the catheter tip) keep the length
        the linearisation predicts, in the direction of the linear step's. Compiled
        (rodsim/core/kernels/_retraction.py) with ``kernels = "compiled"``; this numpy code is
        the reference.
        """
        chains, starts, couplings = self._step_maps
        y = x + dx
        if self._compiled():
            from rodsim.core.kernels._retraction import retract

            retract(x, dx, y, self.rest_full, self._free_of, chains, starts, couplings)
            return y
        before, after = self._absolute(x), self._absolute(y)
        for k in range(len(starts) - 1):
            index = chains[starts[k]:starts[k + 1]]
            r, moved = before[index], after[index]
            edges = np.diff(r, axis=0)
            length = np.linalg.norm(edges, axis=1)
            predicted = length + np.einsum("ij,ij->i", edges,
                                           np.diff(moved - r, axis=0)) / length
            new_edges = np.diff(moved, axis=0)
            new_edges *= (predicted / np.linalg.norm(new_edges, axis=1))[:, None]
            moved[1:] = moved[0] + np.cumsum(new_edges, axis=0)
            free = self._free_of[index]
            keep = free < self.n
            y[free[keep]] = moved[keep]
        for free in couplings:
            tip, tendon_tip = free[:3], free[3:]
            edge = x[tendon_tip] - x[tip]
            length = float(np.linalg.norm(edge))
            if length == 0.0:
                continue
            predicted = length + float(edge @ (dx[tendon_tip] - dx[tip])) / length
            new_edge = y[tendon_tip] - y[tip]
            y[tendon_tip] = y[tip] + predicted * new_edge / np.linalg.norm(new_edge)
        return y

    def residual(self, force: np.ndarray) -> float:
        """Scaled residual max_i |F_i| w_i: forces / F_ref, quaternion forces / (F_ref L_ref)."""
        return float(np.max(np.abs(force) * self.residual_weight))
