"""A scene's rods and terms assembled into F(x), its sparse Jacobian J(x) and the pattern:
``Model``.

The *full* state holds every coordinate of every rod (Eqs. 18 and 30); the supports
(rodsim/core/supports.py) fix some of them. Integrators only see the *free* coordinates
``x``: ``Model.force(x)`` and ``Model.jacobian(x)`` return the generalised force
F(x) = −∂E/∂x (plus non-conservative penalty forces) and ∂F/∂x on those. The sparsity
pattern is the union of the terms' element blocks, fixed when the model is built; the
Jacobian values are scattered into it with precomputed index maps.

The model's parts live beside it (rodsim/core/model_base.py lists them): the structure
(model_pattern.py), the state and its retraction (model_manifold.py), the evaluation through
the compiled kernels or the numpy reference (model_evaluation.py) and the scales
(model_scales.py). This module builds a model from a scene and derives the others from it.

A model never changes once built. What a solver varies is passed in or returned as a new
model: the load fraction is an argument of every evaluation; a penalty continuation scale is
a model built by ``Model.with_term_scales``; a tendon registration that changes gives a
new model from ``Model.reregistered`` (new element coordinates, so a new pattern); the
anchors of friction (the last converged equilibrium: contact's node positions,
rodsim/core/terms/contact.py; a string tendon's chord tensions,
rodsim/core/tendon_friction.py) give a new model from ``Model.anchored`` (same elements
and pattern).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from functools import cached_property
from typing import Literal, overload

import numpy as np

from rodsim.core.assembly_budget import AssemblyBudget
from rodsim.core.base_places import base_place
from rodsim.core.kernel_call import KernelCall
from rodsim.core.model_evaluation import EVALUATION_PATHS, KERNELS
from rodsim.core.model_pattern import Band
from rodsim.core.model_scales import ModelScales
from rodsim.core.rod.layout import RodLayout
from rodsim.core.rod.rod import Rod
from rodsim.core.scene import Scene
from rodsim.core.supports import node_supports
from rodsim.core.tendon import Tendon  # registers the tendon and joined rods' base places
from rodsim.core.terms import Term, registered_terms, term_class
from rodsim.core.terms._string_breaks import split_at_breaks

__all__ = ["Model", "Band", "EVALUATION_PATHS", "KERNELS", "KernelCall", "build_order",
           "scene_rod"]


def scene_rod(scene: Scene, name: str, layout: RodLayout, rods: Mapping[str, Rod]) -> Rod:
    """Rod ``name`` of ``scene`` at ``layout``, held by its base support where its base
    place puts it (``rodsim.core.base_places.base_place``: at its origin, at its catheter's
    lumen for a tendon rod, at its joint for a joined rod; ``rods`` must hold the place's
    ``parent``), with its sections; without the supports at other nodes."""
    support = base_place(scene, name).support(scene, name, rods)
    sections = tuple(scene.data["rods"][name].get("sections", ()))
    return Rod(name, scene.rods[name], layout, support, sections=sections)


def build_order(scene: Scene) -> list[str]:
    """The scene's rods in the order the model builds them (and places them in the state):
    each after the rod its base is placed on (``BasePlace.order``, stable over the scene's
    order)."""
    return sorted(scene.data["rods"], key=lambda n: base_place(scene, n).order(scene, n))


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


class Model(ModelScales):
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
        ``rodsim.core.assembly_budget.AssemblyBudgetExceeded`` is raised. None: no limit.
    """

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
        for name in build_order(scene):
            options = rods[name]
            layout = RodLayout(options.nodes, offset)
            rod = scene_rod(scene, name, layout, self.rods)
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
            base = scene.data["rods"][rod.name].get("base") or {}
            for key, values in rod.support.kind.terms(base):  # a support's energy, if any
                added = term_class(key, values)
                self.terms.append(added(rod, added.Options.of(values)))
                self.term_keys.append(("rods", rod.name, "base"))
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
        shared, and the scales are recomputed as ``Model.__init__`` computes them (the
        same numbers as ``with_scene``), the rest stiffness from the changed terms'
        shares alone (``_rest_diagonal``); a term that only takes new constants is
        made by ``Term.with_options`` (a string tendon's tension: its routing kept).
        Any other difference (rods, sections, supports, tendons' geometry, the evaluation
        path ``solver.kernels``, a term whose elements move) falls back to
        ``with_scene`` — or gives None when ``fallback`` is False. The other solver
        settings are the integrators', not the model's.

        A compiled model's kernel units are made first if they are not yet (a batch's
        shared model, never evaluated itself: rodsim/app/batch_job.py), so that every copy
        keeps their packed constants and stacked targets (rodsim/core/kernel_group.py)
        instead of making its own: ~0.4 ms of each tdcr-two-segment batch case."""
        if self._kernel_calls is not None and self._compiled():
            self._kernel_unit_list()
        made = self.terms_with_values(scene)
        if made is None:
            return self.with_scene(scene) if fallback else None
        other = copy.copy(self)
        other.scene = scene
        terms, changed = made
        if not changed:
            return other
        other._replace_terms(terms, changed)
        other._build_scales(layout=False)
        return other

    def terms_with_values(self, scene: Scene) -> tuple[list[Term], list[int]] | None:
        """The terms of ``with_values(scene)`` and the indices of those rebuilt (this
        model's own terms elsewhere), or None where ``with_values`` falls back to
        ``with_scene``."""
        changed = self._changed_terms(scene)
        if changed is None:
            return None
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
                return None
            terms[index] = term
        return terms, changed

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
        scene changed along one path, ``rodsim.app.inverse.parameter_keys.scene_with``)
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
        """A shallow copy without the memo of the last evaluation (``evaluate``): every
        derived model (other values, scales or registration) is a copy."""
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__)
        other._memo = []
        return other

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
        def anchored(term: Term, full: np.ndarray) -> Term:
            anchors = term.anchors_at(full)
            assert anchors is not None
            return term.anchored(anchors)

        terms, changed = self._replaced_anchor_terms(x, anchored)
        return self._with_replaced(terms, changed)

    def freed(self, x: np.ndarray) -> Model | None:
        """The model in which every point that broke loose at the equilibrium ``x`` (free
        coordinates) of this step slides with its kinetic friction (a string tendon with
        stiction: ``TendonString.freed``), the step's history otherwise kept: the step
        is solved again with it (rodsim/app/inverse/continuation.py), until nothing more
        breaks loose. ``None`` when nothing did (always without stiction)."""
        terms, changed = self._replaced_anchor_terms(x, lambda term, full: term.freed(full))
        return self._with_replaced(terms, changed) if changed else None

    def _replaced_anchor_terms(self, x: np.ndarray,
                               replace: Callable[[Term, np.ndarray], Term | None]
                               ) -> tuple[list[Term], list[int]]:
        """The terms with ``replace(term, full)`` in place of every term that holds anchors
        (where it gives a term; ``full`` the full coordinates of ``x``, made once), and the
        indices replaced: the walk ``anchored`` and ``freed`` share."""
        full = None
        terms = list(self.terms)
        changed = []
        for index, term in enumerate(terms):
            if term.anchor_positions() is None:
                continue
            if full is None:
                full = self.full(x)
            replaced = replace(term, full)
            if replaced is not None:
                terms[index] = replaced
                changed.append(index)
        return terms, changed

    def with_anchors_of(self, other: Model) -> Model:
        """This model with the friction anchors of ``other``, a model of the same layout
        (this scene at other values, ``with_values``): how a run in physical time
        carries friction's history from the model of one time to the model of the next
        (rodsim/app/programs.py). This model itself when no term holds anchors."""
        terms = list(self.terms)
        changed = []
        for index, (term, theirs) in enumerate(zip(self.terms, other.terms, strict=True)):
            anchored = _anchored_as(term, theirs)
            if anchored is not term:
                terms[index] = anchored
                changed.append(index)
        return self._with_replaced(terms, changed)

    def _with_replaced(self, terms: list[Term], changed: list[int]) -> Model:
        """A copy with ``terms`` (those at ``changed`` rebuilt on the same elements: other
        anchors), or this model itself when nothing changed."""
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
        (``with_supports_moved``)."""
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
        fixed coordinates keep (``rest_full``), so everything else is shared
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
        registration) in place of ``terms``.

        The order of the free coordinates is this model's, so its index map is shared, and
        so are the blocks of the terms that are the same objects (``_build_pattern``)
        and their kernel calls, which take the new pattern's targets
        (``_build_kernel_calls``)."""
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
        ``terms``) multiplied by the given factors — a penalty continuation step.

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

    # ------------------------------------------------------------- state maps
    # ------------------------------------------------------------ evaluation
