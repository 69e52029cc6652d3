"""SUNDIALS CVODE (variable-order adaptive BDF, via scikit-sundae) to equilibrium.

Integrates the pseudo-dynamics of :mod:`rodsim.integrators.pseudo_dynamics` (``inertial`` or
``overdamped``) with the analytic Jacobian handed to CVODE's ``jacfn``, using the band
solver (the default below :data:`BAND_LIMIT` unknowns) or SuperLU_MT with the fixed sparsity
pattern. The inertial form is limited to BDF order 2: BDF 3–5 are not A-stable, and the
lightly damped stiff oscillations of a second-order system sit next to the imaginary axis
(orders 3–5 were measured to stall there; docs/benchmarks.md).

CVODE is advanced one internal step at a time; once the load ramp is complete, the scaled
force residual is checked after each step and the run stops as soon as it is below the
tolerance — at equilibrium, not at an arbitrary final time. Non-finite states, CVODE
errors, the step budget and the wall-time budget all end the run with a diagnostic.

Quaternion norm: held by the centerline penalty Eq. (9) only (same model as ``static``).
"""

from __future__ import annotations

import math

import numpy as np
from sksundae.cvode import CVODE

from rodsim.integrators.base import History, Integrator, Outcome, SolverFailure
from rodsim.integrators.pseudo_dynamics import (
    FORMULATIONS,
    FirstOrderSystem,
    LoadRamp,
    damping_rate,
    first_mode_frequency,
)
from rodsim.model import Model
from rodsim.schema import Parameter

#: Above this many unknowns the band solver's dense (n × n) Jacobian template costs too much
#: memory (scikit-sundae hands band Jacobians to Python as a full array); ``linear_solver =
#: "auto"`` then switches to the sparse solver.
BAND_LIMIT = 4000

#: Parameters CVODE and IDA share (pseudo-dynamics and tolerances).
PSEUDO_DYNAMICS_PARAMETERS = (
    Parameter("formulation", "str", "inertial", "-",
              "'inertial' (damped second order, Eqs. 10–11) or 'overdamped' (gradient flow)",
              choices=FORMULATIONS),
    Parameter("damping_ratio", "float", 1.0, "-",
              "ζ: damping rate c = 2 ζ ω₁ of the first bending mode", 0.0, 1e6,
              exclusive_minimum=True),
    Parameter("load_ramp", "float", 1.0, "-",
              "ramp the loads in over this many first-mode periods 2π/ω₁ (0: step load)",
              0.0, 1e6),
    Parameter("rtol", "float", 1e-4, "-", "relative tolerance of the time stepping",
              1e-15, 1e-1),
    Parameter("atol", "float", 1e-7, "-",
              "absolute tolerance, relative to each variable's scale (L for positions, 1 for "
              "quaternions, L ω₁ for velocities)", 1e-20, 1e-1),
    Parameter("linear_solver", "str", "auto", "-",
              f"'band', 'sparse' (SuperLU_MT) or 'auto' (band up to {BAND_LIMIT} unknowns)",
              choices=("auto", "band", "sparse")),
    Parameter("max_steps", "int", 200_000, "-", "give up after this many steps", 1,
              100_000_000),
)


class Cvode(Integrator):
    """CVODE BDF on the inertial or overdamped pseudo-dynamics, stopped at equilibrium."""

    name = "cvode"
    summary = "SUNDIALS CVODE (adaptive BDF) on damped pseudo-dynamics, stopped at equilibrium"
    quaternion_norm = "penalty Eq. (9) only (|d3| = |q|² is pulled to 1)"
    parameters = PSEUDO_DYNAMICS_PARAMETERS

    def __init__(self, model: Model, *args, **kwargs) -> None:
        super().__init__(model, *args, **kwargs)
        opts = self.options
        self.rate = damping_rate(model, opts["damping_ratio"])
        self.ramp = LoadRamp(opts["load_ramp"] * 2.0 * math.pi / first_mode_frequency(model))
        self.system = FirstOrderSystem(model, opts["formulation"], self.rate)
        #: Pseudo-time at which the run gives up (10⁹ first-mode periods).
        self.horizon = 1e9 * 2.0 * math.pi / first_mode_frequency(model)
        solver = opts["linear_solver"]
        if solver == "auto":
            solver = "band" if self.system.size <= BAND_LIMIT else "sparse"
        self.linear_solver = solver

    def advice(self) -> str:
        return ("try --set solver.cvode.formulation=overdamped, a longer load_ramp, or "
                "--integrator static")

    def _tolerances(self) -> np.ndarray:
        model, system = self.model, self.system
        scale_x = np.where(model.is_quaternion, 1.0, model.length_scale)
        if system.formulation == "overdamped":
            scale = scale_x
        else:
            scale = np.empty(system.size)
            scale[0::2] = scale_x
            scale[1::2] = scale_x * self.rate
        return self.options["atol"] * scale

    def _callbacks(self):
        system, model, ramp = self.system, self.model, self.ramp
        counts = self.counts

        def rhs(t: float, y: np.ndarray, yp: np.ndarray) -> None:
            counts["force_evals"] += 1
            system.rhs(y, model.force(system.positions_of(y), ramp(t)), yp)

        def jacobian(t: float, y: np.ndarray) -> np.ndarray:
            counts["jacobian_evals"] += 1
            return system.jacobian_data(model.jacobian_data(system.positions_of(y), ramp(t)))

        if self.linear_solver == "sparse":
            def jacfn(t: float, y: np.ndarray, yp: np.ndarray, jj: np.ndarray) -> None:
                jj[:] = jacobian(t, y)
        else:
            rows, cols = system.pattern_rows, system.pattern_cols

            def jacfn(t: float, y: np.ndarray, yp: np.ndarray, jj: np.ndarray) -> None:
                jj[rows, cols] = jacobian(t, y)

        return rhs, jacfn

    def advance(self) -> Outcome:
        opts, system = self.options, self.system
        rhs, jacfn = self._callbacks()
        kwargs = {"linsolver": self.linear_solver, "jacfn": jacfn, "rtol": opts["rtol"],
                  "atol": self._tolerances(),
                  "max_order": 2 if system.formulation == "inertial" else 5,
                  # The RHS vanishes at t = 0 while the load ramp starts: CVODE's own first
                  # step estimate would then be unbounded.
                  "first_step": 1e-4 / first_mode_frequency(self.model)}
        if self.linear_solver == "band":
            kwargs.update(lband=system.band[0], uband=system.band[1])
        else:
            kwargs.update(sparsity=system.pattern)
        solver = CVODE(rhs, **kwargs)
        y = system.initial_state()
        solver.init_step(0.0, y)
        history = History(self.model)
        t = 0.0
        for step in range(1, opts["max_steps"] + 1):
            where = f"step {step} (t = {t:.4g} s)"
            self.check_budget(where)
            out = solver.step(self.horizon, method="onestep")
            if not out.success:
                return Outcome(system.positions_of(y), False, f"CVODE error: {out.message}",
                               where, {"steps": step}, history.data)
            y, t = out.y, float(out.t)
            x = system.positions_of(y)
            if t < self.ramp.duration:
                continue
            try:
                residual = self.model.residual(self.force(x))
            except SolverFailure as exc:
                return Outcome(x, False, str(exc), where, {"steps": step}, history.data)
            history.record(t, x, residual)
            self.report(None, f"cvode: t = {t:.3g} s, residual {residual:.2e}")
            if self.at_equilibrium(residual):
                return Outcome(x.copy(), True, "at equilibrium", f"t = {t:.4g} s",
                               {"steps": step}, history.data)
        return Outcome(system.positions_of(y).copy(), False,
                       f"not at equilibrium after max_steps = {opts['max_steps']}",
                       f"t = {t:.4g} s", {"steps": opts["max_steps"]}, history.data)
