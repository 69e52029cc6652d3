"""Kernel of ``rodsim.core.terms.lumen`` (the paper's coupling), Eqs. (24)–(27),
(32)–(35): per tendon point p and its parent catheter node (r, q), local coordinates
(p, r, q),

    Δ = r + r_L d_t(q) − p,   C_t = Δ·d_t (Eqs. 26, 34),   C_n = Δ·d_n,
    ∇C_t = (−d_t, d_t, D_tᵀ(Δ + r_L d_t)),   ∇C_n = (−d_n, d_n, D_nᵀΔ + r_L D_tᵀd_n),
    ∇²C_t: (p, q) block −D_t, (r, q) block D_t,
           (q, q) block 2 r_L D_tᵀD_t + ∂²((Δ + r_L d_t)·d_t)/∂q²,
    ∇²C_n: (p, q) block −D_n, (r, q) block D_n,
           (q, q) block r_L (D_nᵀD_t + D_tᵀD_n) + ∂²(Δ·d_n + r_L d_n·d_t)/∂q²,
    F = −K_L (C_t ∇C_t + C_n ∇C_n),   ∂F/∂x = −K_L (∇C_t ∇C_tᵀ + C_t ∇²C_t + (same for n)),

with D = ∂d/∂q and the constant form Hessians ∂²(w·d)/∂q² at frozen weights w
(``rodsim.core.kernels._lumen_frame``). The C_n part only for ``constrain = "both"``: with
``"d_t"`` the kernel sets d_n and D_n to zero, which drops it exactly. The paper's coupling
(§4.1, Eq. 35) keeps the tendon-point rows, puts −share × them on the parent node's rows
(share = 1 / number of points registered to that node) and zeros the quaternion rows.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._lumen_frame import director_hessian, lumen_frame
from rodsim.core.kernels._scatter import add_force, add_jacobian


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, alpha: float, beta: float, offset: float,
             stiffness: float, both: bool, share: np.ndarray, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    q = np.empty(4)
    d_t = np.empty(3)
    d_n = np.empty(3)
    grad_dt = np.empty((3, 4))
    grad_dn = np.empty((3, 4))
    delta = np.empty(3)
    lever = np.empty(3)
    grad_t = np.empty(10)
    grad_n = np.empty(10)
    w1 = np.empty(3)
    w2 = np.empty(3)
    forms = np.empty((4, 4))
    scratch = np.empty((4, 4))
    local_force = np.empty(10)
    local_jacobian = np.empty((10, 10))
    for e in range(dofs.shape[0]):
        for a in range(4):
            q[a] = x[dofs[e, 6 + a]]
        lumen_frame(q, alpha, beta, d_t, grad_dt, d_n, grad_dn)
        if not both:
            d_n[:] = 0.0
            grad_dn[:, :] = 0.0
        c_t = 0.0
        c_n = 0.0
        for m in range(3):
            delta[m] = x[dofs[e, 3 + m]] + offset * d_t[m] - x[dofs[e, m]]
            lever[m] = delta[m] + offset * d_t[m]
            c_t += delta[m] * d_t[m]
            c_n += delta[m] * d_n[m]
            grad_t[m] = -d_t[m]
            grad_t[3 + m] = d_t[m]
            grad_n[m] = -d_n[m]
            grad_n[3 + m] = d_n[m]
        for a in range(4):
            g_t = 0.0
            g_n = 0.0
            for m in range(3):
                g_t += grad_dt[m, a] * lever[m]
                g_n += grad_dn[m, a] * delta[m] + offset * grad_dt[m, a] * d_n[m]
            grad_t[6 + a] = g_t
            grad_n[6 + a] = g_n
        k_t = stiffness * c_t
        k_n = stiffness * c_n
        if want_force:
            for a in range(10):
                local_force[a] = -k_t * grad_t[a] - k_n * grad_n[a]
            for m in range(3):  # the averaged reaction on the parent node only
                local_force[3 + m] = -share[e] * local_force[m]
            for a in range(4):
                local_force[6 + a] = 0.0
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            for a in range(10):
                for b in range(10):
                    local_jacobian[a, b] = (-stiffness * (grad_t[a] * grad_t[b])
                                            - stiffness * (grad_n[a] * grad_n[b]))
            for m in range(3):
                for a in range(4):
                    h = k_t * grad_dt[m, a] + k_n * grad_dn[m, a]
                    local_jacobian[m, 6 + a] += h
                    local_jacobian[3 + m, 6 + a] -= h
                    local_jacobian[6 + a, m] += h
                    local_jacobian[6 + a, 3 + m] -= h
            # (q, q): k_t ∂²(lever·d_t) + k_n ∂²(Δ·d_n + r_L d_n·d_t) as weights on d1, d2.
            for m in range(3):
                w1[m] = k_t * alpha * lever[m] + k_n * (alpha * offset * d_n[m] - beta * delta[m])
                w2[m] = k_t * beta * lever[m] + k_n * (alpha * delta[m] + beta * offset * d_n[m])
            director_hessian(w1, w2, forms, scratch)
            for a in range(4):
                for b in range(4):
                    products = 0.0
                    for m in range(3):
                        products += (2.0 * k_t * grad_dt[m, a] * grad_dt[m, b]
                                     + k_n * (grad_dn[m, a] * grad_dt[m, b]
                                              + grad_dt[m, a] * grad_dn[m, b]))
                    local_jacobian[6 + a, 6 + b] -= offset * products + forms[a, b]
            for b in range(10):
                for m in range(3):
                    local_jacobian[3 + m, b] = -share[e] * local_jacobian[m, b]
                for a in range(4):
                    local_jacobian[6 + a, b] = 0.0
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)
