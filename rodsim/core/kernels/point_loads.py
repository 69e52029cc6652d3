"""Kernel of :mod:`rodsim.core.terms.point_loads`: per load, on (r_j, r_{j+1}, q_j) with the
weights (1 − t, t) of its arclength in segment j, n² = |q|², d_k the directors of Eq. (2),

    F = F_w + Σ_k f_k d_k / n²  → (1 − t) F on r_j, t F on r_{j+1},
    m_k = m_b,k + M_w · d_k / n²,   Q = (2 / n²) Σ_k m_k B_k q  on q_j,
    ∂F/∂q = Σ_k f_k (G_k / n² − 2 d_k qᵀ / n⁴),   G_k = ∂d_k/∂q,
    ∂m_k/∂q = M_wᵀ G_k / n² − 2 (M_w · d_k) qᵀ / n⁴,
    ∂Q/∂q = (2 / n²) Σ_k (m_k B_k + (B_k q) ∂m_kᵀ) − 2 Q qᵀ / n².

Without follower loads or moments (``follower`` false) only the dead forces are added.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._quaternion import director_and_gradient
from rodsim.core.kernels._scatter import add_force, add_jacobian
from rodsim.core.rod.quaternion import B

_B = np.ascontiguousarray(B)


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, world_force: np.ndarray,
             body_force: np.ndarray, world_moment: np.ndarray, body_moment: np.ndarray,
             follower: bool, scale: float, want_force: bool, force: np.ndarray,
             force_target: np.ndarray, want_jacobian: bool, jacobian: np.ndarray,
             jacobian_target: np.ndarray) -> None:
    local_force = np.zeros(10)
    local_jacobian = np.zeros((10, 10))
    q = np.empty(4)
    d = np.empty((3, 3))  # d[k, m]
    g = np.empty((3, 3, 4))  # ∂d_k[m]/∂q
    row = np.empty(3)
    grad = np.empty((3, 4))
    f = np.empty(3)
    m = np.empty(3)
    dm = np.empty((3, 4))
    bq = np.empty((3, 4))
    moment_force = np.empty(4)
    dforce = np.empty((3, 4))
    for e in range(dofs.shape[0]):
        w0 = weights[e, 0]
        w1 = weights[e, 1]
        if not follower:
            if want_force:
                for a in range(3):
                    local_force[a] = w0 * world_force[e, a]
                    local_force[3 + a] = w1 * world_force[e, a]
                    local_force[6 + a] = 0.0
                local_force[9] = 0.0
                add_force(force, force_target, e, local_force, scale)
            continue
        n2 = 0.0
        for a in range(4):
            q[a] = x[dofs[e, 6 + a]]
            n2 += q[a] * q[a]
        for k in range(3):
            director_and_gradient(q, k, row, grad)
            for mm in range(3):
                d[k, mm] = row[mm]
                for a in range(4):
                    g[k, mm, a] = grad[mm, a]
        for mm in range(3):
            value = world_force[e, mm]
            for k in range(3):
                value += body_force[e, k] * d[k, mm] / n2
            f[mm] = value
        for k in range(3):
            proj = 0.0
            for mm in range(3):
                proj += world_moment[e, mm] * d[k, mm]
            m[k] = body_moment[e, k] + proj / n2
            for a in range(4):
                value = 0.0
                for b in range(4):
                    value += _B[k, a, b] * q[b]
                bq[k, a] = value
        for a in range(4):
            moment_force[a] = 2.0 * (m[0] * bq[0, a] + m[1] * bq[1, a] + m[2] * bq[2, a]) / n2
        if want_force:
            for a in range(3):
                local_force[a] = w0 * f[a]
                local_force[3 + a] = w1 * f[a]
            for a in range(4):
                local_force[6 + a] = moment_force[a]
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            n4 = n2 * n2
            for mm in range(3):
                for a in range(4):
                    value = 0.0
                    for k in range(3):
                        value += body_force[e, k] * (g[k, mm, a] / n2
                                                     - 2.0 * d[k, mm] * q[a] / n4)
                    dforce[mm, a] = value
            for k in range(3):
                proj = 0.0
                for mm in range(3):
                    proj += world_moment[e, mm] * d[k, mm]
                for a in range(4):
                    value = 0.0
                    for mm in range(3):
                        value += world_moment[e, mm] * g[k, mm, a]
                    dm[k, a] = value / n2 - 2.0 * proj * q[a] / n4
            for a in range(10):
                for b in range(10):
                    local_jacobian[a, b] = 0.0
            for mm in range(3):
                for a in range(4):
                    local_jacobian[mm, 6 + a] = w0 * dforce[mm, a]
                    local_jacobian[3 + mm, 6 + a] = w1 * dforce[mm, a]
            for a in range(4):
                for b in range(4):
                    value = 0.0
                    for k in range(3):
                        value += m[k] * _B[k, a, b] + bq[k, a] * dm[k, b]
                    local_jacobian[6 + a, 6 + b] = (2.0 * value / n2
                                                    - 2.0 * moment_force[a] * q[b] / n2)
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)
