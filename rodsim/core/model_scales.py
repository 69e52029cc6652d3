"""The scales of a model: the force scale F_ref and length scale L_ref, the weights of the
scaled residual max_i |F_i| w_i, each coordinate's stiffness at rest, and the residual's
round-off floor (docs/model.md, "The offset state and the residual floor"); and the
diagonal masses of the pseudo-dynamics (Eq. 17)."""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.kernel_tier import PROCESS_TIER, nominal_cost
from rodsim.core.model_evaluation import ModelEvaluation
from rodsim.core.terms import Term
from rodsim.core.terms.base import RodTerm

__all__ = ["ModelScales"]


class ModelScales(ModelEvaluation):
    """The scales part of ``rodsim.core.model.Model`` (module docstring)."""

    #: Each term's share of the rest diagonal, with the term and scale it was computed for
    #: (:meth:`_rest_diagonal`).
    _diagonal_shares: dict[int, tuple[Term, float, np.ndarray]]

    def _build_scales(self, layout: bool = True) -> None:
        """F_ref, L_ref, the residual weights and the round-off floor (below); ``layout``
        False keeps ``is_quaternion`` (a model of the same layout)."""
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
        #: Per-coordinate weights of :meth:`force_residual`: 1/F_ref, or 1/(F_ref L_ref) for
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
        rest (its share of ``rest_stiffness``) times the size of the numbers its force
        is a difference of (docs/model.md, "The offset state and the residual floor").

        A term on the full state (springs and penalties between positions of size ~L) takes
        L_ref for positions and 1 for quaternions. A term on offsets (``Term.offsets``)
        takes the size of the offsets the loads make: on its rod, the displacement
        D = min(L, F_ref L³ / (3 E I)) (a cantilever's tip under F_ref, E I the least along
        the rod: a bound for loads that bend by a moment) and the quaternion change
        min(1, 1.5 D / L). The residual floor is 32 eps times the largest of these, weighted
        as the residual: the margin makes it reliably attainable (noise measured at
        converged states is below it; Newton iterations asked to go lower only stall)."""
        noise = np.zeros(self.n)
        sizes: dict[tuple[float, float], np.ndarray] = {}  # the same sizes: one array
        for term, _scale, share in self._diagonal_shares.values():
            if term.offsets and isinstance(term, RodTerm):
                rod = term.rod
                displacement = min(rod.length, self.force_scale * rod.length**3
                                   / (3.0 * rod.smallest_bending_stiffness))
                turn = min(1.0, 1.5 * displacement / rod.length)
            else:
                displacement, turn = self.length_scale, 1.0
            size = sizes.get((turn, displacement))
            if size is None:
                size = sizes[turn, displacement] = np.where(self.is_quaternion, turn,
                                                            displacement)
            noise += np.abs(share) * size
        return noise

    def _rest_diagonal(self, full: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """The diagonal of ∂F/∂x at the full state ``full`` (the rest state), as the sum of
        the terms' shares in term order (a term on offsets, ``Term.offsets``, evaluated
        at ``offsets``). Each term's share is kept with the term and its
        scale (``_diagonal_shares``) and recomputed only for a term or a scale that
        changed: a model of other values (``with_values``) evaluates the changed terms
        alone. A term whose force is a constant times a unit term's (``Term.linear_unit``:
        a frictionless string tendon's tension) takes the constant times the unit's share,
        found once per geometry and kept by the model's copies: a case of a batch or a
        tracking step of new tensions evaluates no tendon. (Summed by term, not accumulated
        in one pass, so that every model of the same terms gets the same numbers whichever
        terms it recomputed.)"""
        kept = getattr(self, "_diagonal_shares", None) or {}
        units = self._rest_units
        shares: dict[int, tuple[Term, float, np.ndarray]] = {}
        total = np.zeros(self.n)
        targets = iter(self._term_targets)
        tiered = self._tiered_numpy()
        recomputed: list[Term] = []
        if self._compiled() and self._kernel_calls is None:
            self._kernel_calls = self._build_kernel_calls()
        for index, term in enumerate(self.terms):
            if not term.has_jacobian:
                continue
            target = next(targets)
            scale = self._scale(index, term, 1.0)
            known = kept.get(index)
            linear = term.linear_unit()
            if known is not None and known[0] is term and known[1] == scale:
                share = known[2]
            elif linear is not None:  # c times the unit's share, found once per geometry
                key, coefficient, unit = linear
                found = units.get(index)
                if found is None or len(found[0]) != len(key) or any(
                        a is not b for a, b in zip(found[0], key, strict=True)):
                    found = units[index] = key, self._share(index, unit(), 1.0, target,
                                                            full, offsets, recomputed)
                share = (scale * coefficient) * found[1]
            else:
                share = self._share(index, term, scale, target, full, offsets, recomputed)
            shares[index] = term, scale, share
            total += share
            self._tick()
        if tiered:  # the numpy shares count toward the move to the compiled kernels
            PROCESS_TIER.charge(nominal_cost(recomputed, force=False, jacobian=True))
        self._diagonal_shares = shares
        return total

    def _share(self, index: int, term: Term, scale: float, target: np.ndarray,
               full: np.ndarray, offsets: np.ndarray, recomputed: list[Term]) -> np.ndarray:
        """Term ``term``'s share (at position ``index``, Jacobian slots ``target``) of the
        diagonal of ∂F/∂x at the rest state, times ``scale`` (``_rest_diagonal``); a term
        evaluated by its numpy reference is appended to ``recomputed``."""
        if self._compiled():
            assert self._kernel_calls is not None
            call = self._kernel_calls[index]
            if call.term is not term:
                call = call.with_term(term)
            buffer = np.zeros(self.nnz + 1)  # a string tendon writes 1.6-3.3 times nnz slots
            if scale != 0.0:
                call.kernel.evaluate(offsets if term.offsets else full, *call.arguments,
                                     scale, False, np.zeros(1), call.force_target, True,
                                     buffer, call.jacobian_target)
            return buffer[self._diagonal_slots]
        values = scale * term.element_jacobians(offsets if term.offsets else full).ravel()
        recomputed.append(term)
        return np.bincount(target, weights=values, minlength=self.nnz + 1)[self._diagonal_slots]

    @property
    def _rest_units(self) -> dict[int, Any]:
        """The rest-diagonal share of each linear term's unit (``Term.linear_unit``) by
        term position, with the objects it was found for, and at -1 the unloaded rest
        force (``unloaded_rest_force``): one dictionary shared by this model and every
        model copied from it (``with_values``: a new tension per case or step, the same
        routing), so each is found once."""
        units = self.__dict__.get("_rest_unit_shares")
        if units is None:
            units = self.__dict__["_rest_unit_shares"] = {}
        return units

    def unloaded_rest_force(self) -> np.ndarray:
        """F(x₀, load 0), the force of the unloaded rest state (``force(x0, 0.0)``, a copy).

        On the compiled path it is kept with what it was evaluated from — the terms whose
        output is not scaled away at load 0 (the same objects), their scales, the full and
        offset states of x₀ — in a dictionary that this model's copies share
        (``with_values``): a copy whose changed terms are all loads (a batch case's or a
        tracking step's tensions and forces) takes it again, the same numbers (the
        compiled path skips a unit scaled to 0 and adds nothing for it). Otherwise
        evaluated."""
        x0 = self.x0
        if not self._compiled():
            return self.force(x0, 0.0)
        active = tuple((term, scale) for index, term in enumerate(self.terms)
                       if (scale := self._scale(index, term, 0.0)) != 0.0)
        full, offsets = self.full(x0), self.offsets(x0)
        kept = self._rest_units.get(-1)
        if kept is not None:
            terms, known_full, known_offsets, force = kept
            if (len(terms) == len(active)
                    and all(a[0] is b[0] and a[1] == b[1]
                            for a, b in zip(terms, active, strict=True))
                    # np.array_equal's test without its Python wrapper
                    and known_full.shape == full.shape
                    and known_offsets.shape == offsets.shape
                    and bool((known_full == full).all())
                    and bool((known_offsets == offsets).all())):
                return force.copy()
        force = self.force(x0, 0.0)
        self._rest_units[-1] = active, full, offsets, force.copy()
        return force

    def force_residual(self, force: np.ndarray) -> float:
        """Scaled residual max_i |F_i| w_i: forces / F_ref, quaternion forces / (F_ref L_ref)."""
        return float((np.abs(force) * self.residual_weight).max())  # the method: no wrapper

    def pseudo_time_masses(self) -> np.ndarray:
        """Diagonal mass matrix M of the free coordinates for the pseudo-dynamics (Eq. 17)
        [kg or kg·m²]: the integrators' way to equilibrium, not the physical inertia
        (that is ``rodsim.core.inertia``)."""
        full = np.zeros(self.full_size)
        for rod in self.rods.values():
            full[rod.layout.position_index] = rod.node_masses()[:, None]
            full[rod.layout.quaternion_index] = (
                rod.pseudo_time_quaternion_masses()[:, None])
        return full[self.free]

    def latent_stiffness(self) -> np.ndarray:
        """Per free coordinate [N/m or N·m], the stiffness the terms may add away from the
        rest state that ``rest_stiffness`` does not show (a contact that appears:
        ``rodsim.core.terms.base.Term.latent_stiffness``), each term's times its scale;
        zeros for a model without such terms."""
        full = np.zeros(self.full_size)
        for index, term in enumerate(self.terms):
            latent = term.latent_stiffness()
            if latent is not None:
                coordinates, stiffness = latent
                np.add.at(full, coordinates, self._scale(index, term, 1.0) * stiffness)
        return full[self.free]
