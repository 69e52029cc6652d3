"""The run loop CVODE and IDA share: one internal step at a time, to equilibrium.

After each step (once the load ramp is complete) the scaled equilibrium residual is checked
and the run stops as soon as it is below the tolerance — at equilibrium, not at an arbitrary
final time. Near equilibrium the steps grow huge and each BDF corrector stops at its own
tolerance, which on stiff scenes can leave the force residual stalled above the equilibrium
tolerance; when it has not halved in ``STALL_STEPS`` steps spanning at least
``STALL_PERIODS`` first-mode periods, or pseudo-time passes the horizon, the solver is
restarted from the current state with rtol and atol 100× tighter
(counted as ``tightenings``; measured on the stress map, where 64 CVODE runs failed that
``static`` solved). Both conditions are needed: in a transient (the inertial form
oscillating, a tendon sliding) the residual may not halve in 100 short steps, and tightening
there only makes the steps shorter (measured: CVODE inertial on ``table3-catheter1`` reached
rtol 1e-12 four times over and crawled at t ≈ 0.8 s until the budget). Tendon registration
(§4.1) is updated after every accepted step; SUNDIALS holds a fixed Jacobian pattern, so when a
tendon point changes parent the solver is rebuilt on the new pattern and re-initialised
from that state (counted as ``reinits``); a fixed superset pattern without re-initialisation
was measured slower and less robust (docs/tendon.md, "Sparsity pattern").
A run whose best residual has not halved over 50 re-initialisations (``FLIP_REINITS``)
or over a quarter of its step budget (``NEVER_SETTLES_SHARE``) ends as stalled, with
advice. A SUNDIALS error in a step (its corrector or error test failing repeatedly) restarts
the solver from the last accepted state with tolerances 100x tighter, as a stall does, until
the tightest rtol: with offsets as coordinates the error weights rtol |y| + atol are nearly
absolute, and IDA's corrector failed on contact-robot-3 of tests/test_contact.py where its
tip slides off a sphere's crest (t = 53 s; converged after the retry). Non-finite states,
solver errors at the tightest rtol, the step budget and the wall-time budget end the run
with a diagnostic.
"""

from __future__ import annotations

import functools
from abc import abstractmethod
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.contact_validity import ThroughTheWall
from rodsim.core.model import Model
from rodsim.solvers.base import LARGE_MODEL_SIZE, Integrator, Outcome, SolverFailure
from rodsim.solvers.continuation import DEFAULT_PENALTY_RATIO, homotopy, penalty_scales
from rodsim.solvers.pseudo_dynamics import (
    BAND_LIMIT,
    LARGE_FINISH_ITERATIONS,
    LINEAR_SOLVERS,
    PSEUDO_DYNAMICS_PARAMETERS,
    PseudoDynamics,
)
from rodsim.solvers.run_state import MAX_SETTLES, RunState
from rodsim.solvers.stops import Equilibrium, Until
from rodsim.solvers.sundials_clock import Clock
from rodsim.solvers.sundials_setup import (
    BandPreconditioner,
    StartFailure,
    jacobian_writer,
    started,
)

__all__ = ["SundialsIntegrator", "SundialsState", "BandPreconditioner", "jacobian_writer",
           "started", "StartFailure", "BAND_LIMIT", "LINEAR_SOLVERS", "PSEUDO_DYNAMICS_PARAMETERS"]

#: Steps without halving the residual (after the load ramp) before tolerances are tightened…
STALL_STEPS = 100
#: …provided they also span this many first-mode periods: a damped transient (ζ = 1 on the
#: first mode, the slowest) shrinks the residual by far more than half in that time.
STALL_PERIODS = 10.0
#: Tightest relative tolerance a tightening may reach.
TIGHTEST_RTOL = 1e-12
#: A residual that repeats itself — equal to within this fraction to the one one or two steps
#: before, for FROZEN_STEPS steps in a row — is frozen: the corrector accepts steps that no
#: longer move the state, or that flip it between two states at a constant step size (a
#: period-2 cycle of BDF near its stability boundary, measured on table1-50g: residual
#: alternating 9.17e-2 / 7.68e-2 for 30 steps of h = 0.95 s). Tolerances are then tightened
#: at once rather than after STALL_PERIODS.
FROZEN_CHANGE = 1e-3
FROZEN_STEPS = 10

#: A run has stalled when its best residual has not halved over this many re-initialisations
#: (a tendon point changing parent: the registration flipping back and forth); it then ends
#: with advice instead of spending the wall-time budget. Neither pseudo-time nor a residual
#: frozen at the tightest tolerances tells such a run from an honest one (docs/benchmark-history.md,
#: "CVODE and IDA: a registration that flips").
FLIP_REINITS = 50

#: A run whose best residual has not halved in this share of its ``max_steps`` (and in
#: :data:`STALL_STEPS`) ends there, as stalled, instead of spending the rest. Measured over
#: 74 CVODE and IDA runs that succeed (the shipped scenes, 12 of tests/test_user_robot.py's
#: family, 12 of tests/test_contact.py's contact robots): the longest stretch without
#: halving was 13 237 steps (a contact robot, CVODE, 20 019 steps in all). tip-on-tissue at
#: a tip moment of 8 mN·m (a follower load) came within 3.9e-4 of equilibrium at step
#: 12 156, left it, and went the remaining 188 000 steps of the default budget (60 s of
#: CVODE, 74 s of IDA) at residuals 0.02–4.
NEVER_SETTLES_SHARE = 0.25

#: The wall-time budget is checked every this many steps (a step costs ~0.1 ms).
BUDGET_STRIDE = 16

#: After a failed Newton finish at residual r, the next is tried below this × r (0.1 before:
#: table3-catheter1 CVODE 340 → 264 steps, catheter2 286 → 233, other scenes unchanged).
RETRY_FACTOR = 0.3

#: The counters of the Newton finish (:meth:`SundialsIntegrator.finish_with_newton`).
FINISH_COUNTS = ("finish_attempts", "finish_newton_iters", "finish_force_evals",
                 "finish_jacobian_evals", "finish_unstable")


@dataclass
class StallWatch:
    """What a run to equilibrium watches for a stall: the best residual, the step, time
    and re-initialisation count where it was reached, and how many steps in a row the
    residual repeated one of the two before it (``frozen``, see ``FROZEN_CHANGE``)."""

    best: float = np.inf
    best_step: int = 0
    best_time: float = 0.0
    reinits_at_best: float = 0.0
    previous: tuple[float, float] = (np.inf, np.inf)  # the residuals one and two steps back
    frozen: int = 0

    def observe(self, residual: float) -> None:
        """Count a residual that repeats one of the two before it."""
        repeats = min(abs(residual - r) for r in self.previous) < FROZEN_CHANGE * residual
        self.frozen = self.frozen + 1 if repeats else 0
        self.previous = (residual, self.previous[0])

    def mark(self, residual: float, step: int, time: float, reinits: float) -> None:
        """Take ``residual`` as the best, reached at ``step``, ``time``, ``reinits``."""
        self.best, self.best_step, self.best_time = residual, step, time
        self.reinits_at_best = reinits



@dataclass(eq=False, kw_only=True)
class SundialsState(RunState):
    """A CVODE or IDA run's state: the run's state plus the pseudo-dynamics' constants, the
    tolerance tightening factor, the first-order system of the model in use and (IDA) the
    last solver state the equilibrium test looked at."""

    dynamics: PseudoDynamics
    #: Factor applied to rtol and atol (divided by 100 at each tightening).
    tightening: float = 1.0
    #: The system (FirstOrderSystem or ConstrainedSystem) of :attr:`model`'s pattern.
    system: Any = None
    #: IDA: the last y whose constrained force the equilibrium test evaluated.
    last_y: np.ndarray | None = None


class SundialsIntegrator(Integrator[SundialsState]):
    """Shared loop of ``rodsim.solvers.cvode.Cvode`` and
    ``rodsim.solvers.ida.Ida``; subclasses build the system and the solver."""

    State = SundialsState
    stops = (Equilibrium, Until)
    dense_output = True

    def state_fields(self, model: Model, warm: bool) -> dict[str, Any]:
        # A warm start (from a nearby equilibrium) takes the loads in full at once.
        return {"dynamics": PseudoDynamics.of(model, self.options, warm)}

    def prepare(self, run: SundialsState) -> None:
        run.counts["reinits"] = 0
        run.counts["tightenings"] = 0
        # SUNDIALS' own Newton iterations and linear solves are not reported by scikit-sundae.
        run.counts["newton_iters"] = run.counts["linear_solves"] = float("nan")
        run.system = self.build_system(run)

    def rtol(self, run: SundialsState) -> float:
        return float(self.options.rtol * run.tightening)

    def linear_solver(self, size: int) -> str:
        choice = str(self.options.linear_solver)
        if choice == "auto":
            return "band" if size <= BAND_LIMIT else "band_gmres"
        return choice

    def advice(self, run: RunState | None = None) -> str:
        other = "inertial" if self.options.formulation == "overdamped" else "overdamped"
        if run is not None and run.model.support_displacements:
            # The load ramp ramps loads, not a support's displacement, which the rest state
            # meets at once; static moves supports with its load steps.
            return (f"try the static integrator (it moves displaced supports in with the "
                    f"loads), or solver.{self.name}.formulation={other!r}")
        return (f"try solver.{self.name}.formulation={other!r}, a longer load_ramp, or the "
                "static integrator")

    @staticmethod
    def coordinate_scale(model: Model) -> np.ndarray:
        """Size of each model coordinate, for absolute tolerances: L_ref for positions, 1 for
        quaternion coordinates."""
        return np.where(model.is_quaternion, 1.0, model.length_scale)

    def common_options(self, run: SundialsState, solver_kind: str, band: tuple[int, int],
                       pattern: Any, inertial: bool) -> dict[str, Any]:
        """Options CVODE and IDA share: linear solver (band widths or sparsity), tolerances,
        BDF order (≤ 2 for the inertial form, see rodsim/solvers/cvode.py) and first step
        (while the load ramp starts the right-hand side vanishes, and SUNDIALS' own estimate
        of the first step would be unbounded)."""
        options: dict[str, Any] = {"linsolver": solver_kind,
                                   "rtol": max(self.rtol(run), TIGHTEST_RTOL),
                                   "max_order": 2 if inertial else 5,
                                   "first_step": 1e-4 / run.dynamics.omega}
        if solver_kind == "band":
            options.update(lband=band[0], uband=band[1])
        elif solver_kind == "band_gmres":
            options["linsolver"] = "gmres"
        else:
            options.update(sparsity=pattern)
        return options

    @abstractmethod
    def build_system(self, run: SundialsState) -> Any:
        """The first-order system of ``run.model``'s current pattern."""

    @abstractmethod
    def start(self, run: SundialsState, t: float, y: np.ndarray, yp: np.ndarray | None) -> Any:
        """A new SUNDIALS solver initialised at (t, y[, y′])."""

    def initial_state(self, run: SundialsState) -> np.ndarray:
        """y at t = 0 (``run.start``, at rest)."""
        return np.asarray(run.system.initial_state(run.start))

    def positions_of(self, run: SundialsState, y: np.ndarray) -> np.ndarray:
        """The model coordinates x inside y."""
        return np.asarray(run.system.positions_of(y))

    def equilibrium_force(self, run: SundialsState, y: np.ndarray,
                          force: np.ndarray) -> np.ndarray:
        """The force whose vanishing is this integrator's equilibrium (default: F itself)."""
        return force

    def screened_residual(self, run: SundialsState, y: np.ndarray) -> float:
        """The scaled residual of the last F the right-hand side computed
        (``run.last_force``: at the corrector's last iterate, so close to, not exactly at,
        the accepted y). It screens the equilibrium test, so an accepted step costs no extra
        evaluation of F."""
        assert run.last_force is not None  # every step evaluates the right-hand side
        return run.model.force_residual(self.equilibrium_force(run, y, run.last_force))

    def finish_start(self, run: SundialsState, y: np.ndarray) -> np.ndarray:
        """The state the Newton finish starts from, given the solver state ``y``: here the
        model coordinates x (IDA keeps y, multipliers included)."""
        return self.positions_of(run, y).copy()

    def finish_newton(self, run: SundialsState,
                      state: np.ndarray) -> tuple[bool, np.ndarray, int]:
        """One Newton solve of the finish from ``state`` (see ``finish_start``) on
        ``run.model``: (converged, the state it reached, iterations). Here Newton on
        F(x) = 0; IDA solves its constrained equilibrium instead.

        On a non-conservative model whose penalties are stiffer than ``static``'s
        penalty_ratio (the paper's tendon coupling), Newton at the full penalties converges
        only very close to the equilibrium, and Newton with those penalties lowered does not
        converge from far either (docs/benchmark-history.md, "CVODE and IDA: the Newton finish").
        So, as ``static`` does, the finish first solves
        with the penalties lowered to that ratio — by residual homotopy, F(x) = (1 − λ) F(x₀)
        for λ from 0 to 1 (rodsim/solvers/continuation.py) — whose equilibrium is next to the
        full one, then Newton at the full penalties from there. Both through the retraction
        ``Model.step`` — or, on a model with string tendons, the Newton at full penalties
        through the retraction ``static``'s default picks
        (``rodsim.solvers.base.retraction_of``: the frames, ``Model.turned_step``,
        unless a rod meets an obstacle): on
        tdcr-two-segment the finish with ``Model.step`` failed three times in the cases
        where a long distal segment turns (CVODE then took ~200 steps, 116 ms; with the
        frames, one finish after 11-12 steps, 10 ms). Only there: on table1-50g the frames
        finish moved the stored CVODE equilibrium by 8e-13 m (docs/benchmark-history.md, "String
        tendons"). And on every model above
        ``rodsim.solvers.base.LARGE_MODEL_SIZE`` free coordinates, where the finish
        through ``Model.step`` fails as Newton from rest through it does (table1-50g,
        N = 20 000: four failed finishes, 1787 steps, 164 s; through the frames one finish
        of 7 iterations after 5 steps, 2.5 s)."""
        converged, state, iterations = self.at_lowered_penalties(run, state)
        if not converged:
            return False, state, iterations
        model = run.model
        frames = (model.n > LARGE_MODEL_SIZE
                  or any(tendon.rod is None for tendon in model.tendons.values()))
        converged, state, more = self.newton_equilibrium(
            run, state, 1.0, self.finish_iterations(model), "the Newton finish",
            retraction="auto" if frames else "lengths")
        return converged, state, iterations + more

    def finish_iterations(self, model: Model) -> int:
        """Newton iterations one finish may take on ``model``: ``newton_iterations``, or at
        least ``LARGE_FINISH_ITERATIONS`` on a large model (see there)."""
        iterations = int(self.options.newton_iterations)
        if model.n > LARGE_MODEL_SIZE:
            return max(iterations, LARGE_FINISH_ITERATIONS)
        return iterations

    def at_lowered_penalties(self, run: SundialsState,
                             x: np.ndarray) -> tuple[bool, np.ndarray, int]:
        """The positions ``x`` taken to the equilibrium of ``run.model`` with its stiff
        penalties lowered (a non-conservative model's penalties stiffer than
        ``rodsim.solvers.continuation.DEFAULT_PENALTY_RATIO``) by residual homotopy, on a
        derived state (the run's model untouched), where a Newton finish at the full
        penalties then converges; ``x`` itself, with no iteration, when nothing needs
        lowering. (converged, positions, iterations)."""
        lowered = {} if run.model.conservative else penalty_scales(run.model,
                                                                   DEFAULT_PENALTY_RATIO)
        if not lowered:
            return True, x, 0
        trial = run.derived(model=run.model.with_term_scales(lowered))
        return homotopy(trial, x, self.options.newton_iterations,
                        lambda target: self.iteration_check(
                            trial, f"the Newton finish (homotopy {target:.3g})"))

    def stall(self, run: SundialsState, steps: int, span: float, best: float,
              residual: float, reinits: int) -> None:
        """Raise the SolverFailure of a stalled run: ``steps`` steps over ``span`` of
        pseudo-time without halving the best residual ``best`` (now ``residual``), with
        ``reinits`` re-initialisations (tendon re-registrations) among them; the advice names
        what to change for what was seen."""
        periods = span / run.dynamics.period
        what = (f"stalled: the residual has not halved from {best:.3g} in {steps} steps "
                f"(now {residual:.3g}) while pseudo-time advanced {span:.3g} s "
                f"({periods:.3g} first-mode periods)")
        if reinits:
            what += (f", with {reinits} re-initialisations on a tendon point changing parent "
                     "(the registration flips back and forth)")
        advice = []
        if reinits:
            advice.append("stiffer lumen penalties (tendons.<name>.lumen.K_L_relative, "
                          "or K_L: with the conserving coupling N/m² per unit length) or a "
                          "larger tendons.<name>.lumen.hysteresis")
        if self.rtol(run) > TIGHTEST_RTOL and not reinits:
            advice.append(f"a tighter solver.{self.name}.rtol/atol")
        other = "inertial" if self.options.formulation == "overdamped" else "overdamped"
        advice.append(f"solver.{self.name}.formulation={other!r}")
        advice.append("the static integrator (or a smaller load)")
        if not reinits:
            advice.append(f"a larger solver.{self.name}.max_steps (a run ends after "
                          f"{NEVER_SETTLES_SHARE:.0%} of it without halving its residual); "
                          "a follower (body-frame) load or a tendon may have no stable "
                          "equilibrium to settle on")
        raise SolverFailure(what, "try " + ", or ".join(advice))

    def finish_with_newton(self, run: SundialsState, y: np.ndarray) -> np.ndarray | None:
        """``finish_newton`` at full load from ``y``, repeated while the tendon
        registration changes; the equilibrium x (the run then on the model and system the
        finish reached), or None (the run untouched) if it fails or lands on an unstable
        equilibrium (rodsim/core/stability.py: the integration then goes on, and may leave
        it).

        It runs on a derived state with counters of its own, added to the run's ``finish_*``
        statistics (its evaluations are counted apart from the integration's)."""
        counts = run.counts
        # The trial's own counters, and which finish attempt this is (finish_start's to read).
        trial = run.derived(counts={"force_evals": 0, "jacobian_evals": 0,
                                    "settles": counts.get("settles", 0),
                                    "finish_attempts": counts.get("finish_attempts", 1)})
        try:
            state = self.finish_start(trial, y)
            for _ in range(MAX_SETTLES + 1):
                converged, state, iterations = self.finish_newton(trial, state)
                counts["finish_newton_iters"] += iterations
                if not converged:
                    break
                x = self.finish_positions(trial, state)
                if trial.reregister(x) or not trial.settled(x):
                    trial.system = self.build_system(trial)
                    continue
                if not trial.stability(x).stable:
                    # Newton converges to the nearest equilibrium, stable or not (a compressed
                    # column's straight branch); the pseudo-dynamics leave an unstable one.
                    counts["finish_unstable"] += 1
                    break
                run.model, run.system = trial.model, trial.system
                run.last_y, run._stability = trial.last_y, trial._stability
                return x
            return None
        finally:
            counts["finish_force_evals"] += trial.counts["force_evals"]
            counts["finish_jacobian_evals"] += trial.counts["jacobian_evals"]
            # Re-registrations at equilibrium count, and note, whether or not it succeeded.
            if "settles" in counts:
                counts["settles"] = trial.counts["settles"]
            run.note = trial.note

    def finish_positions(self, run: SundialsState, state: np.ndarray) -> np.ndarray:
        """The model coordinates in a state reached by ``finish_newton``."""
        return state

    def advance(self, run: SundialsState) -> Outcome:
        """Step the pseudo-dynamics from ``run.start`` until ``run.stop``: to equilibrium
        (``to_equilibrium``) or to a time (``until``)."""
        for key in FINISH_COUNTS:
            run.counts[key] = 0
        stop = run.stop
        clock = Clock(self, run, self.initial_state(run), shift=not isinstance(stop, Until))
        if isinstance(stop, Until):
            return self.until(run, clock, stop)
        return self.to_equilibrium(run, clock)

    def to_equilibrium(self, run: SundialsState, clock: Clock) -> Outcome:
        """Step until the state is an equilibrium (the module docstring): after the load
        ramp, each step's screened residual decides a Newton finish
        (``finish_with_newton``), the equilibrium test, and the watch for a stall
        (``watch``)."""
        opts, counts, ramp = self.options, run.counts, run.dynamics.ramp
        horizon = run.dynamics.horizon
        stalls, switch = StallWatch(), opts.newton_switch
        # A rest shape through a wall: its accepted states are judged once the contact has
        # had its chance (rodsim/core/contact_validity.py).
        wall = ThroughTheWall.of(run.base_model, run.warm)
        for step in range(1, opts.max_steps + 1):
            if clock.t >= horizon:  # steps that large mean a stalled corrector: tighten
                if self.rtol(run) <= TIGHTEST_RTOL:
                    return Outcome(self.positions_of(run, clock.y), False,
                                   f"not at equilibrium by t = {clock.time:.3g} s")
                self.tighten(run, clock)
            x = self.take_step(run, clock, step, horizon)
            if isinstance(x, Outcome):
                if self.rtol(run) > TIGHTEST_RTOL:  # a SUNDIALS error: retry tighter
                    self.tighten(run, clock)
                    continue
                return x
            stuck = None if wall is None else wall.judge(
                run.model, x, step, (clock.time - ramp.duration) / run.dynamics.period)
            if stuck is not None:
                raise SolverFailure(*stuck)
            if run.reregister(x):
                self.reinitialise(run, clock)  # a tendon point changed parent (§4.1)
                continue
            if clock.t < ramp.duration:
                continue
            residual = self.screened_residual(run, clock.y)
            run.record(clock.time, x, residual)
            if self.reporting:
                self.report(None, f"{self.name}: t = {clock.time:.3g} s, residual "
                            f"{residual:.2e}")
            if residual < switch:
                counts["finish_attempts"] += 1
                finished = self.finish_with_newton(run, clock.y)
                if finished is not None:
                    return Outcome(finished, True, "at equilibrium (Newton finish)")
                switch = RETRY_FACTOR * residual  # try again once closer
            if residual < 10.0 * run.tolerance:
                residual = run.model.force_residual(self.equilibrium_force(run, clock.y,
                                                                     run.force(x)))
                if run.at_equilibrium(residual):
                    if run.settled(x):
                        return Outcome(x.copy(), True, "at equilibrium")
                    # A parent changed without hysteresis: go on, on the new pattern.
                    self.reinitialise(run, clock)
                    continue
            self.watch(run, clock, stalls, step, residual)
        raise SolverFailure(f"not at equilibrium after max_steps = {opts.max_steps}",
                            f"try raising solver.{self.name}.max_steps, or "
                            f"{self.advice(run).removeprefix('try ')}")

    def until(self, run: SundialsState, clock: Clock, stop: Until) -> Outcome:
        """Step to the time ``stop.t_end`` (not past it), whatever the state: the recorder
        takes the output times each step spans from its dense output (they force no step),
        and every step's end with its screened residual; a tendon re-registration restarts
        the solver at the same time."""
        for step in range(1, self.options.max_steps + 1):
            start = clock.t
            x = self.take_step(run, clock, step, stop.t_end, tstop=stop.t_end)
            if isinstance(x, Outcome):
                return x
            run.recorder.dense(start, clock.t, lambda t: self.positions_of(
                run, clock.interpolate(t) if t < clock.t else clock.y))
            run.record(clock.t, x, self.screened_residual(run, clock.y))
            if self.reporting:
                self.report(clock.t / stop.t_end, f"{self.name}: t = {clock.t:.4g} s of "
                            f"{stop.t_end:.4g} s")
            if clock.t >= stop.t_end:
                return Outcome(x.copy(), True, f"reached t = {stop.t_end:.4g} s")
            if run.reregister(x):
                self.reinitialise(run, clock)
        raise SolverFailure(f"did not reach t = {stop.t_end:.4g} s in max_steps = "
                            f"{self.options.max_steps}",
                            f"try raising solver.{self.name}.max_steps, or a looser "
                            f"solver.{self.name}.rtol/atol")

    def take_step(self, run: SundialsState, clock: Clock, step: int, toward: float,
                  tstop: float | None = None) -> np.ndarray | Outcome:
        """Step ``step`` of the run toward ``toward``: the model coordinates it reached
        (checkpointed; the wall-time budget checked every ``BUDGET_STRIDE`` steps), or
        the failed Outcome of a SUNDIALS error."""
        out = clock.step(toward, tstop)
        run.counts["steps"] = step
        if not out.success:
            detail = clock.failure_text()
            return Outcome(self.positions_of(run, clock.y), False,
                           f"{self.name.upper()} error: {out.message}"
                           + (f" SUNDIALS: {detail}" if detail else ""))
        clock.accept(out)
        x = self.positions_of(run, clock.y)
        run.checkpoint(x, functools.partial("step {} (t = {:.4g} s)".format, step,
                                            clock.time))
        if step % BUDGET_STRIDE == 0:
            self.check_budget(run, f"step {step} (t = {clock.time:.4g} s)")
        return x

    def tighten(self, run: SundialsState, clock: Clock) -> None:
        """rtol and atol 100× tighter, on a new solver from the last accepted state."""
        run.tightening /= 100.0
        run.counts["tightenings"] += 1
        clock.restart()

    def reinitialise(self, run: SundialsState, clock: Clock) -> None:
        """A new system on the new pattern of ``run.model`` (a tendon point changed
        parent), and a new solver on it from the last accepted state."""
        run.counts["reinits"] += 1
        run.system = self.build_system(run)
        clock.restart()

    def watch(self, run: SundialsState, clock: Clock, stalls: StallWatch, step: int,
              residual: float) -> None:
        """After a step's ``residual`` (no equilibrium yet): end a run that has stalled
        (``stall``), tighten the tolerances of one whose residual froze or has not
        halved for ``STALL_STEPS`` steps over ``STALL_PERIODS`` periods."""
        counts, max_steps = run.counts, self.options.max_steps
        stalls.observe(residual)
        if residual < 0.5 * stalls.best:
            stalls.mark(residual, step, clock.time, counts["reinits"])
            return
        stalled = (step - stalls.best_step > STALL_STEPS
                   and clock.time - stalls.best_time > STALL_PERIODS * run.dynamics.period)
        flipping = counts["reinits"] - stalls.reinits_at_best >= FLIP_REINITS
        unsettled = step - stalls.best_step > max(STALL_STEPS, NEVER_SETTLES_SHARE * max_steps)
        if flipping or unsettled:
            self.stall(run, step - stalls.best_step, clock.time - stalls.best_time,
                       stalls.best, residual, int(counts["reinits"] - stalls.reinits_at_best))
        if self.rtol(run) > TIGHTEST_RTOL and (stalls.frozen >= FROZEN_STEPS or stalled):
            stalls.mark(residual, step, clock.time, counts["reinits"])
            stalls.frozen = 0
            self.tighten(run, clock)
