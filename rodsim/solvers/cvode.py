"""SUNDIALS CVODE (variable-order adaptive BDF, via scikit-sundae) to equilibrium.

Integrates the pseudo-dynamics of ``rodsim.solvers.pseudo_dynamics`` (``inertial`` or
``overdamped``) with the analytic Jacobian handed to CVODE's ``jacfn``, using the band
solver (the default up to ``BAND_LIMIT`` unknowns), GMRES preconditioned by rodsim's band LU
of the same Newton matrix (``band_gmres``, the default above: no dense template) or
SuperLU_MT with the fixed sparsity pattern. The inertial form is limited to BDF order 2:
BDF 3–5 are not A-stable, and the lightly damped stiff oscillations of a second-order
system sit next to the imaginary axis (orders 3–5 were measured to stall there;
docs/model.md). The run loop is ``rodsim.solvers.sundials``.

Quaternion norm: held by the centerline penalty Eq. (9) only (same model as ``static``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rodsim.solvers.base import LARGE_MODEL_SIZE
from rodsim.solvers.pseudo_dynamics import FirstOrderSystem, PseudoDynamicsOptions
from rodsim.solvers.sundials import (
    BandPreconditioner,
    SundialsIntegrator,
    SundialsState,
    jacobian_writer,
    started,
)

if TYPE_CHECKING:
    from sksundae.cvode import CVODE

#: On a large model, a Newton finish from a CVODE state that has moved less than this
#: fraction of the length scale from the rest state starts from the rest state instead
#: (:meth:`Cvode.finish_start`).
FINISH_FROM_REST = 1e-3


@dataclass(frozen=True, kw_only=True)
class CvodeOptions(PseudoDynamicsOptions):
    """``[solver.cvode]``: the shared pseudo-dynamics options as they are."""


class Cvode(SundialsIntegrator):
    """CVODE BDF on the inertial or overdamped pseudo-dynamics, stopped at equilibrium."""

    Options = CvodeOptions
    options: CvodeOptions

    name = "cvode"
    summary = "SUNDIALS CVODE (adaptive BDF) on damped pseudo-dynamics, stopped at equilibrium"
    quaternion_norm = "penalty Eq. (9) only (|d3| = |q|² is pulled to 1)"

    def finish_start(self, run: SundialsState, y: np.ndarray) -> np.ndarray:
        """The model coordinates of ``y``; on a model above
        ``rodsim.solvers.base.LARGE_MODEL_SIZE`` free coordinates without a tendon
        registration, at the first finish attempt, the rest state when no control point of
        ``y`` has moved ``FINISH_FROM_REST`` L from it (a later attempt, after Newton from
        rest failed at full load, starts where CVODE is: no static load continuation here).

        On a large model the switch to the finish (a max-norm residual below
        ``newton_switch``) comes after a few steps with the rod barely moved: the pseudo-
        dynamics have bent only a boundary layer at the load (table1-50g: the last ~10 % of
        the rod, the tip moved 6e-6 m at N = 10 000 and 1e-5 m at 100 000), which balances the
        tip force locally, so the max-norm residual, reading the imbalance now spread along
        the rod as 1/N of it, is small (5.4e-4 at N = 100 000). Newton from that layer took 6,
        12 and 38 iterations at N = 10 000, 40 000 and 100 000, from the rest state 5, 6 and 8
        (``static``'s path): the global bending step through the layer leaves a large
        second-order residual (15.5 after the first step at 100 000, 0.54 from rest), an
        indefinite stiffness and backtracking."""
        x = super().finish_start(run, y)
        model = run.model
        if (model.n <= LARGE_MODEL_SIZE or model.has_registration
                or run.counts.get("finish_attempts", 1) > 1):
            return x
        rest = model.x0
        moved = max(float(np.max(np.abs(model.positions(x, rod) - model.positions(rest, rod))))
                    for rod in model.rods)
        return rest if moved < FINISH_FROM_REST * model.length_scale else x

    def build_system(self, run: SundialsState) -> FirstOrderSystem:
        return FirstOrderSystem(run.model, self.options.formulation, run.dynamics.rate,
                                run.dynamics.masses)

    def _tolerances(self, run: SundialsState) -> np.ndarray:
        system = run.system
        scale_x = self.coordinate_scale(run.model)
        if system.formulation == "overdamped":
            scale = scale_x
        else:
            scale = np.empty(system.size)
            scale[0::2] = scale_x
            scale[1::2] = scale_x * run.dynamics.rate
        return np.asarray(self.options.atol * run.tightening * scale)

    def start(self, run: SundialsState, t: float, y: np.ndarray,
              yp: np.ndarray | None) -> CVODE:
        from sksundae.cvode import CVODE  # SUNDIALS is loaded by the first run, not at import

        system, ramp = run.system, run.dynamics.ramp
        solver_kind = self.linear_solver(system.size)
        write = jacobian_writer(solver_kind, system.pattern_rows, system.pattern_cols)

        # Every callback evaluates the model through the run's counted, checked evaluations.
        def rhs(t: float, y: np.ndarray, yp: np.ndarray) -> None:
            force = run.force(system.positions_of(y), ramp(t))
            run.last_force = force
            system.rhs(y, force, yp)

        def jacfn(t: float, y: np.ndarray, yp: np.ndarray, jj: np.ndarray) -> None:
            write(jj, system.jacobian_data(run.jacobian_data(system.positions_of(y), ramp(t))))

        options = self.common_options(run, solver_kind, system.band, system.pattern,
                                      system.formulation == "inertial")
        if solver_kind == "band_gmres":
            from sksundae.cvode import CVODEJacTimes, CVODEPrecond

            newton = BandPreconditioner(system.pattern, system.pattern_rows,
                                        system.pattern_cols, system.band)
            identity = np.zeros(system.pattern.nnz)
            identity[np.flatnonzero(system.pattern_rows == system.pattern_cols)] = 1.0

            def psetup(t: float, y: np.ndarray, fy: np.ndarray, jok: bool, jnew: list[int],
                       gamma: float) -> None:
                # M = I − γ J; J re-evaluated unless CVODE says the last one will do.
                if not jok or newton.parts is None:
                    jac = system.jacobian_data(run.jacobian_data(system.positions_of(y),
                                                                 ramp(t)))
                    newton.update(identity, -jac)
                    jnew[0] = 1
                else:
                    jnew[0] = 0
                newton.factor(gamma)

            def psolve(t: float, y: np.ndarray, fy: np.ndarray, r: np.ndarray,
                       z: np.ndarray, gamma: float, delta: float, lr: int) -> None:
                newton.solve(r, z)

            def jtimes(t: float, y: np.ndarray, fy: np.ndarray, v: np.ndarray,
                       jv: np.ndarray) -> None:
                # J v (CVODE forms v − γ J v itself): minus the part per γ of M.
                newton.product(v, jv, -1.0)
                jv -= v

            options.update(precond=CVODEPrecond(psetup, psolve, side="left"),
                           jactimes=CVODEJacTimes(None, jtimes))
            return started("CVODE", CVODE, rhs, None, t, y, atol=self._tolerances(run),
                           **options)
        return started("CVODE", CVODE, rhs, jacfn, t, y, atol=self._tolerances(run),
                       **options)
