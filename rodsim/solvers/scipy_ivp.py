"""scipy's ``solve_ivp`` (BDF or LSODA) on the overdamped pseudo-dynamics: an outside baseline.

The same system CVODE integrates in its ``overdamped`` formulation
(``rodsim.solvers.pseudo_dynamics.FirstOrderSystem``: c M ẋ = F(x), same pseudo-masses,
damping rate, smooth load ramp and per-variable absolute tolerance scale — L for positions,
1 for quaternion coordinates), integrated by ``scipy.integrate.solve_ivp`` with the
model's analytic Jacobian (sparse for ``BDF``, whose Newton uses a sparse LU; dense for
``LSODA``, which takes only dense or packed-band Jacobians). It is there to put rodsim's own
integrators in perspective (``rodsim bench work-precision``), not as a default.

The run stops on a terminal event on the scaled residual of the full-load force,
``Model.force_residual(F(x)) − τ``; the state kept is the end of the accepted step on which the
event fired (whose residual is below τ), not scipy's interpolated root. The tendon
registration is updated after every accepted step (from the event function, which scipy
calls once at each step's end); at equilibrium a registration change restarts the
integration from that state on the new model. Non-finite forces and the wall-time budget end
the run from inside the right-hand side (through the template's ``SolverFailure``).

Quaternion norm: held by the centerline penalty Eq. (9) only (same model as ``static``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.schema import Options, option, shared_option
from rodsim.solvers.base import Integrator, Outcome, SolverFailure
from rodsim.solvers.pseudo_dynamics import (
    FirstOrderSystem,
    PseudoDynamics,
    PseudoDynamicsOptions,
)
from rodsim.solvers.run_state import RunState

#: The wall-time budget is checked every this many right-hand-side evaluations.
BUDGET_STRIDE = 16


@dataclass(frozen=True, kw_only=True)
class ScipyOptions(Options):
    """``[solver.scipy]``: scipy's ``solve_ivp`` on the pseudo-dynamics, each option declared
    once by its field (``rodsim.core.schema.option``; three shared with CVODE and IDA,
    ``shared_option``; ``ScipyIvp.parameters`` is made from them)."""

    method: str = option(
        "BDF", "-", "solve_ivp method: 'BDF' (sparse Jacobian) or 'LSODA' (dense Jacobian)",
        choices=("BDF", "LSODA"))
    damping_ratio: float = shared_option(PseudoDynamicsOptions, "damping_ratio")
    mass_scaling: float = shared_option(PseudoDynamicsOptions, "mass_scaling")
    load_ramp: float = shared_option(PseudoDynamicsOptions, "load_ramp")
    # 1e-6, not CVODE's 1e-4: scipy's BDF at 1e-4 stalls above τ on table1-20g and
    # table1-100g (its Newton stops on the update size, not on the force).
    rtol: float = option(1e-6, "-", "relative tolerance of the time stepping", 1e-13, 1e-1)
    atol: float = option(
        1e-6, "-", "absolute tolerance, relative to each variable's scale (L for positions, "
        "1 for quaternions)", 1e-20, 1e-1)


class ScipyIvp(Integrator[RunState]):
    """``scipy.integrate.solve_ivp`` (BDF or LSODA) on the overdamped pseudo-dynamics."""

    Options = ScipyOptions
    options: ScipyOptions

    name = "scipy"
    summary = ("scipy solve_ivp (BDF or LSODA) on the overdamped pseudo-dynamics, stopped at "
               "equilibrium (an outside baseline)")
    quaternion_norm = "penalty Eq. (9) only (|d3| = |q|² is pulled to 1)"
    def advice(self, run: RunState | None = None) -> str:
        return ("try a tighter solver.scipy.rtol (scipy's BDF can stall above τ: its Newton "
                "stops on the update size, not on the force), or the static or cvode "
                "integrator")

    def advance(self, run: RunState) -> Outcome:
        import scipy.sparse as sp
        from scipy.integrate import solve_ivp

        options = self.options
        method = options.method
        dynamics = PseudoDynamics.of(run.model, options, run.warm)
        omega, ramp = dynamics.omega, dynamics.ramp
        run.counts["reinits"] = 0
        systems: dict[int, FirstOrderSystem] = {}

        def system() -> FirstOrderSystem:
            """The overdamped system of the model in use (rebuilt on a re-registration)."""
            key = id(run.model)
            if key not in systems:
                systems.clear()
                systems[key] = FirstOrderSystem(run.model, "overdamped", dynamics.rate,
                                                dynamics.masses)
            return systems[key]

        def rhs(t: float, x: np.ndarray) -> np.ndarray:
            if run.counts["force_evals"] % BUDGET_STRIDE == 0:
                self.check_budget(run, f"t = {t:.4g} s")
            force = run.force(x, ramp(t))
            out = np.empty_like(x)
            system().rhs(x, force, out)
            return out

        def jacobian(t: float, x: np.ndarray) -> Any:
            sys_ = system()
            data = sys_.jacobian_data(run.jacobian_data(x, ramp(t)))
            matrix = sp.csc_matrix((data, sys_.pattern.indices, sys_.pattern.indptr),
                                   shape=(sys_.size, sys_.size))
            return matrix if method == "BDF" else matrix.toarray()

        last: dict[str, Any] = {"t": -math.inf, "x": run.start, "residual": math.inf}

        def held_residual(t: float, x: np.ndarray) -> float:
            """The run's residual at x, held above the tolerance while the load still ramps
            (equilibrium under the full load only): the same function at a step's end and
            inside it, so that the root finding sees the sign change the step ends saw."""
            residual = run.residual_at(x)
            return max(residual, 2.0 * run.tolerance) if ramp(t) < 1.0 else residual

        def at_rest(t: float, x: np.ndarray) -> float:
            if t > last["t"]:  # the end of an accepted step (root finding looks back in time)
                run.counts["steps"] += 1
                if run.reregister(x):
                    run.counts["reinits"] += 1
                residual = held_residual(t, x)
                last.update(t=t, x=x.copy(), residual=residual)
                run.checkpoint(last["x"], functools.partial("t = {:.4g} s".format, t))
                run.record(t, x, residual)
                if self.reporting:
                    self.report(None, f"{self.name} {method}: t = {t:.3g} s, residual "
                                      f"{residual:.3g}")
                return float(residual - run.tolerance)
            return held_residual(t, x) - run.tolerance  # dense output inside the last step

        at_rest.terminal = True  # type: ignore[attr-defined]
        at_rest.direction = -1  # type: ignore[attr-defined]
        scale = np.where(run.model.is_quaternion, 1.0, run.model.length_scale)
        horizon = dynamics.horizon
        t0, x0 = 0.0, run.start
        while True:
            last["t"] = t0
            solution = solve_ivp(rhs, (t0, horizon), x0, method=method, jac=jacobian,
                                 events=at_rest, rtol=options.rtol,
                                 atol=options.atol * scale, first_step=1e-4 / omega,
                                 t_eval=np.empty(0))
            if solution.status == 1 and last["residual"] < run.tolerance:
                x = last["x"]
                if run.settled(x):
                    return Outcome(x, True, f"at equilibrium (scipy {method}, terminal event)")
                t0, x0 = last["t"], x  # a parent changed at equilibrium: go on from there
                continue
            if solution.status == 0:
                raise SolverFailure(f"scipy {method} reached t = {horizon:.3g} s (10⁹ "
                                    "first-mode periods) without reaching equilibrium")
            raise SolverFailure(f"scipy {method}: {solution.message}")
