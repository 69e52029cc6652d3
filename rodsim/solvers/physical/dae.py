"""The equations of motion in physical time as a residual R(t, y, ẏ) = 0 for SUNDIALS IDA,
with the unit quaternions as algebraic equations (docs/dynamics.md, "IDA").

The unknowns are y = (x, u): the free coordinates x (node positions r and segment
quaternions q) and the physical velocities u = (v, ω) of rodsim/solvers/physical/coordinates.py
(node velocities, body rates). The equations are the paper's Eqs. (10)–(13) with the
physical masses, as the implicit midpoint rule integrates them
(rodsim/solvers/physical/midpoint.py):

    ṙ − v = 0                                              (position kinematics)
    (B_k q) · q̇ − ½ ω_k |q|² = 0,  k = 1, 2, 3             (Eq. 13, projected)
    ½ (|q|² − 1) = 0                                       (the unit quaternion)
    M_r v̇ − F_r(x, t) + (D_t u)_r = 0                       (Eqs. 10–11)
    I ω̇ + ω × I ω − τ(x, t) + (D_t u)_ω = 0,  τ_k = ½ (B_k q) · F_q   (Eq. 12)

with F the model's force at the values of time t, D_t = Gᵀ D G the damping on the
velocities (rodsim/core/damping.py) and G the map ẋ = G u. The B_k q (k = 1, 2, 3) and q are
orthogonal with equal norms, so the three projected rows and the derivative of the norm
row, q · q̇ = 0, give q̇ = ½ Σ_k ω_k B_k q, Eq. (13) itself: the system is of index 1 and the
constraint |q| = 1 holds at every step to the corrector's tolerance, not only in the limit
(the norm row has no ẏ: the quaternion's norm is no degree of freedom of the motion, as in
the midpoint step).

The Jacobian ∂R/∂y + c_j ∂R/∂ẏ is analytic: the model's sparse ∂F/∂x mapped through G,
the turning of G with q at fixed F (τ_k's derivative ½ B_kᵀ F_q), the gyroscopic term and
the damping at the state (its change with x left out: IDA's Newton is a modified Newton).
SUNDIALS sees y in a band order — each velocity right after its coordinate — so that a
band LU factors it (``PhysicalDae.order``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from rodsim.core.damping import Damping
from rodsim.core.model import Model
from rodsim.core.rod.quaternion import B
from rodsim.solvers.physical.coordinates import (
    PhysicalCoordinates,
    block_diagonal,
    gyroscopic_jacobian,
    model_state,
    velocity_rows,
)

__all__ = ["PhysicalDae"]


class PhysicalDae:
    """The residual form of one scene's motion (module docstring). ``model_at(t)``: the
    model with the values of time t; y is in natural order (x, v, ω) here, and
    ``order`` is the band order SUNDIALS sees (``y_band = y[order]``)."""

    def __init__(self, coordinates: PhysicalCoordinates, damping: Damping,
                 model_at: Callable[[float], Model], n: int) -> None:
        self.coordinates = coordinates
        self.damping = damping
        self.model_at = model_at
        self.n = n
        c = coordinates
        self.p, self.s = len(c.positions), len(c.quaternions)
        self.size = n + c.size
        self.angles = n + self.p + np.arange(3 * self.s).reshape(-1, 3)
        self.velocities = n + np.arange(self.p)
        # each velocity right after the last coordinate it moves: a narrow band
        key = np.concatenate([np.arange(n, dtype=float), c.positions + 0.5,
                              (np.max(c.quaternions, axis=1)[:, None] + 0.5
                               + 0.1 * np.arange(3)[None]).ravel()])
        self.order = np.argsort(key, kind="stable")
        self.place = np.argsort(self.order)  # natural index → band index
        self.mass_solve = spla.splu(c.mass.tocsc()).solve if self.p else None
        #: Residual evaluations so far.
        self.evaluations = 0

    def split(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x, v, ω (s, 3)) of a natural-order ``y``."""
        n, p = self.n, self.p
        return y[:n], y[n:n + p], y[n + p:].reshape(-1, 3)

    def _forces(self, t: float, x: np.ndarray, u: np.ndarray
                ) -> tuple[Model, np.ndarray, sp.csr_matrix, sp.csr_matrix | None]:
        """(the model at t, F, G, D_t or None) at ``x`` with velocities ``u``."""
        model = self.model_at(t)
        force = model.force(model_state(model, x))
        g = self.coordinates.g_matrix(x, self.n)
        damping = None
        if self.damping.active:
            damping = (g.T @ self.damping.matrix(x) @ g).tocsr()
        return model, force, g, damping

    def dae_residual(self, t: float, y: np.ndarray, yp: np.ndarray) -> np.ndarray:
        """R(t, y, ẏ) in natural order."""
        self.evaluations += 1
        c, n, p = self.coordinates, self.n, self.p
        x, v, w = self.split(y)
        u = y[n:]
        _, force, g, damping = self._forces(t, x, u)
        out = np.empty(self.size)
        out[c.positions] = yp[c.positions] - v
        q, qp = x[c.quaternions], yp[c.quaternions]
        norm2 = np.sum(q * q, axis=1)
        rows = velocity_rows(q)
        kinematic = np.einsum("ska,sa->sk", rows, qp) - 0.5 * w * norm2[:, None]
        out[c.quaternions[:, :3]] = kinematic
        out[c.quaternions[:, 3]] = 0.5 * (norm2 - 1.0)
        generalised = g.T @ force
        dynamic = np.concatenate([c.mass @ yp[n:n + p],
                                  (c.inertia * yp[n + p:].reshape(-1, 3)
                                   + np.cross(w, c.inertia * w)).ravel()]) - generalised
        if damping is not None:
            dynamic += damping @ u
        out[n:] = dynamic
        return out

    def rates(self, t: float, y: np.ndarray) -> np.ndarray:
        """The consistent ẏ at (t, y) (natural order): ẋ = G u, and the accelerations the
        forces give."""
        c, n = self.coordinates, self.n
        x, v, w = self.split(y)
        u = y[n:]
        _, force, g, damping = self._forces(t, x, u)
        out = np.zeros(self.size)
        out[:n] = g @ u
        right = g.T @ force - np.concatenate([np.zeros(self.p), np.cross(w, c.inertia * w
                                                                         ).ravel()])
        if damping is not None:
            right -= damping @ u
        if self.mass_solve is not None:
            out[n:n + self.p] = self.mass_solve(right[:self.p])
        out[n + self.p:] = right[self.p:] / c.inertia.ravel()
        return out

    def jacobian(self, t: float, y: np.ndarray, yp: np.ndarray, cj: float,
                 structure: bool = False) -> sp.coo_matrix:
        """∂R/∂y + c_j ∂R/∂ẏ in natural order (module docstring); ``structure``: with the
        model's whole Jacobian pattern (ones), for the band widths."""
        c, n, p, s = self.coordinates, self.n, self.p, self.s
        x, _, w = self.split(y)
        q, qp = x[c.quaternions], yp[c.quaternions]
        norm2 = np.sum(q * q, axis=1)
        rows = velocity_rows(q)  # (s, 3, 4): B_k q
        # kinematic rows on x: ∂[(B_k q)·q̇]/∂q = B_kᵀ q̇ and −ω_k q, plus c_j (B_k q)
        turned = np.einsum("kba,sb->ska", B, qp)
        block = turned - w[:, :, None] * q[:, None, :] + cj * rows
        block = np.concatenate([block, q[:, None, :]], axis=1)  # the norm row: qᵀ
        quaternion_rows = block_diagonal(block, c.quaternions, c.quaternions, (n, n))
        positions = sp.csr_matrix((np.full(p, cj), (c.positions, c.positions)), shape=(n, n))
        # kinematic rows on u: −1 on v, −½ |q|² on ω_k
        kin_u = sp.csr_matrix((np.concatenate([-np.ones(p), np.repeat(-0.5 * norm2, 3)]),
                               (np.concatenate([c.positions, c.quaternions[:, :3].ravel()]),
                                np.arange(p + 3 * s))), shape=(n, p + 3 * s))
        dyn_x, dyn_u = self.dynamic_rows(t, y, cj, structure)
        return sp.bmat([[positions + quaternion_rows, kin_u], [dyn_x, dyn_u]]).tocoo()

    def dynamic_rows(self, t: float, y: np.ndarray, cj: float, structure: bool = False
                     ) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """The dynamic rows' derivatives (on x, on u) of R at c_j (module docstring):
        −Gᵀ ∂F/∂x minus the turning of G at fixed F; c_j M, c_j I + the gyroscopic term,
        plus D_t."""
        c, n, p, s = self.coordinates, self.n, self.p, self.s
        x, _, w = self.split(y)
        model, force, g, damping = self._forces(t, x, y[n:])
        stiffness = (model.pattern_matrix(np.ones(model.pattern.nnz)) if structure
                     else model.jacobian(model_state(model, x)))  # ∂F/∂x
        # the turning of G at fixed F: τ_k's derivative ½ B_kᵀ F_q on q (with a minus)
        geometric = 0.5 * np.einsum("kab,sb->ska", B, force[c.quaternions])
        local = np.arange(3 * s).reshape(-1, 3) + p
        dyn_x = -(g.T @ stiffness) + block_diagonal(geometric, local, c.quaternions,
                                                    (p + 3 * s, n))
        rotation = (cj * np.eye(3)[None] * c.inertia[:, :, None]
                    + gyroscopic_jacobian(c.inertia, w))
        dyn_u = sp.block_diag([cj * c.mass, block_diagonal(
            rotation, local - p, local - p, (3 * s, 3 * s))]).tocsr()
        if damping is not None:
            dyn_u = dyn_u + damping
        return dyn_x.tocsr(), dyn_u

    def band_entries(self, matrix: sp.coo_matrix) -> tuple[np.ndarray, np.ndarray,
                                                           np.ndarray]:
        """(rows, cols, values) of a natural-order matrix in band order."""
        return self.place[matrix.row], self.place[matrix.col], matrix.data

    def band(self, t: float, y: np.ndarray) -> tuple[int, int]:
        """(lower, upper) band widths in band order of the Jacobian's structure at
        (t, y)."""
        rows, cols, _ = self.band_entries(self.jacobian(t, y, np.zeros(self.size), 1.0,
                                                        structure=True))
        return int(max(0, np.max(rows - cols))), int(max(0, np.max(cols - rows)))
