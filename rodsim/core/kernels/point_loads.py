"""Kernel of ``rodsim.core.terms.point_loads``: per load, on (r_j, r_{j+1}, q_a, q_b) with the
weights (1 − t, t) of its arclength in segment j, the interpolated q̃ = w_a q_a + w_b q_b, the
moment's shares (μ_a, μ_b) on q_a and q_b, d_k the directors of Eq. (2), G_k = ∂d_k/∂q,
ñ² = |q̃|² and the unit directors at s D_k = d_k(q̃) / ñ²; for each c of the pair, q = q_c
and n² = |q|²:

    F = F_w + Σ_k f_k D_k  → (1 − t) F on r_j, t F on r_{j+1},
    M = M_w + Σ_k m_b,k D_k,   m_k = M · d_k(q) / n²,   Q_c = (2 / n²) Σ_k m_k B_k q,
    μ_c Q_c on q_c,
    ∂D_k/∂q̃ = G_k(q̃) / ñ² − 2 d_k(q̃) q̃ᵀ / ñ⁴,
    ∂m_k/∂q = Mᵀ G_k(q) / n² − 2 m_k qᵀ / n²,   ∂m_k/∂q̃ = d_k(q)ᵀ (∂M/∂q̃) / n²,
    ∂Q_c/∂q_c = (2 / n²) Σ_k (m_k B_k + (B_k q) ∂m_k/∂qᵀ) − 2 Q_c qᵀ / n²,
    ∂Q_c/∂q̃ = (2 / n²) Σ_k (B_k q) ∂m_k/∂q̃ᵀ,   ∂/∂q_a = w_a ∂/∂q̃,  ∂/∂q_b = w_b ∂/∂q̃.

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
def _frame(q: np.ndarray, d: np.ndarray, g: np.ndarray, row: np.ndarray,
           grad: np.ndarray) -> float:
    """d[k, m] ← d_k(q)[m], g[k, m, a] ← ∂d_k[m]/∂q_a; returns |q|²."""
    n2 = 0.0
    for a in range(4):
        n2 += q[a] * q[a]
    for k in range(3):
        director_and_gradient(q, k, row, grad)
        for mm in range(3):
            d[k, mm] = row[mm]
            for a in range(4):
                g[k, mm, a] = grad[mm, a]
    return n2


@njit(cache=True, inline="always")
def _force_jacobian(e: int, body_force: np.ndarray, body_moment: np.ndarray,
                    dunit: np.ndarray, w0: float, w1: float, wa: float, wb: float,
                    dforce: np.ndarray, dtotal: np.ndarray,
                    local_jacobian: np.ndarray) -> None:
    """∂F/∂q̃ and ∂M/∂q̃ into ``dforce``, ``dtotal``; ``local_jacobian`` cleared and given
    the force's rows, (1 − t) and t of ∂F/∂q̃ times w_a, w_b on the two quaternions."""
    for a in range(14):
        for b in range(14):
            local_jacobian[a, b] = 0.0
    for mm in range(3):
        for a in range(4):
            fv = 0.0
            tv = 0.0
            for k in range(3):
                fv += body_force[e, k] * dunit[k, mm, a]
                tv += body_moment[e, k] * dunit[k, mm, a]
            dforce[mm, a] = fv
            dtotal[mm, a] = tv
    for c in range(2):
        w = wa if c == 0 else wb
        col = 6 + 4 * c
        for mm in range(3):
            for a in range(4):
                local_jacobian[mm, col + a] = w0 * w * dforce[mm, a]
                local_jacobian[3 + mm, col + a] = w1 * w * dforce[mm, a]


@njit(cache=True, inline="always")
def _moment_force(total: np.ndarray, q: np.ndarray, d: np.ndarray, n2: float, m: np.ndarray,
                  bq: np.ndarray, moment_force: np.ndarray) -> None:
    """m_k = M · d_k(q) / n², B_k q and Q_c = (2 / n²) Σ_k m_k B_k q, in place."""
    for k in range(3):
        proj = 0.0
        for mm in range(3):
            proj += total[mm] * d[k, mm]
        m[k] = proj / n2
        for a in range(4):
            value = 0.0
            for b in range(4):
                value += _B[k, a, b] * q[b]
            bq[k, a] = value
    for a in range(4):
        moment_force[a] = 2.0 * (m[0] * bq[0, a] + m[1] * bq[1, a]
                                 + m[2] * bq[2, a]) / n2


@njit(cache=True, inline="always")
def _moment_jacobian(c: int, share: float, wa: float, wb: float, total: np.ndarray,
                     dtotal: np.ndarray, q: np.ndarray, d: np.ndarray, g: np.ndarray,
                     n2: float, m: np.ndarray, bq: np.ndarray, moment_force: np.ndarray,
                     dm_q: np.ndarray, dm_i: np.ndarray, direct: np.ndarray,
                     through: np.ndarray, local_jacobian: np.ndarray) -> None:
    """μ_c ∂Q_c/∂q_c and μ_c w_{a,b} ∂Q_c/∂q̃ added to quaternion c's rows of
    ``local_jacobian`` (module docstring)."""
    mine = 6 + 4 * c
    for k in range(3):
        for a in range(4):
            direct_value = 0.0
            frame_value = 0.0
            for mm in range(3):
                direct_value += total[mm] * g[k, mm, a]
                frame_value += d[k, mm] * dtotal[mm, a]
            dm_q[k, a] = direct_value / n2 - 2.0 * m[k] * q[a] / n2
            dm_i[k, a] = frame_value / n2
    for a in range(4):
        for b in range(4):
            value = 0.0
            value_i = 0.0
            for k in range(3):
                value += m[k] * _B[k, a, b] + bq[k, a] * dm_q[k, b]
                value_i += bq[k, a] * dm_i[k, b]
            direct[a, b] = 2.0 * value / n2 - 2.0 * moment_force[a] * q[b] / n2
            through[a, b] = 2.0 * value_i / n2
    for col in range(2):
        w = wa if col == 0 else wb
        base = 6 + 4 * col
        for a in range(4):
            for b in range(4):
                value = w * through[a, b]
                if col == c:
                    value += direct[a, b]
                local_jacobian[mine + a, base + b] += share * value


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, frame_weights: np.ndarray,
             moment_weights: np.ndarray, world_force: np.ndarray, body_force: np.ndarray,
             world_moment: np.ndarray, body_moment: np.ndarray, follower: bool, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    local_force = np.zeros(14)
    local_jacobian = np.zeros((14, 14))
    q = np.empty(4)
    qi = np.empty(4)
    d = np.empty((3, 3))
    g = np.empty((3, 3, 4))
    di = np.empty((3, 3))
    gi = np.empty((3, 3, 4))
    dunit = np.empty((3, 3, 4))  # ∂D_k[m]/∂q̃
    row = np.empty(3)
    grad = np.empty((3, 4))
    f = np.empty(3)
    total = np.empty(3)
    dforce = np.empty((3, 4))
    dtotal = np.empty((3, 4))
    m = np.empty(3)
    dm_q = np.empty((3, 4))
    dm_i = np.empty((3, 4))
    bq = np.empty((3, 4))
    moment_force = np.empty(4)
    direct = np.empty((4, 4))
    through = np.empty((4, 4))
    for e in range(dofs.shape[0]):
        w0 = weights[e, 0]
        w1 = weights[e, 1]
        for a in range(14):
            local_force[a] = 0.0
        if not follower:
            if want_force:
                for a in range(3):
                    local_force[a] = w0 * world_force[e, a]
                    local_force[3 + a] = w1 * world_force[e, a]
                add_force(force, force_target, e, local_force, scale)
            continue
        wa = frame_weights[e, 0]
        wb = frame_weights[e, 1]
        for a in range(4):
            qi[a] = wa * x[dofs[e, 6 + a]] + wb * x[dofs[e, 10 + a]]
        ni2 = _frame(qi, di, gi, row, grad)
        ni4 = ni2 * ni2
        for k in range(3):
            for mm in range(3):
                for a in range(4):
                    dunit[k, mm, a] = gi[k, mm, a] / ni2 - 2.0 * di[k, mm] * qi[a] / ni4
        for mm in range(3):
            fv = world_force[e, mm]
            tv = world_moment[e, mm]
            for k in range(3):
                fv += body_force[e, k] * di[k, mm] / ni2
                tv += body_moment[e, k] * di[k, mm] / ni2
            f[mm] = fv
            total[mm] = tv
        if want_force:
            for a in range(3):
                local_force[a] = w0 * f[a]
                local_force[3 + a] = w1 * f[a]
        if want_jacobian:
            _force_jacobian(e, body_force, body_moment, dunit, w0, w1, wa, wb, dforce, dtotal,
                            local_jacobian)
        for c in range(2):  # each quaternion of the pair: its share of the moment
            share = moment_weights[e, c]
            if share == 0.0:
                continue
            mine = 6 + 4 * c
            for a in range(4):
                q[a] = x[dofs[e, mine + a]]
            n2 = _frame(q, d, g, row, grad)
            _moment_force(total, q, d, n2, m, bq, moment_force)
            if want_force:
                for a in range(4):
                    local_force[mine + a] += share * moment_force[a]
            if want_jacobian:
                _moment_jacobian(c, share, wa, wb, total, dtotal, q, d, g, n2, m, bq,
                                 moment_force, dm_q, dm_i, direct, through, local_jacobian)
        if want_force:
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)
