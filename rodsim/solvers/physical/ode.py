"""The equations of motion in physical time as an explicit system ẏ = f(t, y) for SUNDIALS
CVODE, the quaternions held on the unit sphere by projection (docs/dynamics.md, "CVODE").

The unknowns and equations are those of rodsim/solvers/physical/dae.py without the norm
row: ṙ = v, q̇ = ½ Σ_k ω_k B_k q, and the accelerations

    v̇ = M_r⁻¹ (F_r − (D_t u)_r),    ω̇ = I⁻¹ (τ − ω × I ω − (D_t u)_ω).

q̇ ⊥ q, so |q| is constant in the exact flow; CVODE's steps let it drift by their local
error. The forces, the rates and the outputs are all taken at q/|q| (a projection, not a
constraint): the drift of |q| is no motion and never reaches the physics.

The Jacobian ∂f/∂y is analytic — the dynamic rows of the residual form (dae.py) times
−diag(M_r, I)⁻¹, the kinematic rows G and ½ Σ_k ω_k B_k — and dense (M_r⁻¹ couples every
node). A small rod's CVODE factors it densely (``jacobian``); a large rod's solves the
Newton matrix in its mass-scaled, banded form S − γ H (``mass_matrix``, ``scaled_jacobian``;
rodsim/solvers/physical/ode_newton.py), in work linear in the nodes, as IDA takes M_r v̇.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from rodsim.core.rod.quaternion import B
from rodsim.solvers.physical.coordinates import block_diagonal
from rodsim.solvers.physical.dae import PhysicalDae

__all__ = ["PhysicalOde"]


class PhysicalOde:
    """ẏ = f(t, y) of a ``PhysicalDae``'s scene (module docstring); natural order."""

    def __init__(self, dae: PhysicalDae) -> None:
        self.dae = dae

    def unit(self, y: np.ndarray) -> np.ndarray:
        """``y`` with its quaternions normalised."""
        out = y.copy()
        index = self.dae.coordinates.quaternions
        q = out[index]
        out[index] = q / np.linalg.norm(q, axis=1)[:, None]
        return out

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """f(t, y)."""
        self.dae.evaluations += 1
        return self.dae.rates(t, self.unit(y))

    def jacobian(self, t: float, y: np.ndarray) -> np.ndarray:
        """∂f/∂y at the projected state, dense (natural order)."""
        dae = self.dae
        c, n, p = dae.coordinates, dae.n, dae.p
        y = self.unit(y)
        x, _, w = dae.split(y)
        out = np.zeros((dae.size, dae.size))
        # ẋ = G u: ∂/∂u = G, ∂/∂q = ½ Σ_k ω_k B_k on each quaternion
        out[:n, n:] = c.g_matrix(x, n).toarray()
        turning = 0.5 * np.einsum("sk,kab->sab", w, B)
        rows = np.repeat(c.quaternions[:, :, None], 4, axis=2)
        cols = np.repeat(c.quaternions[:, None, :], 4, axis=1)
        out[rows, cols] = turning
        # u̇: −diag(M_r, I)⁻¹ times the residual's dynamic rows at c_j = 0
        dyn_x, dyn_u = dae.dynamic_rows(t, y, 0.0)
        dynamic = -sp.hstack([dyn_x, dyn_u]).toarray()
        if p:
            solve = dae.mass_solve
            assert solve is not None
            out[n:n + p] = solve(dynamic[:p])
        out[n + p:] = dynamic[p:] / c.inertia.ravel()[:, None]
        return out

    def mass_matrix(self) -> sp.csr_matrix:
        """S = diag(1 on x, M_r on v, I on ω), natural order: f = S⁻¹ h."""
        c, n = self.dae.coordinates, self.dae.n
        return sp.block_diag([sp.identity(n), c.mass, sp.diags(c.inertia.ravel())],
                             format="csr")

    def scaled_jacobian(self, t: float, y: np.ndarray) -> sp.csr_matrix:
        """H = S ∂f/∂y at the projected state, sparse (natural order): the kinematic rows
        of ``jacobian`` and minus the residual form's dynamic rows at c_j = 0."""
        dae = self.dae
        c, n = dae.coordinates, dae.n
        y = self.unit(y)
        x, _, w = dae.split(y)
        turning = block_diagonal(0.5 * np.einsum("sk,kab->sab", w, B), c.quaternions,
                                 c.quaternions, (n, n))
        dyn_x, dyn_u = dae.dynamic_rows(t, y, 0.0)
        return sp.bmat([[turning, c.g_matrix(x, n)], [-dyn_x, -dyn_u]], format="csr")

    def unscale(self, h: np.ndarray) -> np.ndarray:
        """S⁻¹ h (natural order)."""
        dae = self.dae
        n, p = dae.n, dae.p
        out = h.copy()
        if p:
            solve = dae.mass_solve
            assert solve is not None
            out[n:n + p] = solve(h[n:n + p])
        out[n + p:] = h[n + p:] / dae.coordinates.inertia.ravel()
        return out
