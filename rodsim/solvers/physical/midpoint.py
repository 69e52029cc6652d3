"""The implicit midpoint step of the equations of motion in physical time (docs/dynamics.md).

The equations (paper Eqs. 10–13 with the physical masses of rodsim/core/inertia.py, in the
velocities of rodsim/solvers/physical/coordinates.py):

    ṙ = v,                    M_r v̇ = F_r(x, t) − (D ẋ)_r
    q̇ = ½ Σ_k ω_k B_k q,      I ω̇ + ω × I ω = τ(x, t) − Gᵀ(D ẋ)_q,   τ_k = ½ (B_k q) · F_q

with F = −∂V/∂x the model's force (loads at full value, a program's values at time t), D
the damping (rodsim/core/damping.py) and G the map from ω to q̇. One step of length h from
(r₀, v₀, q₀, ω₀) solves for the midpoint velocities v_m = (r₁ − r₀)/h and ω_m:

    (2/h) M_r (v_m − v₀) = F_r(x_m) − (D ẋ_m)_r
    (2/h) I (ω_m − ω₀) + ω_m × I ω_m = τ(x_m) − Gᵀ (D ẋ_m)_q
    q₁ = Cayley(h ω_m) q₀,   v₁ = 2 v_m − v₀,   ω₁ = 2 ω_m − ω₀,

x_m the midpoint: positions (r₀ + r₁)/2, quaternions (q₀ + q₁)/|q₀ + q₁| — on the unit
sphere, where the centerline penalty's norm stiffness (Eq. 9) is at rest, so it puts no
spurious force into the step. q₁ − q₀ is orthogonal to q₀ + q₁, so the quaternion rate at
the midpoint of the path normalise((1 − s) q₀ + s q₁) is ½ Σ ω_m,k B_k q̂_m: with it the
step's kinetic energy change is exactly h u_m · (f(x_m) − D_t u_m) (the gyroscopic term
does no work), and the potential's is h u_m · f(x_m) up to the midpoint rule's O(h³) per
step. The scheme is symmetric and second order; undamped, its energy error does not drift
(tests/test_simulate.py measures both); the Cayley transform keeps |q| = 1 to round-off,
and q₁ is normalised after each step to keep it there over many steps.

Newton on the midpoint velocities (rodsim/solvers/physical/fixed_step.py: a simplified
Newton, to the tolerance ``NEWTON_TOLERANCE``) uses a Newton matrix from the model's
analytic sparse Jacobian ∂F/∂x, the last one factored — kept across steps of the same
length (``kept``) — and a fresh one while the iteration converges slowly; the
damping, D_t = Gᵀ D G on the physical velocities, is evaluated at each iterate's
midpoint, so that the converged step's is the midpoint's (held from a predicted midpoint
instead, an O(h²) error in the strain rates that the stiff stretch amplifies put the
Kelvin–Voigt damping ratio of the steel rod's first mode 7 % to 24 % high at 100 steps a
period); its dissipation h u_m · D_t u_m ≥ 0 is what the step removes, exactly. Newton
starts from the last step's midpoint velocities (``Motion``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

from rodsim.core.damping import Damping
from rodsim.core.model import Model
from rodsim.solvers.physical.band_lu import band_order
from rodsim.solvers.physical.coordinates import (
    PhysicalCoordinates,
    cayley,
    cross_rows,
    model_state,
    velocity_rows,
)
from rodsim.solvers.physical.fixed_step import (
    NEWTON_TOLERANCE,
    KeptMatrix,
    Motion,
    StepFailure,
    StepOutcome,
    newton_matrix,
    solve_step,
)
from rodsim.solvers.physical.midpoint_kernels import (
    add_force,
    cayley_derivative,
    derivative_blocks,
    path_state,
    turned,
)
from rodsim.solvers.physical.midpoint_kernels import residual as step_residual
from rodsim.solvers.physical.moving_supports import SupportVelocity
from rodsim.solvers.physical.sparse_kernels import Csr
from rodsim.solvers.physical.stiffness_plan import StiffnessPlan, accumulate
from rodsim.solvers.physical.tangent_damping import TangentDamping

__all__ = ["MidpointStep", "SupportsAt"]

#: The supports' velocity at a time [s] (rodsim/solvers/physical/moving_supports.py).
SupportsAt = Callable[[float], SupportVelocity]


class MidpointStep:
    """The implicit midpoint step of one model's motion (module docstring)."""

    def __init__(self, coordinates: PhysicalCoordinates, damping: Damping,
                 length_scale: float, tolerance: float = NEWTON_TOLERANCE,
                 quadrature: int = 2, supports: SupportsAt | None = None) -> None:
        self.coordinates = coordinates
        self.damping = damping
        self._tangent_damping = TangentDamping(damping)
        #: The supports' velocity at a time, where programs move them (None: no support
        #: moves; rodsim/solvers/physical/moving_supports.py).
        self.supports = supports
        #: The damping of each model met (a moving support's model holds its own held
        #: coordinates and clamp frame), the model kept so that its id stays its own.
        self._dampings: dict[int, tuple[Model, Damping, TangentDamping]] = {}
        self.length_scale = length_scale
        self.tolerance = tolerance
        self.quadrature = quadrature
        #: The last step's factored Newton matrix, which starts the next step's Newton
        #: (fixed_step.solve_step).
        self.kept = KeptMatrix()
        #: The plan of the stiffness on the step's unknowns (stiffness_plan.py), for the
        #: last Jacobian pattern met.
        self._plan: StiffnessPlan | None = None
        #: The unknowns' band order, in which the Newton matrix is factored
        #: (rodsim/solvers/physical/band_lu.py).
        self._order = band_order(coordinates)
        c = coordinates
        self._p = len(c.positions)
        self._s = len(c.quaternions)
        nodes, weights = np.polynomial.legendre.leggauss(quadrature)
        #: The Gauss–Legendre points on [0, 1] and their weights (fixed: computed once).
        self._gauss = tuple(zip((0.5 * (nodes + 1.0)).tolist(), (0.5 * weights).tolist(),
                                strict=True))

    def _tangent(self, xm: np.ndarray, velocity: np.ndarray, w: np.ndarray) -> np.ndarray:
        """ẋ = G u at the (unit) midpoint ``xm``: positions ``velocity``, q̇ = ½ Σ w_k B_k q."""
        c = self.coordinates
        out = np.zeros(len(xm))
        out[c.positions] = velocity
        out[c.quaternions] = 0.5 * np.einsum("ska,sk->sa", velocity_rows(xm[c.quaternions]), w)
        return out

    def _generalised(self, xm: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gᵀ f at ``xm``: (f_r, τ) with τ_k = ½ (B_k q) · f_q."""
        c = self.coordinates
        rows = velocity_rows(xm[c.quaternions])
        return f[c.positions], 0.5 * np.einsum("ska,sa->sk", rows, f[c.quaternions])

    def _averaged(self, model: Model, x0: np.ndarray, r1: np.ndarray, q1: np.ndarray,
                  qm: np.ndarray, dq1: np.ndarray | None = None,
                  start: tuple[np.ndarray, np.ndarray] | None = None,
                  reference: np.ndarray | None = None, rows: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray, Csr | None]:
        """The generalised force averaged along the step's path γ(s) = (r₀ + s Δr,
        normalise(q₀ + s Δq)), s in [0, 1], by Gauss–Legendre quadrature (``quadrature``
        points): (f̄_r, τ̄) with h u_m · (f̄_r, τ̄) = ∫ F(γ) · γ′ ds, the work of the force
        over the step (module docstring). With ``dq1`` (∂q₁/∂ω_m, (s, 4, 3)) also the
        derivative of (f̄_r, τ̄) with respect to (r₁, ω_m): the stiffness terms and the
        change of the path's direction with ω_m at fixed force (large where a penalty's
        internal force is: leaving it out made Newton diverge on stiff wires). ``start``:
        x₀'s (positions, quaternions), ``reference`` the model's rest state at its free
        coordinates (``model_state``) and ``rows`` the rows B_k q_m (``velocity_rows``),
        when the caller has them. The path's states and the force's sums are
        rodsim/solvers/physical/midpoint_kernels.py's."""
        c = self.coordinates
        r0, q0 = (x0[c.positions], x0[c.quaternions]) if start is None else start
        if reference is None:
            reference = model.reference[model.free]
        if rows is None:
            rows = velocity_rows(qm)  # B_k q_m: Δq = (h/2) Σ ω_m,k B_k q_m
        f_r = np.zeros(self._p)
        tau = np.zeros((self._s, 3))
        derivative: np.ndarray | None = None
        plan = self._plan_of(model) if dq1 is not None else None
        state = np.empty(len(x0))
        unit = np.empty((self._s, 4))
        norm = np.empty(self._s)
        if dq1 is not None:
            g_blocks, p_blocks = np.empty((self._s, 4, 3)), np.empty((self._s, 4, 3))
            geometric = np.empty((self._s, 3, 3))
        for node, weight in self._gauss:
            # the state at the path's point: x₀ with r₀ + s Δr and normalise(q₀ + s Δq),
            # minus the rest state (``model_state``)
            path_state(x0, reference, c.positions, c.quaternions, r0, r1, q0, q1, node,
                       state, unit, norm)
            # the model's force (and Jacobian) without its memo: iterates do not repeat; a
            # force alone that is not finite anywhere makes f̄_r or τ̄ not finite (checked
            # once, below)
            if dq1 is None:
                f = model.evaluate_fresh(state, jacobian=False)[0]
            else:
                f, jac = model.evaluate_fresh(state)
                if not (bool(np.isfinite(f).all()) and bool(np.isfinite(jac).all())):
                    raise StepFailure("the force or its Jacobian is not finite")
            # f̄_r += weight f_r, τ̄ += weight ½ B_k q_m · (I − q̂q̂ᵀ) f_q / |q|
            add_force(f, c.positions, c.quaternions, unit, norm, rows, weight, f_r, tau)
            if dq1 is None:
                continue
            # G's and P's 4 × 3 blocks (the identity, times 1 and ``node``, on the positions)
            # and the torque's change at fixed f through a_k = B_k q_m and through q̂, |q|
            derivative_blocks(f, c.quaternions, unit, norm, rows, dq1, node, g_blocks,
                              p_blocks, geometric)
            # (Gᵀ J P + the geometric blocks on the angles), times the weight, summed into
            # the plan's CSR values (stiffness_plan.py)
            assert plan is not None
            if derivative is None:
                derivative = np.zeros(len(plan.indices))
            accumulate(jac, plan.entry, plan.g_index, plan.p_index, plan.slot,
                       g_blocks.ravel(), 1.0, p_blocks.ravel(), node, plan.geometric_slot,
                       geometric.ravel(), weight, derivative)
        if not (bool(np.isfinite(f_r).all()) and bool(np.isfinite(tau).all())):
            raise StepFailure("the force or its Jacobian is not finite")
        if derivative is None or plan is None:
            return f_r, tau, None
        return f_r, tau, Csr(plan.indptr, plan.indices, derivative)

    def _plan_of(self, model: Model) -> StiffnessPlan:
        """The stiffness plan for ``model``'s Jacobian pattern (made once per pattern)."""
        pattern = model.pattern
        if self._plan is None or not self._plan.fits(pattern.indptr, pattern.indices):
            self._plan = StiffnessPlan.of(self.coordinates, model.n, pattern.indptr,
                                          pattern.indices)
        return self._plan

    def _damping_of(self, model: Model) -> tuple[Damping, TangentDamping]:
        """The damping of ``model`` (the start's where no support moves: the damping does
        not depend on the loads)."""
        if self.supports is None or model is self.damping.model:
            return self.damping, self._tangent_damping
        known = self._dampings.get(id(model))
        if known is None:
            if len(self._dampings) > 8:
                self._dampings.clear()
            damping = Damping(model)
            known = (model, damping, TangentDamping(damping))
            self._dampings[id(model)] = known
        return known[1], known[2]

    def step(self, model: Model, start: Motion, h: float, t: float = 0.0) -> StepOutcome:
        """One step of length ``h`` [s] from ``start`` with ``model``'s forces (those of the
        step's midpoint time ``t`` [s]); StepFailure when Newton does not converge."""
        c = self.coordinates
        n = model.n
        moving = None if self.supports is None else self.supports(t)
        damper, tangent_damping = self._damping_of(model)
        # the moving supports' damping force and dissipated power at the last iterate
        support: list[tuple[np.ndarray, np.ndarray, float]] = []
        x0, v0, w0 = start.x, start.v, start.w
        r0 = x0[c.positions]
        split = (r0, x0[c.quaternions])  # x₀'s positions and quaternions, for every iterate
        reference = model.reference[model.free]  # model_state's
        mass = c.mass
        # D_t = Gᵀ D G on the physical velocities at the last iterate's midpoint
        held: list[sp.csr_matrix | None] = [None]
        r1, wm = r0 + h * v0, w0.copy()
        if start.middle is not None:
            r1, wm = r0 + h * start.middle[0], start.middle[1].copy()
        inertia = c.inertia

        q0 = split[1]
        q1, qm = np.empty(q0.shape), np.empty(q0.shape)
        norm, rows = np.empty(len(q0)), np.empty((len(q0), 3, 4))

        def evaluate(r1: np.ndarray, wm: np.ndarray, fresh: bool
                     ) -> tuple[np.ndarray, sp.csr_matrix | None]:
            # q₁, q_m, |q_m| and B_k q_m (midpoint_kernels: as _turned and velocity_rows)
            turned(q0, wm, h, q1, qm, norm, rows)
            dq1 = None
            if fresh:  # ∂q₁/∂ω_m (midpoint_kernels.cayley_derivative)
                dq1 = np.empty((len(q0), 4, 3))
                cayley_derivative(rows, wm, h, dq1)
            f_r, tau, stiffness = self._averaged(model, x0, r1, q1, qm, dq1, split,
                                                 reference, rows)
            residual = np.empty(c.size)
            step_residual(mass.indptr, mass.indices, mass.data, r0, r1, v0, inertia, wm, w0,
                          h, f_r, tau, residual)
            damping = None
            if damper.active:
                vm = (r1 - r0) / h
                xm = _middle(c, x0, r0, r1, qm, norm)  # x_m: the damping's state
                g = c.g_arrays(xm, n)
                damping = tangent_damping.matrix(xm, g, c.size)
                residual += damping @ np.concatenate([vm, wm.ravel()])
                if moving is not None:
                    x_dot = self._tangent(xm, vm, wm)
                    force, power = moving.damping_force(damper, xm, x_dot)
                    pushed_r, pushed_w = self._generalised(xm, force)
                    residual[:self._p] -= pushed_r
                    residual[self._p:] -= pushed_w.ravel()
                    support[:] = [(x_dot, force, power)]
            held[0] = damping
            if stiffness is None:
                return residual, None
            return residual, newton_matrix(c, 2.0, stiffness, damping, wm, h)

        r1, wm, iterations = solve_step(evaluate, r1, wm, h, self.length_scale,
                                        self.tolerance, self.kept, self._order)
        damping = held[0]
        q1, _, _ = _turned(split[1], wm, h)
        vm = (r1 - r0) / h
        dissipated = work = 0.0
        if damping is not None:
            velocity = np.concatenate([vm, wm.ravel()])
            dissipated = float(h * velocity @ (damping @ velocity))
            if support:  # what the free rates lose, the whole dissipation, the difference
                x_dot, force, power = support[0]
                lost = dissipated - h * float(x_dot @ force)
                dissipated = h * power
                work = dissipated - lost
        x1 = x0.copy()
        x1[c.positions] = r1
        x1[c.quaternions] = q1 / _norms(q1)[:, None]
        return StepOutcome(Motion(x1, 2.0 * vm - v0, 2.0 * wm - w0, (vm, wm)), dissipated,
                           iterations, work)

    def start_force(self, model: Model, start: Motion) -> np.ndarray:
        """The generalised force at ``start`` with ``model``'s forces, in the step's residual
        rows: (F_r − (D_t u)_r, τ − ω × I ω − (D_t u)_ω) — what an explicit half step
        from ``start`` would apply (rodsim/solvers/physical/error_control.py's estimate;
        a moving support's damping force left out)."""
        c = self.coordinates
        x = start.x
        f = model.force(model_state(model, x))
        if not np.all(np.isfinite(f)):
            raise StepFailure("the force is not finite")
        f_r, tau = self._generalised(x, f)
        f_q = f[c.quaternions]
        q = x[c.quaternions]
        # the part of f_q along q does no work on a unit quaternion (as in _averaged)
        tau = 0.5 * np.einsum("ska,sa->sk", velocity_rows(q),
                              f_q - q * np.sum(q * f_q, axis=1)[:, None])
        tau = tau - cross_rows(start.w, c.inertia * start.w)
        damper, tangent_damping = self._damping_of(model)
        out = np.concatenate([f_r, tau.ravel()])
        if damper.active:
            g = c.g_arrays(x, model.n)
            out = out - tangent_damping.matrix(x, g, c.size) @ np.concatenate(
                [start.v, start.w.ravel()])
        return out


def _turned(q0: np.ndarray, wm: np.ndarray, h: float
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The step's quaternions: (q₁ = Cayley(h ω_m) q₀, the unnormalised midpoint
    q_m = (q₀ + q₁)/2, |q_m|)."""
    q1 = cayley(q0, wm, h)
    qm = 0.5 * (q0 + q1)
    return q1, qm, _norms(qm)


def _middle(c: PhysicalCoordinates, x0: np.ndarray, r0: np.ndarray, r1: np.ndarray,
            qm: np.ndarray, norm: np.ndarray) -> np.ndarray:
    """The midpoint x_m: positions (r₀ + r₁)/2, quaternions q_m/|q_m|."""
    xm = x0.copy()
    xm[c.positions] = 0.5 * (r0 + r1)
    xm[c.quaternions] = qm / norm[:, None]
    return xm


def _norms(q: np.ndarray) -> np.ndarray:
    """|q| row by row: numpy.linalg.norm(q, axis=1)'s own sum of squares and root, without
    its argument handling (the same numbers)."""
    return np.sqrt(np.add.reduce(q * q, axis=1))
