"""Direct equilibrium solve: Newton on F(x) = 0 with load and penalty continuation.

No pseudo-dynamics at all: this is the exact discrete equilibrium of the model, against
which the other integrators are scored (docs/design.md §3–4). Each Newton step solves
J(x) Δx = −F(x) with the analytic Jacobian (band Cholesky, band LU or SuperLU:
rodsim/solvers/linear.py) and a backtracking line search
(rodsim/solvers/newton.py). If Newton does not converge at full load, the external
loads are applied in increments λ ∈ (0, 1] (load continuation), cutting the increment on
failure and growing it after easy steps. Newton steps through the retraction
``Model.step`` (each segment and the endpoint coupling keep the length the
linearisation predicts).

Penalty continuation: when the centerline penalty dwarfs bending at the scale of a segment
(K_P l² / (E I) above ``penalty_ratio``), Newton from the rest state may converge only
linearly — a linear quaternion update leaves the penalty's constraint manifold by O(δ²),
which K_P amplifies. The loads are then applied with those penalties lowered to that ratio
(rodsim/solvers/continuation.py), which are then raised back to their values (at once; tenfold
per step if that fails), each step a short Newton solve from the last. A non-conservative
model (the paper's tendon coupling: no energy for the line search) loaded with lowered
penalties starts at a load step of ``NONCONSERVATIVE_FIRST_STEP``. Intermediate solves
are not polished past the tolerance; only the last one is.

``retraction``: how a Newton step moves the rods. ``"lengths"`` is the retraction above;
``"frames"`` turns each segment as a rigid frame (``Model.turned_step``,
rodsim/core/rod/retraction.py), far fewer iterations when segments turn a lot
(tdcr-two-segment: 5–6 instead of 13–98). The default ``"auto"``
(``rodsim.solvers.base.retraction_of``) takes "frames" unless a tendon of the model is
a rod (the paper's two-rod couplings), where "lengths" was measured as fast or faster
(four-tendons: 4 iterations against 5, table3-*: 25–30 against 29, each iteration dearer)
and keeps the numbers those scenes were published with, or a rod meets an obstacle, where
the frames' long first steps were measured to leave Newton on an indefinite stiffness (a
tip pushed onto a plane: failed where "lengths" converges).

Why each of these choices, with the measurements behind them (iterations and times per
scene, what was tried and dropped): docs/benchmark-history.md, "Solver design measurements".

Quaternion norm: held by the centerline penalty Eq. (9) (|d3| = |q|²), as in the model.

Warm start (``initial_state``, e.g. the penalty-error estimate of rodsim/app/trust.py):
Newton at full load from the given state, repeated while the registration changes; if that
fails, the run starts over from rest with the continuations above. A continuation step
(``Integrator.restart``, what track, fit and reach take): chord iterations with a
factorisation made at the step's start (made again where they stall, twice at most), then
Newton if they still stall, no fall-back (``Static._continuation_step``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rodsim.core.model import Model
from rodsim.core.schema import Options, option
from rodsim.solvers.base import Integrator, Outcome, retraction_of
from rodsim.solvers.continuation import (
    DEFAULT_PENALTY_RATIO,
    load_continuation,
    penalty_scales,
)
from rodsim.solvers.newton import NewtonProblem, newton
from rodsim.solvers.run_state import MAX_SETTLES, RunState

#: First load increment of a non-conservative model loaded with its penalties lowered (when
#: ``first_load_step`` is larger): see the module docstring.
NONCONSERVATIVE_FIRST_STEP = 0.25
#: ``retraction`` choices: :meth:`Model.step`, :meth:`Model.turned_step`, or by the model's
#: content (:func:`rodsim.solvers.base.retraction_of`, the default).
RETRACTIONS = ("auto", "lengths", "frames")
#: Chord iterations a continuation step tries before Newton.
MAX_CHORD = 10
#: Times a continuation step's chord iterations factor the Jacobian again, at the state
#: they stalled in, before Newton takes over (:meth:`Static._chord`)...
CHORD_REFRESHES = 2
#: ... and only once they brought the residual this far below the step's start (they
#: stalled near the solution; on coarse steps a stall far from it is Newton's to solve).
CHORD_REFRESH_BELOW = 1e-3
#: Newton iterations a continuation step may take (per registration), whatever
#: ``max_newton`` (the budget of a cold load step) says: a step that needs more is retried
#: smaller by the caller.
CONTINUATION_NEWTON = 30


def rest_start_crossings(run: RunState | None) -> str:
    """The advice of a failure from a rest shape through an obstacle's wall: each crossing
    (``rodsim.core.contact_depth.rest_crossings``) and why the usual advice does not apply,
    else "". Measured on a user's guidewire whose straight rest shape leaves its vessel
    (benchmarks/results/default-integrator.md): static failed with a 100× smaller first
    load step and with 200 Newton iterations, ida spent its 300 s (it now fails once the
    contact has had its chance, rodsim/core/contact_validity.py), cvode settled on a
    state through the wall; a track of the insertion from a state inside converged."""
    if run is None or run.warm or not meets_obstacles(run.model):
        return ""
    from rodsim.core.contact_depth import rest_crossings

    crossings = rest_crossings(run.base_model)
    if not crossings:
        return ""
    return "; ".join(crossings) + ("; smaller load steps do not help there, and a "
                                   "pseudo-dynamic integrator fails or settles "
                                   "through the wall")


def meets_obstacles(model: Model) -> bool:
    """Whether ``model`` has contact: a term with latent stiffness
    (``Model.latent_stiffness``, an obstacle's contact). No term with any (the model's
    zeros, not made: each static solve asks)."""
    if all(term.latent_stiffness() is None for term in model.terms):
        return False
    return bool(np.any(model.latent_stiffness()))


def secant_predicted(model: Model) -> bool:
    """Whether ``static``'s load steps start from the secant through the last two equilibria
    (``rodsim.solvers.continuation.load_continuation``'s ``predict``): on a model with
    contact (``meets_obstacles``), not elsewhere.

    Started from the last equilibrium, a node resting in the contact's onset (ψ'' = p/δ ≪ 1)
    leaves it in the first Newton step; the next step, with no contact stiffness left, sends
    it millimetres through the obstacle, and the line search creeps back over tens of
    iterations (tip-on-tissue: 30–200 a load step; with the default ``max_newton`` = 30 each
    of twelve variants of it failed). The secant carries the contact's motion into the
    start. Measured (docs/contact.md, "static on contact"): tip-on-tissue 3 635 → 907
    iterations with ``max_newton`` = 200, and the twelve variants all converge with the
    default 30. Not taken elsewhere: table3-catheter1's lowered-penalty load steps went
    29 → 167 iterations with it."""
    return meets_obstacles(model)


def rest_imbalance(run: RunState, model: Model) -> np.ndarray | None:
    """The force F₀ = F(x₀) of ``model``'s unloaded rest state when it is not an equilibrium
    (its residual above the run's tolerance), else None.

    Load continuation starts from the rest state as the equilibrium at load 0; a rod that
    starts inside an obstacle (a straight catheter in a curved vessel) is not one, and Newton
    at the first small load fraction then failed (its contact force does not scale with the
    load). The continuation then fades that imbalance out with the load instead: each step
    solves F(x; λ) = (1 − λ)^p F₀ (p = ``rodsim.solvers.base.IMBALANCE_FADE_POWER``),
    the rest state at λ = 0, the model at λ = 1. Only the imbalance's existence decides;
    every model whose rest state balances (every shipped scene's) solves as before, bit for
    bit (one more force evaluation is counted)."""
    run.counts["force_evals"] += 1
    force = model.unloaded_rest_force()  # kept by a batch's or a track's model copies
    return force if model.force_residual(force) > run.tolerance else None


@dataclass(frozen=True, kw_only=True)
class StaticOptions(Options):
    """``[solver.static]``: Newton with load and penalty continuation, each option declared
    once by its field (``rodsim.core.schema.option``; ``Static.parameters`` is made from
    them)."""

    max_newton: int = option(30, "-", "Newton iterations per load step", 1, 10_000)
    first_load_step: float = option(
        1.0, "-", "first load increment (fraction of the full load)", 0.0, 1.0,
        exclusive_minimum=True)
    min_load_step: float = option(
        1e-4, "-", "smallest load increment before giving up", 0.0, 1.0,
        exclusive_minimum=True)
    penalty_ratio: float = option(
        DEFAULT_PENALTY_RATIO, "-", "above this K_P l²/(E I), load with K_P lowered to it, "
        "then raise K_P tenfold per step (penalty continuation)", 1.0, 1e300)
    retraction: str = option(
        "auto", "-", "how a Newton step moves the rods: 'lengths' (segment lengths kept), "
        "'frames' (segments turned as rigid frames: far fewer iterations when segments turn "
        "a lot, rodsim/core/rod/retraction.py) or 'auto' ('frames' unless a tendon is a rod "
        "or a rod meets an obstacle, then 'lengths')", choices=RETRACTIONS)


class Static(Integrator[RunState]):
    """Newton–Raphson with load continuation on F(x) = 0."""

    Options = StaticOptions
    options: StaticOptions

    takes_predictor = True
    resolves_below_floor = True

    name = "static"
    summary = "Newton on F(x) = 0 with the analytic Jacobian and load continuation"
    quaternion_norm = "penalty Eq. (9) only (|d3| = |q|² is pulled to 1)"
    history_time = ("1", "load fraction after each load step")
    def advice(self, run: RunState | None = None) -> str:
        if run is not None and run.continued:
            return "try smaller parameter steps (the last equilibrium is too far away)"
        crossings = rest_start_crossings(run)
        if crossings:
            return crossings
        # ida is the integrator of a scene with obstacles (docs/contact.md, "Which integrator")
        other = "ida" if run is not None and meets_obstacles(run.model) else "cvode"
        return ("try a smaller solver.static.first_load_step or min_load_step, or a "
                f"pseudo-dynamic integrator ({other})")

    @classmethod
    def work(cls, stats: dict[str, float]) -> int:
        return int(stats["newton_iters"] + stats.get("chord_iters", 0))

    def carry(self, previous: RunState, state: RunState) -> None:
        """A continuation step keeps the linear solver of the last step while the Jacobian
        pattern is the same. (Not its factorisation: one kept from the last step was
        measured to stall the chord iterations, ``_chord``.)"""
        linear = previous._linear
        if linear is not None and linear[0].pattern is state.model.pattern:
            state._linear = state.model, linear[1]

    def predicted(self, model: Model, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """The predictor x + dx with each segment turned as a rigid frame
        (``Model.turned_step``) where this integrator's retraction is "frames": a
        straight-line extrapolation of turning segments stretches them, which their stretch
        and penalty stiffness turn into a large residual (tdcr-two-segment, 201 steps: the
        start's residual halves and one factorisation a step suffices instead of 1.5).
        Where it is "lengths" the straight line is kept: ``Model.step`` was measured
        slower there (table3-catheter1: 265 against 300 steps/s)."""
        if retraction_of(model, self.options.retraction) == "frames":
            return model.turned_step(x, dx)
        return x + dx

    def advance(self, run: RunState) -> Outcome:
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
            # Same registration as reached, new penalty scales: the scales of the model
            # reached (every penalty's among ``trial``'s keys, the others the base's), so its
            # pattern, index maps and kernel calls are kept (a model of the base's rebuilt
            # with this registration was a fourth pattern merge in a four-tendons solve).
            model = run.model
            run.model = model.with_term_scales(trial)
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

    def _continuation_step(self, run: RunState) -> Outcome:
        """A continuation step (``Integrator.restart``: a nearby model, from a nearby
        equilibrium or a predictor): chord iterations (``_chord``), then, if they
        stall, Newton at full load (the analytic Jacobian, band solves and line search;
        x + Δx, not polished past the tolerance); either repeated while the registration
        changes, until it settles without hysteresis. No load or penalty continuation and
        no fall-back to a cold start: a warm step costs a few iterations, and a failed one
        is the caller's to retry with a smaller step (rodsim/app/inverse/continuation.py)."""
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
                force_residual=model.force_residual, weight=model.residual_weight,
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

    def _chord(self, run: RunState, x: np.ndarray) -> np.ndarray | None:
        """Chord iterations x ← x − J₀⁻¹F(x) with J₀ factored at the step's start ``x``:
        each costs an evaluation of F and a band back-substitution instead of F, J and a
        band factorisation. When an iteration fails to halve the residual (or is too slow
        to reach the tolerance in the iterations left) after the iterations brought the
        residual below ``CHORD_REFRESH_BELOW`` of the start's, J₀ is factored again at
        the state reached, up to ``CHORD_REFRESHES`` times. Returns x once the residual
        is below the tolerance, or None: Newton then takes over. J₀ is factored only
        once the start's residual is found above the tolerance: a start already at the
        equilibrium (a tangent predictor's, often: 110 of tdcr-two-segment's 200 tracker
        steps) costs F alone, and the verification's factorisation there is the step's only
        one (it was the second, at the same state).

        Why J₀ is not kept from the last step (as it was before): between two neighbouring
        equilibria of a tracked ramp the Jacobian changes by far more than its parameters
        suggest (the spectral radius of J_k⁻¹ J_{k+1} − I is 2.5–6 on table3-catheter1 and
        tdcr-two-segment at 201 steps, almost all of it from the state, not from the new
        value), and a factorisation kept from the last step's start or equilibrium stalled
        within one or two iterations (docs/benchmark-history.md, "Tracking")."""
        model = run.model
        counts = run.counts
        refreshes = 0
        previous = start = np.inf
        solve = None
        iteration = 0
        if model.keeps_jacobians:
            # J at the start is taken either way: as J₀, or by the verification of a start
            # at the equilibrium already. F and J in one pass (the model's memo keeps both).
            model.evaluate(x)
        while iteration < MAX_CHORD:
            f = run.force(x, check=False)
            residual = model.force_residual(f) if np.all(np.isfinite(f)) else np.inf
            if residual < run.tolerance:
                counts["chord_iters"] += iteration
                return x
            if solve is None:
                solve = run.linear_solver().factorized(run.jacobian_data(x))
                if solve is None:
                    break
            if iteration == 0:
                start = residual
            rate = residual / previous
            # Stalled (not halving), or too slow to reach the tolerance within the
            # iterations left at the rate just measured.
            if not rate < 0.5 or residual * rate ** (MAX_CHORD - iteration) >= run.tolerance:
                if (refreshes == CHORD_REFRESHES
                        or not residual < CHORD_REFRESH_BELOW * start):
                    break
                refreshes += 1
                previous, solve = np.inf, None  # factor again here
                continue
            previous = residual
            x = x - solve(f)
            iteration += 1
        return None  # the iterations that led nowhere are not counted

    def _load_continuation(self, run: RunState, model: Model,
                           first_step: float | None = None) -> Outcome:
        """Apply the loads to ``model`` in increments from its rest state and registration
        (rodsim/solvers/continuation.py); the first increment is ``first_load_step``, or
        ``first_step`` if smaller."""

        imbalance = rest_imbalance(run, model)
        # Node supports moved from their rest places are moved with the loads, as loads.
        moved = imbalance is not None and bool(model.support_displacements)
        if moved:
            imbalance = rest_imbalance(run, model.with_supports_moved(0.0))

        def newton_at(x: np.ndarray, load: float, polish: bool
                      ) -> tuple[bool, np.ndarray, int]:
            if moved:  # the model reached (its registration), the supports at ``load``
                run.model = run.model.with_supports_moved(load)
            return self._newton(run, x, load, polish, imbalance)

        def progress(load: float) -> None:
            self.report(load, f"static: load {load:.3f}, {run.counts['newton_iters']} Newton "
                        "iterations")

        return load_continuation(run, model, min(self.options.first_load_step,
                                                 first_step or 1.0),
                                 self.options.min_load_step, newton_at,
                                 lambda where: self.check_budget(run, where), progress,
                                 predict=secant_predicted(model))

    def _newton_registered(self, run: RunState, x: np.ndarray,
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

    def _newton(self, run: RunState, x: np.ndarray, load: float,
                polish: bool = True, imbalance: np.ndarray | None = None
                ) -> tuple[bool, np.ndarray, int]:
        """Newton iterations at a fixed load (polished past the tolerance when ``polish``:
        intermediate steps need not be), through the retraction the options name, counted;
        returns (converged, x, iterations). ``imbalance``: see ``rest_imbalance``."""
        converged, x, iterations = self.newton_equilibrium(
            run, x, load, self.options.max_newton, f"load fraction {load:.4g}", polish,
            retraction=self.options.retraction, imbalance=imbalance)
        run.counts["newton_iters"] += iterations
        run.counts["linear_solves"] += iterations
        return converged, x, iterations
