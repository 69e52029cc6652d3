"""Direct equilibrium solve: Newton on F(x) = 0 with load and penalty continuation.

No pseudo-dynamics at all: this is the exact discrete equilibrium of the model, against
which the other integrators are scored (DESIGN §3–4). Each Newton step solves
J(x) Δx = −F(x) with the analytic Jacobian (band Cholesky, band LU or SuperLU:
rodsim/solvers/linear.py) and a backtracking line search
(rodsim/solvers/newton.py). If Newton does not converge at full load, the external
loads are applied in increments λ ∈ (0, 1] (load continuation), cutting the increment on
failure and growing it after easy steps.

Penalty continuation: when the centerline penalty dwarfs bending at the scale of a segment
(K_P l² / (E I) above ``penalty_ratio``), Newton from the rest state may converge only
linearly — a linear quaternion update leaves the penalty's constraint manifold by O(δ²),
which K_P amplifies. If load continuation has not converged within 20 × max_newton Newton
iterations, the loads are applied again with those penalties lowered to that ratio, which
are then raised tenfold per step back to their values, each step a short Newton solve from
the last (measured on Table 1, 100 g, K_P = 1e8: 31 Newton iterations in all, against no
convergence in 300 at full K_P).

A non-conservative model (the paper's tendon coupling) has no energy for the line search, and
there the stiff penalties are lowered from the start. Measured on table3-catheter1 (the
tendon's centerline penalty has K_P l²/(E I) = 6.8e9): at full K_P, load continuation took
227 Newton iterations — 90 in three failed 30-iteration attempts (load 1, 0.25, 0.5625),
54 in three struggling steps, and ~7 per step in 11 steps of 1/16, because Newton from the
last equilibrium converges only for load increments up to 1/16–1/8 (not 1/4); the analytic
Jacobian matches finite differences, so this is the geometry (the first Newton step raises
the residual 20–40×, mostly the stiff endpoint coupling K_C at the catheter tip). With the
penalty lowered first: 90 (75 loading, in steps of 1/4 after one failed attempt at full
load, then 15 raising K_P), on the same equilibrium to 1e-14 L. Tried and dropped: secant and
quadratic predictors across load steps, looser tolerances on intermediate steps, and
retracting the linear update onto the quaternion norm or the coupling's length (none cut
the iterations below ~80 at full K_P).

Quaternion norm: held by the centerline penalty Eq. (9) (|d3| = |q|²), as in the model.

Warm start (``initial_state``, rodsim/track.py): Newton at full load from the given state,
repeated while the registration changes; if that fails, the run starts over from rest with
the continuations above.
"""

from __future__ import annotations

import numpy as np

from rodsim.core.model import Model
from rodsim.core.schema import Parameter
from rodsim.solvers.base import Integrator, Outcome


class Static(Integrator):
    """Newton–Raphson with load continuation on F(x) = 0."""

    name = "static"
    summary = "Newton on F(x) = 0 with the analytic Jacobian and load continuation"
    quaternion_norm = "penalty Eq. (9) only (|d3| = |q|² is pulled to 1)"
    parameters = (
        Parameter("max_newton", "int", 30, "-", "Newton iterations per load step", 1, 10_000),
        Parameter("first_load_step", "float", 1.0, "-",
                  "first load increment (fraction of the full load)", 0.0, 1.0,
                  exclusive_minimum=True),
        Parameter("min_load_step", "float", 1e-4, "-",
                  "smallest load increment before giving up", 0.0, 1.0, exclusive_minimum=True),
        Parameter("penalty_ratio", "float", 1e3, "-",
                  "above this K_P l²/(E I), load with K_P lowered to it, then raise K_P "
                  "tenfold per step (penalty continuation)", 1.0, 1e300),
    )

    def advice(self) -> str:
        return ("try a smaller solver.static.first_load_step or min_load_step, or a "
                "pseudo-dynamic integrator (cvode)")

    def advance(self) -> Outcome:
        if self.warm:
            converged, x = self._newton_registered(self.start_state, True)
            if converged:
                return Outcome(x, True, "converged (warm start)")
            self.model = self.base_model
        base = self.base_model
        penalties = {k: self.options["penalty_ratio"] / term.penalty_ratio
                     for k, term in enumerate(base.terms)
                     if term.penalty and term.penalty_ratio > self.options["penalty_ratio"]}
        budget = 20 * self.options["max_newton"] if penalties else None
        # Without an energy to line-search on, Newton at full penalty first is not worth
        # trying: load with the penalties lowered straight away (module docstring).
        if base.conservative or not penalties:
            outcome = self._load_continuation(base, budget)
            if outcome.success or not penalties:
                return outcome
        # Stiff penalties: load with them lowered, then raise them tenfold per step.
        scales = dict(penalties)
        outcome = self._load_continuation(base.with_term_scales(scales), None)
        while outcome.success and min(scales.values()) < 1.0:
            scales = {k: min(1.0, 10.0 * scale) for k, scale in scales.items()}
            smallest = min(scales.values())
            # Same registration as reached, new penalty scales.
            self.model = self._with_registration_of(base.with_term_scales(scales))
            where = f"penalty scale {smallest:.3g}"
            self.check_budget(where)
            converged, x = self._newton_registered(outcome.x, smallest >= 1.0)
            self.counts["steps"] += 1
            self.checkpoint(x, where)
            if not converged:
                return Outcome(outcome.x, False, "Newton did not converge while raising the "
                               "penalty constants")
            outcome = Outcome(x, True, "converged")
        return outcome

    def _with_registration_of(self, model: Model) -> Model:
        """``model`` (same terms, other scales) with the registration of :attr:`model`."""
        terms = [current if current.dynamic else term
                 for current, term in zip(self.model.terms, model.terms, strict=True)]
        if all(a is b for a, b in zip(terms, model.terms, strict=True)):
            return model
        return model.with_terms(terms)

    def _load_continuation(self, model: Model, budget: int | None) -> Outcome:
        """Apply the loads to ``model`` in increments from its rest state and registration;
        give up after ``budget`` Newton iterations."""
        self.model = model
        counts = self.counts
        x = model.x0
        load, step = 0.0, self.options["first_load_step"]
        spent = 0
        # At full load the run ends once the registration settles (exact re-registration);
        # if a parent changes there, Newton goes on at full load from the same state.
        while load < 1.0 or not self.settled(x):
            if budget is not None and spent > budget:
                return Outcome(x, False, f"no equilibrium within {budget} Newton iterations")
            target = min(1.0, load + step)
            self.check_budget(f"load fraction {target:.4g}")
            converged, x_new, iterations = self._newton(x, target)
            spent += iterations
            if not converged:
                step *= 0.25
                if step < self.options["min_load_step"]:
                    return Outcome(x, False, f"Newton did not converge at load fraction "
                                   f"{target:.4g} and the load step fell below min_load_step")
                continue
            if self.reregister(x_new):
                x = x_new  # a tendon point changed parent: solve again at this load
                continue
            x, load = x_new, target
            counts["steps"] += 1
            self.checkpoint(x, f"load fraction {load:.4g}")
            self.history.record(load, x, self.residual(x))
            self.report(load, f"static: load {load:.3f}, {counts['newton_iters']} Newton "
                        "iterations")
            if iterations <= 6:
                step = min(1.0, 2.0 * step)
        return Outcome(x, True, "converged")

    def _newton_registered(self, x: np.ndarray, final: bool) -> tuple[bool, np.ndarray]:
        """Newton at full load, repeated from its result while the tendon registration
        changes (and, when ``final``, until it settles without hysteresis)."""
        while True:
            self.check_budget("full load")
            converged, x, _ = self._newton(x, 1.0)
            if not converged:
                return False, x
            if self.reregister(x):
                continue
            if not final or self.settled(x):
                return True, x

    def _newton(self, x: np.ndarray, load: float) -> tuple[bool, np.ndarray, int]:
        """Newton iterations at a fixed load, counted; returns (converged, x, iterations)."""
        converged, x, iterations = self.newton_equilibrium(
            x, load, self.options["max_newton"], f"load fraction {load:.4g}")
        self.counts["newton_iters"] += iterations
        self.counts["linear_solves"] += iterations
        return converged, x, iterations
