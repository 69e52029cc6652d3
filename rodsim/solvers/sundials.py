"""The run loop CVODE and IDA share: one internal step at a time, to equilibrium.

After each step (once the load ramp is complete) the scaled equilibrium residual is checked
and the run stops as soon as it is below the tolerance — at equilibrium, not at an arbitrary
final time. Near equilibrium the steps grow huge and each BDF corrector stops at its own
tolerance, which on stiff scenes can leave the force residual stalled above the equilibrium
tolerance; when it has not halved in :data:`STALL_STEPS` steps spanning at least
:data:`STALL_PERIODS` first-mode periods, or pseudo-time passes the horizon, the solver is
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
Non-finite states, solver errors, the step budget and the wall-time budget end the run with
a diagnostic.
"""

from __future__ import annotations

import contextlib
import io
import math
import sys
import warnings
from abc import abstractmethod
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from rodsim.core.model import Model
from rodsim.core.schema import Parameter
from rodsim.solvers.base import MAX_SETTLES, Integrator, Outcome, SolverFailure
from rodsim.solvers.pseudo_dynamics import (
    FORMULATIONS,
    LoadRamp,
    first_mode_frequency,
    pseudo_masses,
)

#: Above this many unknowns the band solver's dense (n × n) Jacobian template costs too much
#: memory (scikit-sundae hands band Jacobians to Python as a full array); ``linear_solver =
#: "auto"`` then switches to ``band_gmres``: SUNDIALS' GMRES preconditioned by rodsim's own
#: band LU of the same Newton matrix (:class:`BandPreconditioner`), which holds only the band.
BAND_LIMIT = 4000
#: The linear solvers of CVODE and IDA (``linear_solver``; "auto" picks one by size).
LINEAR_SOLVERS = ("auto", "band", "band_gmres", "sparse")

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
#: with advice instead of spending the wall-time budget. Measured on the user scene of issue
#: 22 item 2 (conserving coupling, K_L = 1000 N/m², then the default): CVODE at t = 1.43-1.44 s for
#: 9 000 steps with 187 re-initialisations in 90 s, the residual wandering 1.5-160 (602 s
#: before this check); 123 re-initialisations in its 1 000 steps after the best residual.
#: Honest runs with the most: table3-catheter1 inertial, CVODE 23 in 13 028 steps, IDA 25 in
#: 6 898. Pseudo-time is no test here: those honest runs also crawl (1 000 steps in 0.004
#: first-mode periods: the period is the catheter's, the tendon is much faster). Nor is a
#: residual frozen at the tightest tolerances: the same scene with K_L = 1e4 freezes there
#: at 3.7e-4 after 4 tightenings and still converges (step 1 812, 6 finish attempts).
FLIP_REINITS = 50

#: The wall-time budget is checked every this many steps (a step costs ~0.1 ms).
BUDGET_STRIDE = 16

#: After a failed Newton finish at residual r, the next is tried below this × r (0.1 before:
#: table3-catheter1 CVODE 340 → 264 steps, catheter2 286 → 233, other scenes unchanged).
RETRY_FACTOR = 0.3

#: First homotopy step of the finish on a non-conservative model with stiff penalties
#: (SundialsIntegrator.homotopy), and the smallest before it gives up.
HOMOTOPY_FIRST_STEP = 0.5
HOMOTOPY_MIN_STEP = 1e-3

#: Options CVODE and IDA share (pseudo-dynamics and tolerances).
PSEUDO_DYNAMICS_PARAMETERS = (
    Parameter("formulation", "str", "overdamped", "-",
              "'inertial' (damped second order, Eqs. 10–11) or 'overdamped' (gradient flow)",
              choices=FORMULATIONS),
    Parameter("damping_ratio", "float", 1.0, "-",
              "ζ: damping rate c = 2 ζ ω₁ of the first bending mode", 0.0, 1e6,
              exclusive_minimum=True),
    Parameter("mass_scaling", "float", 1e3, "-",
              "raise masses so no coordinate's own frequency exceeds this × ω₁ (0: physical "
              "masses)", 0.0, 1e12),
    Parameter("load_ramp", "float", 1.0, "-",
              "ramp the loads in over this many first-mode periods 2π/ω₁ (0: step load)",
              0.0, 1e6),
    Parameter("rtol", "float", 1e-4, "-", "relative tolerance of the time stepping",
              1e-15, 1e-1),
    Parameter("atol", "float", 1e-4, "-",
              "absolute tolerance, relative to each variable's scale (L for positions, 1 for "
              "quaternions, L ω₁ for velocities)", 1e-20, 1e-1),
    Parameter("linear_solver", "str", "auto", "-",
              "'band', 'band_gmres' (GMRES with the exact band LU as preconditioner: band "
              "storage only), 'sparse' (SuperLU_MT) or 'auto' (band up to "
              f"{BAND_LIMIT} unknowns, band_gmres above)",
              choices=LINEAR_SOLVERS),
    Parameter("max_steps", "int", 200_000, "-", "give up after this many steps", 1,
              100_000_000),
    Parameter("newton_switch", "float", 0.1, "-",
              "finish with Newton on F(x) = 0 once the scaled residual is below this (0: "
              "integrate all the way to the tolerance)", 0.0, 1.0),
    Parameter("newton_iterations", "int", 20, "-",
              "Newton iterations of one finishing attempt (a failed attempt goes back to "
              "integrating)", 1, 10_000),
)


class SundialsIntegrator(Integrator):
    """Shared loop of :class:`~rodsim.solvers.cvode.Cvode` and
    :class:`~rodsim.solvers.ida.Ida`; subclasses build the system and the solver."""

    parameters = PSEUDO_DYNAMICS_PARAMETERS

    def __init__(self, model: Model, *args: Any, **kwargs: Any) -> None:
        super().__init__(model, *args, **kwargs)
        omega = first_mode_frequency(model)
        self.omega = omega
        #: First-mode period 2π/ω₁ [s], the pseudo-time unit of the ramp and the run's tests.
        self.period = 2.0 * math.pi / omega
        # A warm start (from a nearby equilibrium) takes the loads in full at once.
        self.ramp = LoadRamp(0.0 if self.warm else self.options.load_ramp * self.period)
        #: Pseudo-time at which the run gives up (10⁹ first-mode periods).
        self.horizon = 1e9 * self.period
        self.counts["reinits"] = 0
        self.counts["tightenings"] = 0
        # SUNDIALS' own Newton iterations and linear solves are not reported by scikit-sundae.
        self.counts["newton_iters"] = self.counts["linear_solves"] = float("nan")
        #: Factor applied to rtol and atol (divided by 100 at each tightening).
        self.tightening = 1.0
        self.masses = pseudo_masses(model, self.options.mass_scaling)
        self.build_system()

    @property
    def rtol(self) -> float:
        return self.options.rtol * self.tightening

    def linear_solver(self, size: int) -> str:
        choice = self.options.linear_solver
        if choice == "auto":
            return "band" if size <= BAND_LIMIT else "band_gmres"
        return choice

    def advice(self) -> str:
        other = "inertial" if self.options.formulation == "overdamped" else "overdamped"
        return (f"try solver.{self.name}.formulation={other!r}, a longer load_ramp, or the "
                "static integrator")

    def coordinate_scale(self) -> np.ndarray:
        """Size of each model coordinate, for absolute tolerances: L_ref for positions, 1 for
        quaternion coordinates."""
        model = self.model
        return np.where(model.is_quaternion, 1.0, model.length_scale)

    def common_options(self, solver_kind: str, band: tuple[int, int], pattern: Any,
                       inertial: bool) -> dict[str, Any]:
        """Options CVODE and IDA share: linear solver (band widths or sparsity), tolerances,
        BDF order (≤ 2 for the inertial form, see rodsim/solvers/cvode.py) and first step
        (while the load ramp starts the right-hand side vanishes, and SUNDIALS' own estimate
        of the first step would be unbounded)."""
        options: dict[str, Any] = {"linsolver": solver_kind,
                                   "rtol": max(self.rtol, TIGHTEST_RTOL),
                                   "max_order": 2 if inertial else 5,
                                   "first_step": 1e-4 / self.omega}
        if solver_kind == "band":
            options.update(lband=band[0], uband=band[1])
        elif solver_kind == "band_gmres":
            options["linsolver"] = "gmres"
        else:
            options.update(sparsity=pattern)
        return options


    @abstractmethod
    def build_system(self) -> None:
        """(Re)build the first-order system from the model's current pattern."""

    @abstractmethod
    def start(self, t: float, y: np.ndarray, yp: np.ndarray | None) -> Any:
        """A new SUNDIALS solver initialised at (t, y[, y′])."""

    @abstractmethod
    def initial_state(self) -> np.ndarray:
        """y at t = 0 (:attr:`start_state`, at rest)."""

    @abstractmethod
    def positions_of(self, y: np.ndarray) -> np.ndarray:
        """The model coordinates x inside y."""

    def equilibrium_force(self, y: np.ndarray, force: np.ndarray) -> np.ndarray:
        """The force whose vanishing is this integrator's equilibrium (default: F itself)."""
        return force

    def screened_residual(self, y: np.ndarray) -> float:
        """The scaled residual of the last F the right-hand side computed (``_last_force``,
        which the right-hand side keeps: at the corrector's last iterate, so close to, not
        exactly at, the accepted y). It screens the equilibrium test, so an accepted step
        costs no extra evaluation of F."""
        return self.model.residual(self.equilibrium_force(y, self._last_force))

    def finish_start(self, y: np.ndarray) -> np.ndarray:
        """The state the Newton finish starts from, given the solver state ``y``: here the
        model coordinates x (IDA keeps y, multipliers included)."""
        return self.positions_of(y).copy()

    def finish_newton(self, state: np.ndarray) -> tuple[bool, np.ndarray, int]:
        """One Newton solve of the finish from ``state`` (see :meth:`finish_start`) on the
        current model: (converged, the state it reached, iterations). Here Newton on
        F(x) = 0; IDA solves its constrained equilibrium instead.

        On a non-conservative model whose penalties are stiffer than ``static``'s
        penalty_ratio (the paper's tendon coupling), Newton at the full penalties does not
        converge until the residual is ~1e-6 (measured on table3-catheter1: 20 iterations
        without convergence from 2.4e-2 and from 2.1e-3), nor does Newton with those penalties
        lowered from 2.4e-2 (20 iterations). So, as ``static`` does, the finish first solves
        with the penalties lowered to that ratio — by residual homotopy, F(x) = (1 − λ) F(x₀)
        for λ from 0 to 1 (:meth:`homotopy`) — whose equilibrium is next to the full one, then
        Newton at the full penalties from there. Both through the retraction
        :meth:`Model.step`."""
        converged, state, iterations = self.at_lowered_penalties(state)
        if not converged:
            return False, state, iterations
        converged, state, more = self.newton_equilibrium(
            state, 1.0, self.options.newton_iterations, "the Newton finish",
            retraction="lengths")
        return converged, state, iterations + more

    def at_lowered_penalties(self, x: np.ndarray) -> tuple[bool, np.ndarray, int]:
        """The positions ``x`` taken to the equilibrium of :attr:`model` with its stiff
        penalties lowered (:meth:`lowered_penalties`) by :meth:`homotopy`, where a Newton
        finish at the full penalties then converges; ``x`` itself, with no iteration, when
        nothing needs lowering. (converged, positions, iterations)."""
        lowered = self.lowered_penalties()
        if not lowered:
            return True, x, 0
        model = self.model
        self.model = model.with_term_scales(lowered)
        try:
            return self.homotopy(x)
        finally:
            self.model = model

    def homotopy(self, x: np.ndarray) -> tuple[bool, np.ndarray, int]:
        """Solve F(x) = 0 on :attr:`model` from ``x`` by residual homotopy: Newton on
        F(y) − (1 − λ) F(x) = 0 (x solves it at λ = 0) for λ rising in steps from
        :data:`HOMOTOPY_FIRST_STEP`, quartered after a failure and doubled after an easy
        step, as ``static``'s load continuation. (converged, state, iterations).

        Measured on table3-catheter1 (first finish at step 146, residual 2.4e-2): first
        step 1/2 13 iterations, 1/4 18, 1/8 21, 1 (plain Newton first) 38; CVODE 264 → 146
        steps, the finish 35 → 23 iterations."""
        from rodsim.solvers.newton import NewtonProblem, newton

        model = self.model
        start = self.force(x)
        lam, step, total = 0.0, HOMOTOPY_FIRST_STEP, 0
        while lam < 1.0:
            target = min(1.0, lam + step)
            shift = (1.0 - target) * start
            problem = NewtonProblem(
                force=lambda y, shift=shift: self.force(y) - shift,
                jacobian=lambda y: self.jacobian_data(y),
                linear=self.newton_linear_solver(), residual=model.residual,
                weight=model.residual_weight, step=model.step)
            outcome = newton(problem, x, self.tolerance, self.options.newton_iterations,
                             polish=False,
                             check=self.iteration_check(f"the Newton finish (homotopy "
                                                        f"{target:.3g})"))
            total += outcome.iterations
            if not outcome.converged:
                step *= 0.25
                if step < HOMOTOPY_MIN_STEP:
                    return False, x, total
                continue
            x, lam = outcome.x, target
            if outcome.iterations <= 6:
                step = min(1.0, 2.0 * step)
        return True, x, total

    def lowered_penalties(self) -> dict[int, float]:
        """Scales lowering the penalties of a non-conservative :attr:`model` to
        :data:`~rodsim.solvers.static.DEFAULT_PENALTY_RATIO` (empty if it is conservative or has
        none that stiff)."""
        from rodsim.solvers.static import DEFAULT_PENALTY_RATIO as ratio

        if self.model.conservative:
            return {}
        return {k: ratio / term.penalty_ratio for k, term in enumerate(self.model.terms)
                if term.penalty and term.penalty_ratio > ratio}

    def stall(self, steps: int, span: float, best: float, residual: float,
              reinits: int) -> None:
        """Raise the SolverFailure of a stalled run: ``steps`` steps over ``span`` of
        pseudo-time without halving the best residual ``best`` (now ``residual``), with
        ``reinits`` re-initialisations (tendon re-registrations) among them; the advice names
        what to change for what was seen."""
        periods = span / self.period
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
        if self.rtol > TIGHTEST_RTOL and not reinits:
            advice.append(f"a tighter solver.{self.name}.rtol/atol")
        other = "inertial" if self.options.formulation == "overdamped" else "overdamped"
        advice.append(f"solver.{self.name}.formulation={other!r}")
        advice.append("the static integrator (or a smaller load)")
        raise SolverFailure(what, "try " + ", or ".join(advice))

    def finish_with_newton(self, y: np.ndarray) -> np.ndarray | None:
        """:meth:`finish_newton` at full load from ``y``, repeated while the tendon
        registration changes; the equilibrium x, or None (model and system as they were) if
        it fails or lands on an unstable equilibrium (rodsim/core/stability.py: the integration
        then goes on, and may leave it).

        Its evaluations are counted apart from the integration's (``finish_*`` statistics)."""
        model, system, counts = self.model, self.system, self.counts
        before = counts["force_evals"], counts["jacobian_evals"]
        try:
            state = self.finish_start(y)
            for _ in range(MAX_SETTLES + 1):
                converged, state, iterations = self.finish_newton(state)
                counts["finish_newton_iters"] += iterations
                if not converged:
                    break
                x = self.finish_positions(state)
                if self.reregister(x) or not self.settled(x):
                    self.build_system()
                    continue
                if not self.stability(x).stable:
                    # Newton converges to the nearest equilibrium, stable or not (a compressed
                    # column's straight branch); the pseudo-dynamics leave an unstable one.
                    counts["finish_unstable"] += 1
                    break
                return x
            self.model, self.system = model, system
            return None
        finally:
            counts["finish_force_evals"] += counts["force_evals"] - before[0]
            counts["finish_jacobian_evals"] += counts["jacobian_evals"] - before[1]
            counts["force_evals"], counts["jacobian_evals"] = before

    def finish_positions(self, state: np.ndarray) -> np.ndarray:
        """The model coordinates in a state reached by :meth:`finish_newton`."""
        return state

    def advance(self) -> Outcome:
        opts, counts = self.options, self.counts
        switch = opts.newton_switch
        for key in ("finish_attempts", "finish_newton_iters", "finish_force_evals",
                    "finish_jacobian_evals", "finish_unstable"):
            counts[key] = 0
        t, y, yp = 0.0, self.initial_state(), None
        solver = self.start(t, y, yp)
        # Pseudo-time already elapsed in solvers that were replaced (reinits, tightenings):
        # a new solver restarts its clock at the end of the load ramp, where the dynamics are
        # autonomous, so its first step is not lost against a huge t.
        elapsed = 0.0
        best, best_step, best_time = np.inf, 0, 0.0
        reinits_at_best = 0.0
        previous, frozen = [np.inf, np.inf], 0  # the residuals one and two steps back

        def restart(t: float, y: np.ndarray) -> tuple[Any, float]:
            nonlocal elapsed
            if t > self.ramp.duration:
                elapsed += t - self.ramp.duration
                t = self.ramp.duration
            return self.start(t, y, None), t

        # SUNDIALS prints its failure text to stdout (scikit-sundae's error handler): each step
        # writes there into one buffer, so it lands in rodsim's diagnostic, not in the middle
        # of rodsim run's summary, while progress callbacks print as usual.
        printed = io.StringIO()

        def step_quietly(solver: Any) -> Any:
            saved, sys.stdout = sys.stdout, printed
            try:
                return solver.step(self.horizon, method="onestep")
            finally:
                sys.stdout = saved

        for step in range(1, opts.max_steps + 1):
            if t >= self.horizon:  # steps that large mean a stalled corrector: tighten
                if self.rtol <= TIGHTEST_RTOL:
                    return Outcome(self.positions_of(y), False,
                                   f"not at equilibrium by t = {t + elapsed:.3g} s")
                self.tightening /= 100.0
                counts["tightenings"] += 1
                solver, t = restart(t, y)
            out = step_quietly(solver)
            counts["steps"] = step
            if not out.success:
                detail = " ".join(printed.getvalue().split())
                return Outcome(self.positions_of(y), False,
                               f"{self.name.upper()} error: {out.message}"
                               + (f" SUNDIALS: {detail}" if detail else ""))
            t, y, yp = float(out.t), out.y.copy(), getattr(out, "yp", None)
            x = self.positions_of(y)
            self.checkpoint(x, lambda step=step, t=t + elapsed: f"step {step} (t = {t:.4g} s)")
            if step % BUDGET_STRIDE == 0:
                self.check_budget(f"step {step} (t = {t + elapsed:.4g} s)")
            if self.reregister(x):
                # A tendon point changed parent (§4.1): new pattern, new solver, same state.
                counts["reinits"] += 1
                self.build_system()
                solver, t = restart(t, y)
                continue
            if t < self.ramp.duration:
                continue
            residual = self.screened_residual(y)
            self.history.record(t + elapsed, x, residual)
            if self.reporting:
                self.report(None, f"{self.name}: t = {t + elapsed:.3g} s, residual "
                            f"{residual:.2e}")
            if residual < switch:
                counts["finish_attempts"] += 1
                finished = self.finish_with_newton(y)
                if finished is not None:
                    return Outcome(finished, True, "at equilibrium (Newton finish)")
                switch = RETRY_FACTOR * residual  # try again once closer
            if residual < 10.0 * self.tolerance:
                residual = self.model.residual(self.equilibrium_force(y, self.force(x)))
                if self.at_equilibrium(residual):
                    if self.settled(x):
                        return Outcome(x.copy(), True, "at equilibrium")
                    # A parent changed without hysteresis: go on, on the new pattern.
                    counts["reinits"] += 1
                    self.build_system()
                    solver, t = restart(t, y)
                    continue
            repeats = min(abs(residual - r) for r in previous) < FROZEN_CHANGE * residual
            frozen = frozen + 1 if repeats else 0
            previous = [residual, previous[0]]
            if residual < 0.5 * best:
                best, best_step, best_time = residual, step, t + elapsed
                reinits_at_best = counts["reinits"]
                continue
            stalled = (step - best_step > STALL_STEPS
                       and t + elapsed - best_time > STALL_PERIODS * self.period)
            flipping = counts["reinits"] - reinits_at_best >= FLIP_REINITS
            if flipping:
                self.stall(step - best_step, t + elapsed - best_time, best, residual,
                           int(counts["reinits"] - reinits_at_best))
            if self.rtol > TIGHTEST_RTOL and (frozen >= FROZEN_STEPS or stalled):
                self.tightening /= 100.0
                counts["tightenings"] += 1
                best, best_step, best_time = residual, step, t + elapsed
                reinits_at_best = counts["reinits"]
                frozen = 0
                solver, t = restart(t, y)
        raise SolverFailure(f"not at equilibrium after max_steps = {opts.max_steps}",
                            f"try raising solver.{self.name}.max_steps, or "
                            f"{self.advice().removeprefix('try ')}")


class BandPreconditioner:
    """The Newton matrix of a SUNDIALS step, A = A₀ + c A₁ (CVODE: I − γ J, c = γ; IDA:
    ∂R/∂y + c_j ∂R/∂y′), held in its CSC pattern, factored by rodsim's band LU
    (:class:`~rodsim.solvers.linear.LinearSolver`, band storage only) and handed to SUNDIALS'
    GMRES as its preconditioner, with the product A v for the Krylov iterations. With the
    factorisation of the very matrix GMRES works on, it converges in one iteration: the same
    modified Newton as a direct band solve, without scikit-sundae's dense (n × n) template.

    :meth:`update` takes the two parts from the integrator's analytic Jacobian (once per
    SUNDIALS set-up), :meth:`factor` factors A for the current c, :meth:`solve` and
    :meth:`product` are the preconditioner solve and A v."""

    def __init__(self, pattern: Any, rows: np.ndarray, cols: np.ndarray,
                 band: tuple[int, int]) -> None:
        import scipy.sparse as sp

        from rodsim.solvers.linear import LinearSolver

        self._sp = sp
        self.pattern = pattern
        self.linear = LinearSolver(pattern, rows, cols, band, symmetric=False)
        self.parts: tuple[np.ndarray, np.ndarray] | None = None
        self.matrices: tuple[Any, Any] | None = None
        self.c = 0.0
        self._solve: Callable[[np.ndarray], np.ndarray] | None = None

    def update(self, constant: np.ndarray, per_c: np.ndarray) -> None:
        self.parts = constant, per_c
        n = self.pattern.shape[0]
        self.matrices = tuple(self._sp.csc_matrix((data, self.pattern.indices,
                                                   self.pattern.indptr), shape=(n, n))
                              for data in self.parts)

    def factor(self, c: float) -> None:
        assert self.parts is not None
        self.c = c
        self._solve = self.linear.factorized(self.parts[0] + c * self.parts[1])
        if self._solve is None:
            raise SolverFailure("the Newton matrix of a step is singular")

    def solve(self, rhs: np.ndarray, out: np.ndarray) -> None:
        assert self._solve is not None
        out[:] = self._solve(rhs)

    def product(self, v: np.ndarray, out: np.ndarray, c: float) -> None:
        assert self.matrices is not None
        out[:] = self.matrices[0] @ v + c * (self.matrices[1] @ v)


def jacobian_writer(solver_kind: str, rows: np.ndarray,
                    cols: np.ndarray) -> Callable[[np.ndarray, np.ndarray], None]:
    """``write(jj, data)``: put Jacobian values given in CSC pattern order into the array
    SUNDIALS hands a ``jacfn`` — for the band solver a full (n, n) array (only the band is
    read), for the sparse solver the CSC data itself."""
    if solver_kind == "band":
        def write(jj: np.ndarray, data: np.ndarray) -> None:
            jj[rows, cols] = data
    else:
        def write(jj: np.ndarray, data: np.ndarray) -> None:
            jj[:] = data
    return write


def started(name: str, solver_class: type, function: Callable, jacfn: Callable, t: float,
            *initial: np.ndarray, **options: Any) -> Any:
    """A scikit-sundae solver (``CVODE`` or ``IDA``, called ``name`` in diagnostics) with our
    analytic ``jacfn``, initialised at ``t`` from ``initial`` (y, or y and y′). Its warning
    that its own sparse finite-difference Jacobian goes unused is expected and silenced.
    A set-up failure —
    scikit-sundae raises RuntimeError for some (e.g. a failed consistent-initial-condition
    solve, IDACalcIC) and reports others as an unsuccessful ``init_step`` — is a
    :class:`SolverFailure` carrying SUNDIALS' own text."""
    where = f"{name} could not start at t = {t:.4g} s"
    with captured_sundials_messages() as printed:
        try:
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", "Custom sparse Jacobian", UserWarning)
                solver = solver_class(function, jacfn=jacfn, **options)
            initialised = solver.init_step(t, *initial)
        except RuntimeError as exc:
            raise SolverFailure(f"{where}: {exc}") from None
    if not initialised.success:
        raise SolverFailure(f"{where}: {initialised.message} "
                            + " ".join(printed.getvalue().split()))
    return solver


@contextlib.contextmanager
def captured_sundials_messages() -> Iterator[io.StringIO]:
    """Capture what SUNDIALS reports on a failure: scikit-sundae's error handler prints it
    to stdout, where it would land in the middle of ``rodsim run``'s summary; rodsim puts it
    in its own diagnostic instead."""
    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        yield buffer
