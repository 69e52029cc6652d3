"""Direct equilibrium solve: Newton on F(x) = 0 with load and penalty continuation.

No pseudo-dynamics at all: this is the exact discrete equilibrium of the model, against
which the other integrators are scored (docs/design.md §3–4). Each Newton step solves
J(x) Δx = −F(x) with the analytic Jacobian (band Cholesky, band LU or SuperLU:
rodsim/solvers/linear.py) and a backtracking line search
(rodsim/solvers/newton.py). If Newton does not converge at full load, the external
loads are applied in increments λ ∈ (0, 1] (load continuation), cutting the increment on
failure and growing it after easy steps. Newton steps through the retraction
:meth:`Model.step` (below).

Penalty continuation: when the centerline penalty dwarfs bending at the scale of a segment
(K_P l² / (E I) above ``penalty_ratio``), Newton from the rest state may converge only
linearly — a linear quaternion update leaves the penalty's constraint manifold by O(δ²),
which K_P amplifies. The loads are then applied with those penalties lowered to that ratio,
which are then raised back to their values (at once; tenfold per step if that fails), each
step a short Newton solve from the last. On a conservative model this used to be a fallback
after 20 × max_newton Newton iterations at the full penalties; going there straight away
was measured on the same equilibria (≤ 1.3e-15 m apart): table1-100g with K_P = 1e8
748 → 131 iterations (582 → 21 ms), at N = 160 1405 → 786, K_P = 1e6 276 → 255,
tendon-conserving 17 → 14, four-tendons 6 → 4; scenes without stiff penalties (Table 1 at
its K_P) are not affected.

A non-conservative model (the paper's tendon coupling) has no energy for the line search, and
there the stiff penalties were lowered from the start already. Measured on table3-catheter1 (the
tendon's centerline penalty has K_P l²/(E I) = 6.8e9): at full K_P, load continuation took
227 Newton iterations; with the penalty lowered first and raised tenfold per step, 88 — 30
in a failed attempt at full load, 44 loading in steps of 1/4 and 1/2 (15, 10 + 3 after a
re-registration, 16), 14 raising K_P (7 steps of 2: one Newton step and one polishing
iteration that gains nothing); no line-search backtracking outside the failed attempt.

Where those iterations went: a linear Newton step that turns a stiff link of fixed length
stretches it by O(δ²). The endpoint coupling (K_C, a spring of rest length r_L with no
tension at rest) gave residuals 20–40× the loads after the first step, the catheter's
segments (stretch and the centerline penalty) after later ones. Newton now steps through
the retraction :meth:`Model.step` (each segment and the coupling keep the length the
linearisation predicts), which converges a load step of 1/4 in 6 iterations (14 before).
With it, on table3-catheter1 (catheter2, catheter3; tendon-conserving): 29 (29, 29; 17, 14
since the conserving scene also loads with its penalties lowered) iterations, against 88
(86, 83; 21) — on the same equilibria to 1e-14 L:

- retraction of the coupling alone: 42 → 30 (the segments' retraction: 30 → 29, and 20 → 17
  on tendon-conserving);
- a non-conservative model loaded with lowered penalties starts at a load step of
  :data:`NONCONSERVATIVE_FIRST_STEP` = 1/4: the attempt at full load fails in 30 iterations
  (the watchdog returns to the start six times), and 1/2 and 1/8 were measured worse on
  catheter1 (64 / 37);
- the penalties are raised to their values in one step (2–3 iterations from the lowered
  equilibrium, which is next to the full one); tenfold steps only if that fails;
- intermediate solves are not polished past the tolerance; only the last one is.

Tried and dropped: retracting the quaternions onto the norm the linearisation predicts (worse:
66–104 iterations, the direction error of the linear quaternion update remains); secant and
quadratic predictors across load steps, and looser tolerances on intermediate steps (at full
K_P, before the penalty lowering).

``retraction = "frames"`` (opt-in; the default "lengths" is the retraction above, which
every shipped scene's stored equilibrium was computed with): each segment turns as a rigid
frame (:meth:`Model.turned_step`, rodsim/core/rod/retraction.py). With the default, Newton
crept on tdcr-two-segment: a linear step leaves q off the rotations (|q + Δq|² = |q|² +
|Δq|²) and turns each edge by atan θ instead of θ, so edge and d3 disagree at O(θ³), which
the centerline penalty (K_P l²/(E I) = 139) turns into forces: the energy line search
rejected every other full step (half steps accepted, the energy falling by 1e-3 per
iteration), the attempt at full load ran out of iterations, and load steps of 1/4 followed.
Measured (static, CPU, the six tdcr cases of ``rodsim bench string-tendon``): Newton
iterations 22, 96, 30, 16, 13, 98 → 5, 6, 6, 5, 5, 6; time 40–142 → 31–37 ms, of which the
model's assembly is about 22 ms. Same equilibria within 4.8e-10 m (the residual floor of
tdcr: 1.2e-9 L); on the other shipped scenes 14/19/11/15/14 → 8/7/5/6/10 iterations
(catheter-pull-ring, table1-100g/20g/50g, tendon-conserving), table3's paper coupling
29/29/29 → 26/25/30 and four-tendons 4 → 5 (the numpy retraction then costs more than the
iterations save: 21 → 29–42 ms), equilibria within 1e-15 m.

Quaternion norm: held by the centerline penalty Eq. (9) (|d3| = |q|²), as in the model.

Warm start (``initial_state``, rodsim/app/inverse/track.py): Newton at full load from the
given state, repeated while the registration changes; if that fails, the run starts over from
rest with the continuations above.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.model import Model
from rodsim.core.schema import Parameter
from rodsim.solvers.base import Integrator, Outcome
from rodsim.solvers.newton import NewtonProblem, newton
from rodsim.solvers.penalties import DEFAULT_PENALTY_RATIO, penalty_scales, with_registration_of
from rodsim.solvers.run_state import MAX_SETTLES, RunState

#: First load increment of a non-conservative model loaded with its penalties lowered (when
#: ``first_load_step`` is larger): see the module docstring.
NONCONSERVATIVE_FIRST_STEP = 0.25
#: ``retraction`` choices: :meth:`Model.step` (the default, every shipped scene's numbers)
#: or :meth:`Model.turned_step`.
RETRACTIONS = ("lengths", "frames")
#: Chord iterations (kept factorisation) a continuation step tries before Newton.
MAX_CHORD = 10
#: Newton iterations a continuation step may take (per registration), whatever
#: ``max_newton`` (the budget of a cold load step) says: a step that needs more is retried
#: smaller by the caller.
CONTINUATION_NEWTON = 30


@dataclass(eq=False, kw_only=True)
class StaticState(RunState):
    """A static run's state, with the factorisation a continuation step keeps: (the
    Jacobian pattern it belongs to, its solve), or None."""

    factor: tuple[Any, Callable[[np.ndarray], np.ndarray]] | None = None


class Static(Integrator[StaticState]):
    """Newton–Raphson with load continuation on F(x) = 0."""

    State = StaticState
    takes_predictor = True

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
        Parameter("penalty_ratio", "float", DEFAULT_PENALTY_RATIO, "-",
                  "above this K_P l²/(E I), load with K_P lowered to it, then raise K_P "
                  "tenfold per step (penalty continuation)", 1.0, 1e300),
        Parameter("retraction", "str", "lengths", "-",
                  "how a Newton step moves the rods: 'lengths' (segment lengths kept) or "
                  "'frames' (segments turned as rigid frames: far fewer iterations when "
                  "segments turn a lot, rodsim/core/rod/retraction.py)",
                  choices=RETRACTIONS),
    )

    def advice(self, run: RunState | None = None) -> str:
        if run is not None and run.continued:
            return "try smaller parameter steps (the last equilibrium is too far away)"
        return ("try a smaller solver.static.first_load_step or min_load_step, or a "
                "pseudo-dynamic integrator (cvode)")

    @classmethod
    def work(cls, stats: dict[str, float]) -> int:
        return int(stats["newton_iters"] + stats.get("chord_iters", 0))

    def carry(self, previous: RunState, state: StaticState) -> None:
        """A continuation step keeps the factorisation and the linear solver of the last
        step while the Jacobian pattern is the same."""
        if isinstance(previous, StaticState):
            state.factor = previous.factor
        linear = previous._linear
        if linear is not None and linear[0].pattern is state.model.pattern:
            state._linear = state.model, linear[1]

    def advance(self, run: StaticState) -> Outcome:
        if run.continued:
            return self._continuation_step(run)
        if run.warm:
            converged, x = self._newton_registered(run, run.start, True)
            if converged:
                return Outcome(x, True, "converged (warm start)")
            run.model = run.base_model
        base = run.base_model
        penalties = penalty_scales(base, self.options.penalty_ratio)
        # Stiff penalties are lowered for loading straight away, with or without an energy to
        # line-search on: a first attempt at the full penalties was measured wasteful on
        # both kinds (module docstring).
        if not penalties:
            return self._load_continuation(run, base)
        # Stiff penalties: load with them lowered, then raise them to their values at once;
        # if Newton fails there, raise them tenfold per step from the last scales reached.
        scales = dict(penalties)
        outcome = self._load_continuation(run, base.with_term_scales(scales),
                                          None if base.conservative else NONCONSERVATIVE_FIRST_STEP)
        factor = np.inf
        while outcome.success and min(scales.values()) < 1.0:
            trial = {k: min(1.0, factor * scale) for k, scale in scales.items()}
            smallest = min(trial.values())
            # Same registration as reached, new penalty scales.
            model = run.model
            run.model = with_registration_of(base.with_term_scales(trial), model)
            where = f"penalty scale {smallest:.3g}"
            self.check_budget(run, where)
            converged, x = self._newton_registered(run, outcome.x, smallest >= 1.0)
            run.counts["steps"] += 1
            if not converged:
                if factor > 10.0:  # the jump failed: back, and tenfold per step
                    run.model, factor = model, 10.0
                    continue
                run.checkpoint(x, where)
                return Outcome(outcome.x, False, "Newton did not converge while raising the "
                               "penalty constants")
            run.checkpoint(x, where)
            scales = trial
            outcome = Outcome(x, True, "converged")
        return outcome

    def _continuation_step(self, run: StaticState) -> Outcome:
        """A continuation step (:meth:`Integrator.restart`: a nearby model, from a nearby
        equilibrium or a predictor): chord iterations with the kept factorisation
        (:meth:`_chord`), then, if they stall, Newton at full load (the analytic Jacobian,
        band solves and line search; x + Δx, not polished past the tolerance); either
        repeated while the registration changes, until it settles without hysteresis. No
        load or penalty continuation and no fall-back to a cold start: a warm step costs a
        few iterations, and a failed one is the caller's to retry with a smaller step
        (rodsim/app/inverse/continuation.py)."""
        x = run.start
        counts = run.counts
        counts["chord_iters"] = 0
        run.where = "a continuation step"
        for _ in range(MAX_SETTLES + 1):
            self.check_budget(run, "a continuation step")
            chord = self._chord(run, x)
            if chord is not None:
                x = chord
                run.checkpoint(x, "a continuation step (chord iterations)")
                if not run.reregister(x, exact=True):
                    counts["steps"] += 1
                    return Outcome(x, True, "converged")
                continue
            model = run.model
            problem = NewtonProblem(
                force=run.force, jacobian=run.jacobian_data, linear=run.linear_solver(),
                residual=model.residual, weight=model.residual_weight,
                potential=model.energy if model.conservative else None)
            solved = newton(problem, x, run.tolerance, CONTINUATION_NEWTON, polish=False,
                            check=self.iteration_check(run, "a continuation step"))
            counts["newton_iters"] += solved.iterations
            counts["linear_solves"] += solved.iterations
            if not solved.converged:
                return Outcome(x, False, f"Newton did not converge: {solved.message}")
            x = solved.x
            run.checkpoint(x, "a continuation step (Newton)")
            if not run.reregister(x, exact=True):
                counts["steps"] += 1
                return Outcome(x, True, "converged")
        return Outcome(x, False, "the tendon registration did not settle")

    def _chord(self, run: StaticState, x: np.ndarray) -> np.ndarray | None:
        """Chord iterations x ← x − J₀⁻¹F(x) with a factorisation J₀ kept from an earlier
        equilibrium of the same Jacobian pattern (factored here if there is none): each
        costs an evaluation of F and a band back-substitution instead of F, J and a band
        factorisation. Returns x once the residual is below the tolerance, or None — and
        drops J₀ — as soon as an iteration fails to halve it (J₀ too far from the current
        Jacobian): Newton then takes over."""
        model = run.model
        if run.factor is None or run.factor[0] is not model.pattern:
            solve = run.linear_solver().factorized(run.jacobian_data(x))
            if solve is None:
                return None
            run.factor = model.pattern, solve
        solve = run.factor[1]
        previous = np.inf
        for iteration in range(MAX_CHORD):
            f = run.force(x, check=False)
            residual = model.residual(f) if np.all(np.isfinite(f)) else np.inf
            if residual < run.tolerance:
                run.counts["chord_iters"] += iteration
                return x
            if not residual < 0.5 * previous:
                break
            previous = residual
            x = x - solve(f)
        run.factor = None  # iterations that led nowhere are not counted
        return None

    def _load_continuation(self, run: StaticState, model: Model,
                           first_step: float | None = None) -> Outcome:
        """Apply the loads to ``model`` in increments from its rest state and registration;
        the first increment is ``first_load_step``, or ``first_step`` if smaller."""
        run.model = model
        counts = run.counts
        x = model.x0
        load, step = 0.0, min(self.options.first_load_step, first_step or 1.0)
        # Only the last solve (full load, penalties at their values) is polished.
        final = bool(np.all(model.term_scales == 1.0))
        # At full load the run ends once the registration settles (exact re-registration);
        # if a parent changes there, Newton goes on at full load from the same state.
        while load < 1.0 or not run.settled(x):
            target = min(1.0, load + step)
            self.check_budget(run, f"load fraction {target:.4g}")
            converged, x_new, iterations = self._newton(run, x, target,
                                                        final and target >= 1.0)
            if not converged:
                step *= 0.25
                if step < self.options.min_load_step:
                    return Outcome(x, False, f"Newton did not converge at load fraction "
                                   f"{target:.4g} and the load step fell below min_load_step")
                continue
            if run.reregister(x_new):
                x = x_new  # a tendon point changed parent: solve again at this load
                continue
            x, load = x_new, target
            counts["steps"] += 1
            run.checkpoint(x, f"load fraction {load:.4g}")
            run.history.record(load, x, run.residual(x))
            self.report(load, f"static: load {load:.3f}, {counts['newton_iters']} Newton "
                        "iterations")
            if iterations <= 6:
                step = min(1.0, 2.0 * step)
        return Outcome(x, True, "converged")

    def _newton_registered(self, run: StaticState, x: np.ndarray,
                           final: bool) -> tuple[bool, np.ndarray]:
        """Newton at full load, repeated from its result while the tendon registration
        changes (and, when ``final``, until it settles without hysteresis)."""
        while True:
            self.check_budget(run, "full load")
            converged, x, _ = self._newton(run, x, 1.0, final)
            if not converged:
                return False, x
            if run.reregister(x):
                continue
            if not final or run.settled(x):
                return True, x

    def _newton(self, run: StaticState, x: np.ndarray, load: float,
                polish: bool = True) -> tuple[bool, np.ndarray, int]:
        """Newton iterations at a fixed load (polished past the tolerance when ``polish``:
        intermediate steps need not be), through the retraction the options name, counted;
        returns (converged, x, iterations)."""
        converged, x, iterations = self.newton_equilibrium(
            run, x, load, self.options.max_newton, f"load fraction {load:.4g}", polish,
            retraction=self.options.retraction)
        run.counts["newton_iters"] += iterations
        run.counts["linear_solves"] += iterations
        return converged, x, iterations
