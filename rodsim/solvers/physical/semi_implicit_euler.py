"""The paper's semi-implicit Euler step (Eqs. 14–17) with the physical masses, in physical
time (docs/dynamics.md, "The paper's semi-implicit Euler").

The paper writes its scheme as Eqs. (14)–(16), a_t = F^t/m, v^{t+h} = ξ v^t + h a_t,
r^{t+h} = r^t + h v^{t+h}, and integrates it in the implicit form of Eq. (17),

    x^{t+h} = x^t + ξ h ẋ^t + h² M⁻¹ F(x^{t+h}),

the force taken at the step's end x^{t+h} and the position moved by the new velocity
ẋ^{t+h} = (x^{t+h} − x^t)/h (Eq. 16). Here M is the physical mass in the physical
velocities u = (v, ω) of rodsim/solvers/physical/coordinates.py (the consistent M_r and
each segment's body inertia I), ξ = 1 (the paper's ξ < 1 removes a share 1 − ξ of the
velocity every step: a damping that depends on h, not a material's; the scene's damping
is the physical one), and the rotation follows Eqs. (12)–(13). One step of length h from
(r₀, v₀, q₀, ω₀) solves for the end positions r₁ and body rates ω₁:

    M_r (v₁ − v₀)/h = F_r(x₁) − (D_t u₁)_r,                                  v₁ = (r₁ − r₀)/h
    I (ω₁ − ω₀)/h + ω₁ × I ω₁ = τ(x₁) − (D_t u₁)_ω,    q₁ = normalise(q₀ + (h/2) Σ_k ω₁,k B_k q₀)

with τ_k = ½ (B_k q₁) · F_q(x₁) and D_t = Gᵀ D G at x₁. What is implicit: the force and
torque (at x₁), the gyroscopic term and the damping (at u₁ and x₁), and the velocity that
moves the positions and turns the quaternions (u₁, Eq. 16); what is explicit: only the
carried velocity u₀ (ξ = 1). That is the backward Euler method on the first-order system
(r, q, v, ω): first order, L-stable — no step limit on a linear system, and every mode
loses energy, by the factor 1/(1 + (ωh)²) per step for an undamped mode of angular
frequency ω, its phase per step atan(ωh) (docs/dynamics.md measures both). Eqs. (14)–(16)
alone, with the force at t, would be the explicit symplectic Euler method, stable only for
h < 2/ω_max, ω_max the rod's highest (shear-penalty) frequency.

The quaternion update is Eq. (17) on q with q̇ = ½ Ω q (Ω = Σ_k ω₁,k B_k, Eq. 13), then
renormalised: the quaternion's norm has no mass (docs/dynamics.md), so |q₁| = 1 is kept as
a constraint by projection. q₀ + (h/2) Ω q₀ and the backward form (I − (h/2) Ω)⁻¹ q₀ differ
only in their norm (Ω² = −|ω|² I), so the normalised q₁ is the same: a turn by the angle
2 atan(h|ω₁|/2) about ω₁'s axis.

Newton on (r₁, ω₁) (rodsim/solvers/physical/fixed_step.py) uses the model's analytic sparse
Jacobian ∂F/∂x at x₁ through ∂x₁/∂(r₁, ω₁), with the turning of B_k q₁ at fixed F (the
geometric part, large where a penalty's internal force is); the damping is evaluated at
each iterate and held in the Newton matrix, as the midpoint rule does. The step's
dissipation is h u₁ · D_t u₁ ≥ 0; the energy it loses besides is the scheme's own numerical
damping, which the run's energy balance shows.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from rodsim.core.damping import Damping
from rodsim.core.model import Model
from rodsim.core.rod.quaternion import B
from rodsim.solvers.physical.coordinates import (
    PhysicalCoordinates,
    block_arrays,
    cross_rows,
    model_state,
    velocity_rows,
)
from rodsim.solvers.physical.fixed_step import (
    NEWTON_TOLERANCE,
    Motion,
    StepFailure,
    StepOutcome,
    newton_matrix,
    solve_step,
)
from rodsim.solvers.physical.sparse_kernels import (
    arrays,
    congruent,
    csr_of,
    plus,
    transpose,
)
from rodsim.solvers.physical.tangent_damping import TangentDamping

__all__ = ["SemiImplicitEulerStep", "turned"]


def turned(q0: np.ndarray, w: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (17) on the quaternions ``q0`` (s, 4) at the body rates ``w`` (s, 3) over ``h``,
    renormalised: (q₁, ∂q₁/∂w of shape (s, 4, 3))."""
    rows = velocity_rows(q0)  # B_k q₀
    moved = q0 + 0.5 * h * np.einsum("sk,ska->sa", w, rows)
    norm = np.linalg.norm(moved, axis=1)
    unit = moved / norm[:, None]
    project = (np.eye(4)[None] - unit[:, :, None] * unit[:, None, :]) / norm[:, None, None]
    return unit, project @ (0.5 * h * np.transpose(rows, (0, 2, 1)))


class SemiImplicitEulerStep:
    """The paper's semi-implicit Euler step of one model's motion with its physical masses
    (module docstring)."""

    def __init__(self, coordinates: PhysicalCoordinates, damping: Damping,
                 length_scale: float, tolerance: float = NEWTON_TOLERANCE) -> None:
        self.coordinates = coordinates
        self.damping = damping
        self._tangent_damping = TangentDamping(damping)
        self.length_scale = length_scale
        self.tolerance = tolerance

    def _end(self, x0: np.ndarray, r1: np.ndarray, w1: np.ndarray, h: float
             ) -> tuple[np.ndarray, np.ndarray]:
        """(x₁, ∂q₁/∂ω₁) of the iterate (``r1``, ``w1``)."""
        c = self.coordinates
        q1, dq1 = turned(x0[c.quaternions], w1, h)
        x1 = x0.copy()
        x1[c.positions] = r1
        x1[c.quaternions] = q1
        return x1, dq1

    def _force(self, model: Model, x1: np.ndarray, dq1: np.ndarray, fresh: bool
               ) -> tuple[np.ndarray, np.ndarray, sp.csr_matrix | None]:
        """(F_r, τ) at ``x1`` and, when ``fresh``, their derivative with respect to
        (r₁, ω₁): Gᵀ ∂F/∂x ∂x₁/∂(r₁, ω₁) plus the turning of B_k q₁ at fixed F,
        ½ (B_k ∂q₁/∂ω₁) · F_q."""
        c = self.coordinates
        n = model.n
        if fresh:
            f, jac = model.evaluate(model_state(model, x1))
        else:
            f, jac = model.force(model_state(model, x1)), np.zeros(0)
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(jac))):
            raise StepFailure("the force or its Jacobian is not finite")
        q1, f_q = x1[c.quaternions], f[c.quaternions]
        tau = 0.5 * np.einsum("ska,sa->sk", velocity_rows(q1), f_q)
        if not fresh:
            return f[c.positions], tau, None
        g = c.g_arrays(x1, n)
        moves = c.tangent_arrays(dq1, 1.0, n)
        bent = np.einsum("kba,sb->ska", B, f_q)  # B_kᵀ F_q
        geometric = 0.5 * np.einsum("ska,sal->skl", bent, dq1)
        # g.T @ J @ moves + the blocks, scipy's own operators' arrays by its kernels
        # (sparse_kernels), CSC until the end's ``tocsr``
        m = c.size
        derivative = plus(m, m, congruent(n, m, g, arrays(model.pattern_matrix(jac)), moves),
                          transpose(m, m, block_arrays(
                              geometric, c.angle_columns, c.angle_columns, (m, m))))
        return f[c.positions], tau, csr_of(transpose(m, m, derivative), (m, m),
                                           sorted_indices=True)

    def step(self, model: Model, start: Motion, h: float, t: float = 0.0) -> StepOutcome:
        """One step of length ``h`` [s] from ``start`` with ``model``'s forces (those of the
        step's time); StepFailure when Newton does not converge."""
        c = self.coordinates
        n = model.n
        p = len(c.positions)
        x0, v0, w0 = start.x, start.v, start.w
        r0 = x0[c.positions]
        inertia = c.inertia
        held: list[sp.csr_matrix | None] = [None]  # D_t at the last iterate

        def evaluate(r1: np.ndarray, w1: np.ndarray, fresh: bool
                     ) -> tuple[np.ndarray, sp.csr_matrix | None]:
            x1, dq1 = self._end(x0, r1, w1, h)
            v1 = (r1 - r0) / h
            f_r, tau, stiffness = self._force(model, x1, dq1, fresh)
            res_r = (c.mass @ (v1 - v0)) / h - f_r
            res_w = inertia * (w1 - w0) / h + cross_rows(w1, inertia * w1) - tau
            damping = None
            if self.damping.active:
                g = c.g_arrays(x1, n)
                damping = self._tangent_damping.matrix(x1, g, c.size)
                dragged = damping @ np.concatenate([v1, w1.ravel()])
                res_r = res_r + dragged[:p]
                res_w = res_w + dragged[p:].reshape(-1, 3)
            held[0] = damping
            residual = np.concatenate([res_r, res_w.ravel()])
            if stiffness is None:
                return residual, None
            return residual, newton_matrix(c, 1.0, stiffness, damping, w1, h)

        r1, w1, iterations = solve_step(evaluate, r0 + h * v0, w0.copy(), h,
                                        self.length_scale, self.tolerance)
        x1, _ = self._end(x0, r1, w1, h)
        v1 = (r1 - r0) / h
        dissipated = 0.0
        damping = held[0]
        if damping is not None:
            velocity = np.concatenate([v1, w1.ravel()])
            dissipated = float(h * velocity @ (damping @ velocity))
        return StepOutcome(Motion(x1, v1, w1), dissipated, iterations)
