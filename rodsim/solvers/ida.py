"""SUNDIALS IDA (adaptive BDF on a residual form, via scikit-sundae) to equilibrium.

The same pseudo-dynamics as CVODE (:mod:`rodsim.solvers.pseudo_dynamics`), written as a
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

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from rodsim.core.model import Model
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.newton import NewtonProblem, newton
from rodsim.solvers.pseudo_dynamics import damping_rate
from rodsim.solvers.sundials import (
    PSEUDO_DYNAMICS_PARAMETERS,
    BandPreconditioner,
    SundialsIntegrator,
    jacobian_writer,
    started,
)

if TYPE_CHECKING:
    from sksundae.ida import IDA
from rodsim.core.sparsity import csc_pattern


class ConstrainedSystem:
    """Index maps, residual and analytic Jacobian of IDA's constrained residual form."""

    def __init__(self, model: Model, formulation: str, damping: float, baumgarte: float,
                 masses: np.ndarray) -> None:
        self.model = model
        self.inertial = formulation == "inertial"
        self.c, self.beta = damping, baumgarte
        self.mass = masses
        n = model.n
        free_of = np.full(model.full_size, -1)
        free_of[model.free] = np.arange(n)
        groups = []
        for rod in model.rods.values():
            index = free_of[rod.layout.quaternion_index]
            groups.extend(row for row in index if np.all(row >= 0))
        self.quat = np.array(groups, dtype=int).reshape(-1, 4)  # model coords of each q_j
        # Slot of every variable in y: per model coordinate 1 (or 2 with velocity) slots,
        # and one multiplier after the last coordinate of each quaternion.
        per = 2 if self.inertial else 1
        after = np.zeros(n, dtype=int)
        after[self.quat[:, 3]] = 1
        start = np.concatenate([[0], np.cumsum(per + after)[:-1]])
        self.x_slot = start
        self.v_slot = start + 1 if self.inertial else None
        self.mu_slot = start[self.quat[:, 3]] + per
        self.size = n * per + len(self.quat)
        self.algebraic = self.mu_slot
        self._build_pattern()

    def _build_pattern(self) -> None:
        model, q = self.model, self.quat.ravel()
        force_row = self.v_slot if self.inertial else self.x_slot
        mu = np.repeat(self.mu_slot, 4)
        slots = np.arange(self.size)
        blocks = {
            "K": (force_row[model.pattern_rows], self.x_slot[model.pattern_cols]),
            "diag": (slots, slots),
            "mu_col": (force_row[q], mu),
            "mu_row_x": (mu, self.x_slot[q]),
        }
        if self.inertial:
            blocks["mu_row_v"] = (mu, self.v_slot[q])
            blocks["xv"] = (self.x_slot, self.v_slot)
        pattern = csc_pattern(np.concatenate([r for r, _ in blocks.values()]),
                              np.concatenate([c for _, c in blocks.values()]), self.size)
        self.pattern, self.rows, self.cols = pattern.matrix, pattern.rows, pattern.cols
        bounds = np.cumsum([0, *(len(r) for r, _ in blocks.values())])
        #: For each block, where its entries land in the CSC data (unique within a block).
        self._target = {name: pattern.target[bounds[k]:bounds[k + 1]]
                        for k, name in enumerate(blocks)}
        diagonal = np.flatnonzero(model.pattern_rows == model.pattern_cols)
        self._quat_diagonal = diagonal[np.isin(model.pattern_rows[diagonal], q)]
        self._quat_order = np.argsort(q)  # _quat_diagonal runs over ascending coordinates
        self.band = pattern.band

    def constrained_force(self, y: np.ndarray, force: np.ndarray) -> np.ndarray:
        """F(x) + Gᵀμ: the force whose vanishing is IDA's (constrained) equilibrium."""
        total = force.copy()
        total[self.quat] += 2.0 * y[self.mu_slot][:, None] * y[self.x_slot][self.quat]
        return total

    def initial_state(self, x0: np.ndarray | None = None) -> np.ndarray:
        """The state ``x0`` (default: the rest state; or a warm start), at rest, μ = 0."""
        y = np.zeros(self.size)
        y[self.x_slot] = self.model.x0 if x0 is None else x0
        return y

    def positions_of(self, y: np.ndarray) -> np.ndarray:
        return y[self.x_slot]

    def residual(self, y: np.ndarray, yp: np.ndarray, force: np.ndarray,
                 out: np.ndarray) -> None:
        """R(t, y, y′) into ``out`` given F(x)."""
        q = self.quat
        qv = y[self.x_slot][q]
        total = self.constrained_force(y, force)
        g = np.sum(qv * qv, axis=1) - 1.0
        if self.inertial:
            v, vdot = y[self.v_slot], yp[self.v_slot]
            vq = v[q]
            out[self.x_slot] = yp[self.x_slot] - v
            out[self.v_slot] = self.mass * (vdot + self.c * v) - total
            out[self.mu_slot] = (2.0 * np.sum(qv * vdot[q], axis=1)
                                 + 2.0 * np.sum(vq * vq, axis=1)
                                 + 4.0 * self.beta * np.sum(qv * vq, axis=1)
                                 + self.beta**2 * g)
        else:
            xdot = yp[self.x_slot]
            out[self.x_slot] = self.c * self.mass * xdot - total
            out[self.mu_slot] = 2.0 * np.sum(qv * xdot[q], axis=1) + self.beta * g

    def jacobian_data(self, y: np.ndarray, yp: np.ndarray, cj: float,
                      model_jacobian: np.ndarray) -> np.ndarray:
        """dR/dy + cj dR/dy′ in the CSC order of :attr:`pattern`."""
        q, t = self.quat, self._target
        x, mu = y[self.x_slot], y[self.mu_slot]
        qv = x[q]
        stiffness = model_jacobian.copy()  # ∂(F + 2μq)/∂x = K + 2μ I on quaternion coords
        stiffness[self._quat_diagonal] += np.repeat(2.0 * mu, 4)[self._quat_order]
        data = np.zeros(self.pattern.nnz)
        data[t["K"]] -= stiffness
        diag = np.zeros(self.size)
        if self.inertial:
            v, vdot = y[self.v_slot], yp[self.v_slot]
            vq = v[q]
            diag[self.x_slot] = cj
            diag[self.v_slot] = self.mass * (self.c + cj)
            data[t["xv"]] -= 1.0
            data[t["mu_row_x"]] += (2.0 * vdot[q] + 4.0 * self.beta * vq
                                    + 2.0 * self.beta**2 * qv).ravel()
            data[t["mu_row_v"]] += (4.0 * vq + (4.0 * self.beta + 2.0 * cj) * qv).ravel()
        else:
            diag[self.x_slot] = self.c * self.mass * cj
            data[t["mu_row_x"]] += (2.0 * yp[self.x_slot][q]
                                    + (2.0 * self.beta + 2.0 * cj) * qv).ravel()
        data[t["diag"]] += diag
        data[t["mu_col"]] -= 2.0 * qv.ravel()
        return data


class Ida(SundialsIntegrator):
    """IDA BDF on the constrained residual form, stopped at equilibrium."""

    name = "ida"
    summary = "SUNDIALS IDA on the residual form with quaternion norms as algebraic equations"
    quaternion_norm = ("algebraic constraint |q|² = 1 per quaternion with a multiplier, "
                       "Baumgarte-stabilised to index 1")
    # The constrained Newton finish (a merit line search: no energy to minimise) fails more
    # often from far away than CVODE's: measured with switch 0.1 / 0.03 / 0.01 / 0 on
    # table1-50g 24.8 / 13.2 / 21.6 / 19.4 ms (the 0.1 run wastes one 20-iteration attempt;
    # re-measured after the homotopy finish: 0.1 / 0.03 / 0.01 44 / 17 / 18 ms, table1-100g
    # 25 / 18 / 22 ms). The tendon scenes, where the homotopy finish succeeds from 0.1,
    # declare 0.1 and a step load (docs/benchmarks.md, "CVODE and IDA on the tendon scenes").
    parameters = tuple(replace(p, default=0.03) if p.name == "newton_switch" else p
                       for p in PSEUDO_DYNAMICS_PARAMETERS)

    def build_system(self) -> None:
        self.rate = damping_rate(self.model, self.options.damping_ratio)
        self.system = ConstrainedSystem(self.model, self.options.formulation, self.rate,
                                        2.0 * self.omega, self.masses)
        self._last_y: np.ndarray | None = None

    def initial_state(self) -> np.ndarray:
        return self.system.initial_state(self.start_state)

    def positions_of(self, y: np.ndarray) -> np.ndarray:
        return self.system.positions_of(y)

    def equilibrium_force(self, y: np.ndarray, force: np.ndarray) -> np.ndarray:
        """F + Gᵀμ: IDA's equilibrium is the constrained one."""
        self._last_y = y
        return self.system.constrained_force(y, force)

    def residual(self, x: np.ndarray) -> float:
        """Residual of the constrained equilibrium F + Gᵀμ = 0 at the last IDA state."""
        y = self._last_y
        if y is None or not np.array_equal(self.system.positions_of(y), x):
            return super().residual(x)
        return self.model.residual(self.system.constrained_force(y, self.model.force(x)))

    def verification_force(self, model: Model, x: np.ndarray) -> np.ndarray:
        """F + Gᵀμ with the multipliers recomputed from ``x`` alone (μ_j minimises the
        constrained force of quaternion j: F_j minus its component along q_j), not taken from
        the IDA state: the result's check (:meth:`Integrator.verified_residual`)."""
        force = model.force(x)
        q = x[self.system.quat]
        f = force[self.system.quat]
        along = np.sum(q * f, axis=1) / np.sum(q * q, axis=1)
        force[self.system.quat] = f - along[:, None] * q
        return force

    def finish_start(self, y: np.ndarray) -> np.ndarray:
        return y.copy()

    def finish_newton(self, y: np.ndarray) -> tuple[bool, np.ndarray, int]:
        """Newton on IDA's own equilibrium, R(y, y′ = 0) = 0 — F(x) + Gᵀμ = 0 with
        |q_j|² = 1 exactly (and v = 0 in the inertial form) — with the analytic dR/dy
        (``jacobian_data`` at c_j = 0) and a band LU of IDA's pattern: the finish keeps IDA's
        exact unit quaternions. Rows are weighted as the equilibrium test weighs forces;
        constraint rows so that their weighted value is |q_j|² − 1 (velocity rows: v / (L ω₁)).

        On a non-conservative model with stiff penalties (the paper's tendon coupling) the
        positions first go to the equilibrium of F(x) = 0 with the penalties lowered, by
        the residual homotopy CVODE's finish uses (:meth:`SundialsIntegrator.at_lowered_penalties`);
        the constrained Newton at the full penalties starts there. Without it, Newton at the
        full penalties failed until IDA had integrated much closer (measured on
        table3-catheter1: 4 finish attempts and 214 steps with a step load)."""
        converged, x, iterations = self.at_lowered_penalties(self.system.positions_of(y))
        if not converged:
            return False, y, iterations
        if iterations:
            y = y.copy()
            y[self.system.x_slot] = x
        converged, y, more = self.constrained_newton(y)
        return converged, y, iterations + more

    def constrained_newton(self, y: np.ndarray) -> tuple[bool, np.ndarray, int]:
        """Newton on R(y, y′ = 0) = 0 from ``y`` (see :meth:`finish_newton`)."""
        system, model = self.system, self.model
        rest = np.zeros(system.size)

        def force(z: np.ndarray) -> np.ndarray:
            out = np.empty(system.size)
            system.residual(z, rest, self.force(system.positions_of(z)), out)
            return -out

        def jacobian(z: np.ndarray) -> np.ndarray:
            return -system.jacobian_data(z, rest, 0.0,
                                         self.jacobian_data(system.positions_of(z)))

        weight = np.empty(system.size)
        force_rows = system.v_slot if system.inertial else system.x_slot
        weight[force_rows] = model.residual_weight
        if system.inertial:
            weight[system.x_slot] = 1.0 / (model.length_scale * self.omega)
        weight[system.mu_slot] = 1.0 / (system.beta**2 if system.inertial else system.beta)
        linear = LinearSolver(system.pattern, system.rows, system.cols, system.band,
                              symmetric=False)
        problem = NewtonProblem(force, jacobian, linear,
                                residual=lambda g: float(np.max(np.abs(g) * weight)),
                                weight=weight)
        outcome = newton(problem, y, self.tolerance, self.options.newton_iterations,
                         check=self.iteration_check("the Newton finish"))
        if outcome.converged:
            self._last_y = outcome.x
        return outcome.converged, outcome.x, outcome.iterations

    def finish_positions(self, state: np.ndarray) -> np.ndarray:
        return self.system.positions_of(state)

    def _tolerances(self) -> np.ndarray:
        system, model = self.system, self.model
        scale_x = self.coordinate_scale()
        atol = np.empty(system.size)
        atol[system.x_slot] = scale_x
        if system.inertial:
            atol[system.v_slot] = scale_x * self.rate
        # Multipliers are forces of size F_ref L; keep them out of the step-size control.
        atol[system.mu_slot] = 1e6 * model.force_scale * model.length_scale
        return self.options.atol * self.tightening * atol

    def start(self, t: float, y: np.ndarray, yp: np.ndarray | None) -> IDA:
        from sksundae.ida import IDA  # SUNDIALS is loaded by the first run, not at import

        system, model, ramp, counts = self.system, self.model, self.ramp, self.counts
        solver_kind = self.linear_solver(system.size)

        def resfn(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray) -> None:
            counts["force_evals"] += 1
            force = model.force(system.positions_of(y), ramp(t))
            self._last_force = force
            system.residual(y, yp, force, res)

        def jacobian(t: float, y: np.ndarray, yp: np.ndarray, cj: float) -> np.ndarray:
            counts["jacobian_evals"] += 1
            return system.jacobian_data(
                y, yp, cj, model.jacobian_data(system.positions_of(y), ramp(t)))

        options = self.common_options(solver_kind, system.band, system.pattern, system.inertial)
        if yp is None and ramp(t) > 0.0 or yp is not None and len(yp) != system.size:
            # A load already on (step load, or a re-initialisation with a new system):
            # the rates and multipliers follow from the residual.
            yp = None
            options.update(calc_initcond="yp0", calc_init_dt=1e-3 / self.omega)
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
                counts["jacobian_evals"] += 1
                stiffness = model.jacobian_data(system.positions_of(y), ramp(t))
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
                           atol=self._tolerances(), algebraic_idx=system.algebraic, **options)
        return started("IDA", IDA, resfn, jacfn, t, y, initial_rates, atol=self._tolerances(),
                       algebraic_idx=system.algebraic, **options)
