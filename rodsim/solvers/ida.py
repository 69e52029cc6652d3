"""SUNDIALS IDA (adaptive BDF on a residual form, via scikit-sundae) to equilibrium.

The same pseudo-dynamics as CVODE (``rodsim.solvers.pseudo_dynamics``), written as a
residual R(t, y, y′) = 0, with the quaternions' unit norm carried as algebraic equations:
one multiplier μ_j per free quaternion adds the constraint force 2 μ_j q_j, and the
constraint g_j = |q_j|² − 1 = 0 is replaced by its Baumgarte-stabilised derivative so the
system has index 1 (the raw index-2/3 form fails in IDA):

- ``overdamped``: c M ẋ = F(x) + Gᵀμ,   2 q_j · q̇_j + β g_j = 0
- ``inertial``:   ẋ = v,  M v̇ = F(x) + Gᵀμ − c M v,
                  2 q_j · v̇_j + 2 |v_j|² + 2β (2 q_j · v_j) + β² g_j = 0

with β = 2ω₁. Each multiplier sits right after its quaternion in y, so the Jacobian
dR/dy + c_j dR/dy′ (analytic) keeps the band structure. Stops at equilibrium by the same
residual test as every integrator, on the constrained force F + Gᵀμ. |q| = 1 is enforced
exactly here while the other integrators only penalise it (Eq. 9); with the normalised
strains of the bending term the penalty's norm defect is below 3e-9 and does not show:
IDA (overdamped and inertial) agreed with ``static`` to within 1.6e-8 L on Table 1's
three masses, as close as the residual tolerance allows (tests/test_integrators.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rodsim.core.model import Model
from rodsim.solvers.base import LARGE_MODEL_SIZE, retraction_of
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.newton import NewtonProblem, newton
from rodsim.solvers.pseudo_dynamics import (
    ConstrainedSystem,
    PseudoDynamicsOptions,
)
from rodsim.solvers.sundials import (
    BandPreconditioner,
    SundialsIntegrator,
    SundialsState,
    jacobian_writer,
    started,
)

if TYPE_CHECKING:
    from sksundae.ida import IDA


@dataclass(frozen=True, kw_only=True)
class IdaOptions(PseudoDynamicsOptions):
    """``[solver.ida]``: the shared pseudo-dynamics options; the Newton finish switches in
    later. The constrained Newton finish (a merit line search: no energy to minimise) fails
    more often from far away than CVODE's, hence a smaller default switch
    (docs/benchmark-history.md, "IDA: the default newton_switch = 0.03")."""

    newton_switch: float = 0.03


class Ida(SundialsIntegrator):
    """IDA BDF on the constrained residual form, stopped at equilibrium."""

    Options = IdaOptions
    options: IdaOptions

    name = "ida"
    summary = "SUNDIALS IDA on the residual form with quaternion norms as algebraic equations"
    quaternion_norm = ("algebraic constraint |q|² = 1 per quaternion with a multiplier, "
                       "Baumgarte-stabilised to index 1")
    def build_system(self, run: SundialsState) -> ConstrainedSystem:
        run.last_y = None  # a new system: the last y belongs to the old one
        dynamics = run.dynamics
        return ConstrainedSystem(run.model, self.options.formulation, dynamics.rate,
                                 2.0 * dynamics.omega, dynamics.masses)

    def equilibrium_force(self, run: SundialsState, y: np.ndarray,
                          force: np.ndarray) -> np.ndarray:
        """F + Gᵀμ: IDA's equilibrium is the constrained one."""
        run.last_y = y
        return np.asarray(run.system.constrained_force(y, force))

    def residual_at(self, run: SundialsState, x: np.ndarray) -> float:
        """Residual of the constrained equilibrium F + Gᵀμ = 0 at the last IDA state."""
        y = run.last_y
        if y is None or not np.array_equal(run.system.positions_of(y), x):
            return super().residual_at(run, x)
        return run.model.force_residual(run.system.constrained_force(y, run.model.force(x)))

    def verification_force(self, run: SundialsState, model: Model,
                           x: np.ndarray) -> np.ndarray:
        """F + Gᵀμ with the multipliers recomputed from ``x`` alone (μ_j minimises the
        constrained force of quaternion j: F_j minus its component along q_j), not taken from
        the IDA state: the result's check (``Integrator.verified_residual``)."""
        force = model.force(x)
        quat = run.system.quat
        q = run.system.quaternions(x)
        f = force[quat]
        along = np.sum(q * f, axis=1) / np.sum(q * q, axis=1)
        force[quat] = f - along[:, None] * q
        return force

    def finish_start(self, run: SundialsState, y: np.ndarray) -> np.ndarray:
        return y.copy()

    def finish_newton(self, run: SundialsState,
                      y: np.ndarray) -> tuple[bool, np.ndarray, int]:
        """Newton on IDA's own equilibrium, R(y, y′ = 0) = 0 — F(x) + Gᵀμ = 0 with
        |q_j|² = 1 exactly (and v = 0 in the inertial form) — with the analytic dR/dy
        (``jacobian_data`` at c_j = 0) and a band LU of IDA's pattern: the finish keeps IDA's
        exact unit quaternions. Rows are weighted as the equilibrium test weighs forces;
        constraint rows so that their weighted value is |q_j|² − 1 (velocity rows: v / (L ω₁)).

        On a non-conservative model with stiff penalties (the paper's tendon coupling) the
        positions first go to the equilibrium of F(x) = 0 with the penalties lowered, by
        the residual homotopy CVODE's finish uses (``SundialsIntegrator.at_lowered_penalties``);
        the constrained Newton at the full penalties starts there. Without it, Newton at the
        full penalties failed until IDA had integrated much closer (docs/benchmark-history.md,
        "CVODE and IDA: the Newton finish"). Above
        ``rodsim.solvers.base.LARGE_MODEL_SIZE`` free coordinates the model
        coordinates step through the frames where they are ``static``'s default retraction
        (``constrained_newton``)."""
        converged, x, iterations = self.at_lowered_penalties(run,
                                                             run.system.positions_of(y))
        if not converged:
            return False, y, iterations
        if iterations:
            y = y.copy()
            y[run.system.x_slot] = x
        converged, y, more = self.constrained_newton(run, y)
        return converged, y, iterations + more

    def constrained_newton(self, run: SundialsState,
                           y: np.ndarray) -> tuple[bool, np.ndarray, int]:
        """Newton on R(y, y′ = 0) = 0 from ``y`` (see ``finish_newton``)."""
        system, model = run.system, run.model
        rest = np.zeros(system.size)

        def force(z: np.ndarray) -> np.ndarray:
            out = np.empty(system.size)
            system.dae_residual(z, rest, run.force(system.positions_of(z)), out)
            return -out

        def jacobian(z: np.ndarray) -> np.ndarray:
            return -np.asarray(system.jacobian_data(z, rest, 0.0,
                                                    run.jacobian_data(system.positions_of(z))))

        weight = np.empty(system.size)
        force_rows = system.force_rows()
        weight[force_rows] = model.residual_weight
        if system.inertial:
            weight[system.x_slot] = 1.0 / (model.length_scale * run.dynamics.omega)
        weight[system.mu_slot] = 1.0 / (system.beta**2 if system.inertial else system.beta)
        linear = LinearSolver(system.pattern, system.rows, system.cols, system.band,
                              symmetric=False)
        # Above LARGE_MODEL_SIZE free coordinates, where static's default retraction is the
        # frames, the model coordinates move through them (which keep |q_j| = 1 exactly),
        # the multipliers linearly: with x + Δx the finish failed four times on table1-50g
        # at N = 10 000 (97 steps, 21 s; through the frames one finish after 17 steps,
        # 4.4 s), and at N = 40 000 stopped 8.9e-4 L from static's equilibrium, which the
        # result check refused (now 19 steps, 22 s, on it). Where static's default is the
        # lengths (a tendon is a rod, or contact) the finish stays x + Δx: through
        # Model.step it failed on tendon-conserving at N = 320 (455 steps, stalled on
        # re-initialisations, where x + Δx finishes after 4 steps).
        retract = None
        if model.n > LARGE_MODEL_SIZE and retraction_of(model, "auto") == "frames":
            def retract(z: np.ndarray, dz: np.ndarray) -> np.ndarray:
                out = z + dz
                out[system.x_slot] = model.turned_step(z[system.x_slot], dz[system.x_slot])
                return out

        problem = NewtonProblem(force, jacobian, linear,
                                force_residual=lambda g: float(np.max(np.abs(g) * weight)),
                                weight=weight, step=retract)
        outcome = newton(problem, y, run.tolerance, self.finish_iterations(model),
                         check=self.iteration_check(run, "the Newton finish"))
        if outcome.converged:
            run.last_y = outcome.x
        return outcome.converged, outcome.x, outcome.iterations

    def finish_positions(self, run: SundialsState, state: np.ndarray) -> np.ndarray:
        return np.asarray(run.system.positions_of(state))

    def _tolerances(self, run: SundialsState) -> np.ndarray:
        system, model = run.system, run.model
        scale_x = self.coordinate_scale(model)
        atol = np.empty(system.size)
        atol[system.x_slot] = scale_x
        if system.inertial:
            atol[system.v_slot] = scale_x * run.dynamics.rate
        # Multipliers are forces of size F_ref L; keep them out of the step-size control.
        atol[system.mu_slot] = 1e6 * model.force_scale * model.length_scale
        return np.asarray(self.options.atol * run.tightening * atol)

    def start(self, run: SundialsState, t: float, y: np.ndarray,
              yp: np.ndarray | None) -> IDA:
        from sksundae.ida import IDA  # SUNDIALS is loaded by the first run, not at import

        system, ramp = run.system, run.dynamics.ramp
        solver_kind = self.linear_solver(system.size)

        # Every callback evaluates the model through the run's counted, checked evaluations.
        def resfn(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray) -> None:
            force = run.force(system.positions_of(y), ramp(t))
            run.last_force = force
            system.dae_residual(y, yp, force, res)

        def jacobian(t: float, y: np.ndarray, yp: np.ndarray, cj: float) -> np.ndarray:
            return np.asarray(system.jacobian_data(
                y, yp, cj, run.jacobian_data(system.positions_of(y), ramp(t))))

        options = self.common_options(run, solver_kind, system.band, system.pattern,
                                      system.inertial)
        if yp is None and ramp(t) > 0.0 or yp is not None and len(yp) != system.size:
            # A load already on (step load, or a re-initialisation with a new system):
            # the rates and multipliers follow from the residual.
            yp = None
            options.update(calc_initcond="yp0", calc_init_dt=1e-3 / run.dynamics.omega)
        write = jacobian_writer(solver_kind, system.rows, system.cols)

        def jacfn(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray, cj: float,
                  jj: np.ndarray) -> None:
            write(jj, jacobian(t, y, yp, cj))

        initial_rates = np.zeros(system.size) if yp is None else yp
        if solver_kind == "band_gmres":
            from sksundae.ida import IDAJacTimes, IDAPrecond

            newton = BandPreconditioner(system.pattern, system.rows, system.cols, system.band)

            def psetup(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray,
                       cj: float) -> None:
                # ∂R/∂y + c_j ∂R/∂y′ is linear in c_j: its two parts from one model Jacobian.
                stiffness = run.jacobian_data(system.positions_of(y), ramp(t))
                constant = system.jacobian_data(y, yp, 0.0, stiffness)
                newton.update(constant, system.jacobian_data(y, yp, 1.0, stiffness) - constant)
                newton.factor(cj)

            def psolve(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray,
                       r: np.ndarray, z: np.ndarray, cj: float, delta: float) -> None:
                newton.solve(r, z)

            def jtimes(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray,
                       v: np.ndarray, jv: np.ndarray, cj: float) -> None:
                newton.product(v, jv, cj)

            options.update(precond=IDAPrecond(psetup, psolve),
                           jactimes=IDAJacTimes(None, jtimes))
            return started("IDA", IDA, resfn, None, t, y, initial_rates,
                           atol=self._tolerances(run), algebraic_idx=system.algebraic, **options)
        return started("IDA", IDA, resfn, jacfn, t, y, initial_rates,
                       atol=self._tolerances(run),
                       algebraic_idx=system.algebraic, **options)
