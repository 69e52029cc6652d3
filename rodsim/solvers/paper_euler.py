"""The paper's integrator: damped semi-implicit (backward) Euler, Eqs. (14)–(19).

Each step solves the nonlinear system of Eq. (19) for the next state y = x^{t+h},

    f(y) = x^t + ξ h ẋ^t + h² M⁻¹ F(y) − y = 0,

multiplied through by M so the Jacobian −M + h² ∂F/∂x stays symmetric, by Newton's method
with a band (Cholesky or LU) or sparse LU solve per iteration; then ẋ^{t+h} = (y − x^t)/h.
ξ ∈ [0, 1] scales the carried-over velocity (ξ = 1: plain backward Euler; smaller ξ damps
more). ``h2_omega2`` > 0 scales M so that h² ω₁² takes that value
(``PaperEuler.mass_scale``, docs/design.md, erratum 12): the regime in which the paper's Fig. 8
ordering of ξ can appear. The Jacobian is the model's analytic one, or —
``jacobian = "finite_difference"``,
the paper's MATLAB cost model (fsolve with JacobPattern) — forward differences over the
sparsity pattern with columns grouped so that each group costs one force evaluation.

At rest when the scaled force residual is below ``solver.tolerance`` (same criterion as
every integrator). Quaternion norm: held by the centerline penalty Eq. (9) only, as in the
paper.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from rodsim.core.model import Model
from rodsim.core.schema import Options, option
from rodsim.solvers.base import (
    LARGE_MODEL_SIZE,
    Integrator,
    Outcome,
    SolverFailure,
    correction_size,
    retraction_of,
)
from rodsim.solvers.newton import NewtonProblem, newton
from rodsim.solvers.pseudo_dynamics import first_mode_frequency
from rodsim.solvers.run_state import RunState
from rodsim.solvers.tolerance import CORRECTION_TOLERANCE, effective_tolerance


def column_groups(pattern: sp.csc_matrix) -> list[np.ndarray]:
    """Greedy colouring of the columns: columns in one group share no row of ``pattern``.

    One forward difference per group then recovers every entry of a Jacobian with this
    sparsity (Curtis–Powell–Reid), as MATLAB's JacobPattern does.
    """
    n = pattern.shape[1]
    pattern = pattern.tocsc()
    rows_of = [pattern.indices[pattern.indptr[j]:pattern.indptr[j + 1]] for j in range(n)]
    row_color: list[set[int]] = [set() for _ in range(pattern.shape[0])]
    color = np.empty(n, dtype=int)
    for j in range(n):
        used = set().union(*(row_color[r] for r in rows_of[j])) if len(rows_of[j]) else set()
        c = 0
        while c in used:
            c += 1
        color[j] = c
        for r in rows_of[j]:
            row_color[r].add(c)
    return [np.flatnonzero(color == c) for c in range(color.max() + 1)]


#: Consecutive steps with the residual below the tolerance before the rod is at rest. With
#: one, a run kept up to 1.3× the declared distance to ``static`` at N = 320–1000 (the
#: residuals of all nodes add up; tests/test_integrators.py); with two, 0.97× at N = 320.
RESTING_STEPS = 3


@dataclass(frozen=True, kw_only=True)
class PaperOptions(Options):
    """``[solver.paper]``: the paper's damped semi-implicit Euler, Eqs. (14)–(19), each
    option declared once by its field (``rodsim.core.schema.option``;
    ``PaperEuler.parameters`` is made from them)."""

    h: float = option(0.3, "s", "time step Δt (Table 1: 0.3 s; Table 3: 0.2 s)", 0.0, 1e3,
                      exclusive_minimum=True)
    xi: float = option(0.9, "-", "damping constant ξ (velocity kept per step)", 0.0, 1.0)
    jacobian: str = option(
        "analytic", "-",
        "'analytic' or 'finite_difference' (over the sparsity pattern, as MATLAB)",
        choices=("analytic", "finite_difference"))
    max_steps: int = option(100_000, "-", "give up after this many steps", 1, 100_000_000)
    max_newton: int = option(50, "-", "Newton iterations per step", 1, 10_000)
    ramp_steps: int = option(
        0, "-", "apply the loads in equal increments over this many steps (0: all at once, "
        "as the paper)", 0, 1_000_000)
    h2_omega2: float = option(
        0.0, "-", "0: physical masses; > 0: the mass matrix scaled so that h² ω₁² equals "
        "this (the paper's Fig. 8 regime is ≈ 0.003; docs/design.md, erratum 12)", 0.0, 1e6)


@dataclass(eq=False, kw_only=True)
class PaperState(RunState):
    """A paper run's state: the (scaled) masses, and the diagonal positions and FD column
    groups of the pattern of ``pattern_of`` (refreshed when the registration changes)."""

    mass: np.ndarray
    diag: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    groups: list[np.ndarray] = field(default_factory=list)
    pattern_of: Model | None = None


class PaperEuler(Integrator[PaperState]):
    """Eq. (17)/(19): fixed step h, damping ξ, one Newton root solve per step."""

    Options = PaperOptions
    options: PaperOptions

    name = "paper"
    summary = "the paper's damped implicit Euler, Eqs. (17)/(19): fixed h, damping ξ"
    quaternion_norm = "penalty Eq. (9) only (|d3| = |q|² is pulled to 1), as in the paper"
    State = PaperState

    def state_fields(self, model: Model, warm: bool) -> dict[str, Any]:
        return {"mass": model.pseudo_time_masses() * self.mass_scale(model)}

    def prepare(self, run: PaperState) -> None:
        self._refresh_pattern(run)

    def mass_scale(self, model: Model) -> float:
        """Factor on M that puts h² ω₁² at ``h2_omega2`` (1 when it is 0).

        ω₁ = 1.875² √(E I / (ρ A L⁴)) is the first rod's first cantilever mode. Only the path
        to rest depends on M — the equilibrium F(x) = 0 does not — so the factor changes
        how many steps ξ needs, not where the rod comes to rest. With Table 1 in SI units
        h² ω₁² ≈ 26 at h = 0.3 s: backward Euler then damps the slowest mode several-fold per
        step whatever ξ is. ξ = 0.9 damps that mode critically where (1 − √ξ)² ≈ h² ω₁²,
        i.e. h² ω₁² ≈ 0.003 — about 1e4 times the physical mass per stiffness.
        """
        target = self.options.h2_omega2
        if target == 0.0:
            return 1.0
        return float((self.options.h * first_mode_frequency(model)) ** 2 / target)

    def _refresh_pattern(self, run: PaperState) -> None:
        """Diagonal positions and FD column groups of the run's model's current pattern."""
        model = run.model
        if run.pattern_of is model:
            return
        diag = np.flatnonzero(model.pattern_rows == model.pattern_cols)
        run.diag = diag[np.argsort(model.pattern_cols[diag])]
        run.groups = (column_groups(model.pattern)
                      if self.options.jacobian == "finite_difference" else [])
        run.pattern_of = model

    def advice(self, run: RunState | None = None) -> str:
        return ("try applying the load in increments (solver.paper.ramp_steps=20), a "
                "smaller step (solver.paper.h=...), more Newton iterations per step "
                "(solver.paper.max_newton=200), or the cvode integrator")

    def _stiffness(self, run: PaperState, y: np.ndarray, force: np.ndarray,
                   load: float) -> np.ndarray:
        """∂F/∂x at y in pattern order: analytic, or grouped forward differences."""
        if self.options.jacobian == "analytic":
            return run.jacobian_data(y, load)
        model = run.model
        data = np.zeros(model.nnz)
        rows, cols = model.pattern_rows, model.pattern_cols
        for group in run.groups:
            delta = np.sqrt(np.finfo(float).eps) * np.maximum(np.abs(y[group]), 1e-3)
            shifted = y.copy()
            shifted[group] += delta
            diff = run.force(shifted, load) - force
            step = np.zeros(model.n)
            step[group] = delta
            in_group = step[cols] != 0.0
            data[in_group] = diff[rows[in_group]] / step[cols[in_group]]
        return data

    def _step_problem(self, run: PaperState, predictor: np.ndarray, h: float,
                      load: float, correction: Callable[[np.ndarray], float] | None = None
                      ) -> NewtonProblem:
        """Eq. (19) times M: g(y) = M(p − y) + h² F(y) = −∇Φ(y), p = x^t + ξ h ẋ^t. On a
        large model (``correction`` given, see ``advance``) the Newton steps go through
        the retraction ``static``'s default picks and stop on the correction as well."""
        model, mass = run.model, run.mass
        cache: dict[str, np.ndarray] = {}

        def force(y: np.ndarray) -> np.ndarray:
            cache["y"], cache["F"] = y, run.force(y, load)
            return mass * (predictor - y) + h * h * cache["F"]

        def jacobian(y: np.ndarray) -> np.ndarray:
            f = cache["F"] if cache.get("y") is y else run.force(y, load)
            data = h * h * self._stiffness(run, y, f, load)
            data[run.diag] -= mass
            run.counts["linear_solves"] += 1
            return data

        def potential(y: np.ndarray) -> float:
            d = y - predictor
            return 0.5 * float(d @ (mass * d)) + h * h * model.energy(y, load)

        step = None
        if correction is not None:
            step = (model.turned_step if retraction_of(model, "auto") == "frames"
                    else model.step)
        return NewtonProblem(force, jacobian, run.linear_solver(),
                             lambda g: model.force_residual(g / (h * h)),
                             model.residual_weight / (h * h),
                             potential if model.conservative else None, step=step,
                             correction=correction,
                             correction_tolerance=0.1 * CORRECTION_TOLERANCE)

    def advance(self, run: PaperState) -> Outcome:
        h, xi = self.options.h, self.options.xi
        model, counts = run.model, run.counts
        x = run.start
        v = np.zeros_like(x)
        # Each step's Newton solve goes 10× below the tolerance, but not below round-off.
        inner = effective_tolerance(model, 0.1 * run.tolerance)
        # A large model (LARGE_MODEL_SIZE): each step's Newton starts from the last state,
        # not the predictor (its linear extrapolation of positions and quaternions stretches
        # the short segments at second order: table1-50g at N = 20 000 started step 2 at a
        # residual of 1056 and failed there), steps through the retraction, and stops on the
        # correction too, 10× below the result check's (the max-norm residual alone stopped
        # the steps 3.6e-3 L from the step's root, and the run then stood still there).
        correction = correction_size(model) if model.n > LARGE_MODEL_SIZE else None
        resting = 0
        for step in range(1, self.options.max_steps + 1):
            where = f"step {step} (t = {step * h:.4g} s)"
            self.check_budget(run, where)
            predictor = x + xi * h * v
            self._refresh_pattern(run)  # registration changes the pattern between steps only
            ramp = 0 if run.warm else self.options.ramp_steps
            load = min(1.0, step / ramp) if ramp else 1.0
            solved = newton(self._step_problem(run, predictor, h, load, correction),
                            predictor if correction is None else x, inner,
                            self.options.max_newton, polish=False,
                            check=self.iteration_check(run, where))
            counts["newton_iters"] += solved.iterations
            counts["steps"] = step
            if not solved.converged:
                run.where = where
                return Outcome(x, False, f"Newton failed: {solved.message}")
            v = (solved.x - x) / h
            x = solved.x
            run.checkpoint(x, where)
            # Tendon registration is recomputed after every step (§4.1).
            moved = run.reregister(x)
            residual = run.model.force_residual(run.model.force(x, load))
            run.record(step * h, x, residual)
            self.report(None, f"paper: {where}, residual {residual:.2e}")
            # At rest: below the tolerance on RESTING_STEPS consecutive steps (see there).
            below = not moved and load == 1.0 and run.at_equilibrium(residual)
            resting = resting + 1 if below else 0
            # At rest by the force residual, the run also asks the result check (the
            # correction residual: a per-node force test lets a large N stop early, measured
            # N = 4 000: 1.2e-5 of the load's displacement from the equilibrium, 10 000:
            # 1.2e-4) and goes on stepping until it passes; on a large model until its
            # correction is below the step solves' (the result check's 1e-5 stopped the run
            # 1.2e-6 L from static's equilibrium at every N from 4 000 to 40 000, its last
            # correction 4.1e-6; one step more: 2.7e-8 L).
            if resting >= RESTING_STEPS and run.settled(x):
                checked = self.verified_residual(run, x)
                if self.verified(run, checked) and (
                        correction is None or checked[1] < 0.1 * CORRECTION_TOLERANCE):
                    return Outcome(x, True, "at rest")
        raise SolverFailure(f"not at rest after max_steps = {self.options.max_steps}",
                            "try raising solver.paper.max_steps, or "
                            f"{self.advice().removeprefix('try ')}")
