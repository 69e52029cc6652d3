"""Kernel of :mod:`rodsim.core.terms.tendon_string`: V = T ℓ, one element per chord of the
tendon's path between routing points A and B (28 coordinates: r_m, r_{m+1}, Q_0, Q_1 of A,
then of B). For a point with weights (c0, c1, w0, w1), constant quaternion q_c and forms G_m,

    q = w0 Q_0 + w1 Q_1 + q_c,  n = |q|²,  g_m = qᵀ G_m q,  p = c0 r_m + c1 r_{m+1} + g / n,
    ∂p/∂q = 2 G q / n − 2 g qᵀ / n²,
    ∂²p_m/∂q² = 2 G_m/n − 4 (G_m q qᵀ + q qᵀ G_m)/n² − 2 g_m I/n² + 8 g_m q qᵀ/n³;

with d = p_B − p_A, u = d/|d|: F = −T Jdᵀ u and ∂F/∂x = −T [Jdᵀ (I − u uᵀ) Jd / |d|
+ Σ_m u_m (∂²p_B[m] − ∂²p_A[m])], Jd = [−J_A, J_B].
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._scatter import add_force, add_jacobian


@njit(cache=True)
def _point(x: np.ndarray, dofs: np.ndarray, e: int, side: int, weights: np.ndarray,
           constant: np.ndarray, forms: np.ndarray, p: np.ndarray, jac: np.ndarray,
           hess: np.ndarray, want_hessian: bool, q: np.ndarray, gq: np.ndarray,
           g: np.ndarray) -> None:
    """Position p (3,), ∂p/∂x_point (3, 14) and ∇²f (3, 4, 4) of point e + side; ``q``
    (4,), ``gq`` (3, 4) and ``g`` (3,) are scratch (allocated once by the caller: an
    allocation per point was most of a force evaluation's time)."""
    k = e + side
    base = 14 * side
    c0, c1, w0, w1 = weights[k, 0], weights[k, 1], weights[k, 2], weights[k, 3]
    for i in range(4):
        q[i] = w0 * x[dofs[e, base + 6 + i]] + w1 * x[dofs[e, base + 10 + i]] + constant[k, i]
    n = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]
    for m in range(3):
        value = 0.0
        for i in range(4):
            row = 0.0
            for j in range(4):
                row += forms[k, m, i, j] * q[j]
            gq[m, i] = row
            value += row * q[i]
        g[m] = value
    for m in range(3):
        p[m] = (c0 * x[dofs[e, base + m]] + c1 * x[dofs[e, base + 3 + m]] + g[m] / n)
        for a in range(14):
            jac[m, a] = 0.0
        jac[m, m] = c0
        jac[m, 3 + m] = c1
        for i in range(4):
            grad = 2.0 * gq[m, i] / n - 2.0 * g[m] * q[i] / (n * n)
            jac[m, 6 + i] = w0 * grad
            jac[m, 10 + i] = w1 * grad
        if want_hessian:
            for i in range(4):
                for j in range(4):
                    h = (2.0 * forms[k, m, i, j] / n
                         - 4.0 * (gq[m, i] * q[j] + q[i] * gq[m, j]) / (n * n)
                         + 8.0 * g[m] * q[i] * q[j] / (n * n * n))
                    if i == j:
                        h -= 2.0 * g[m] / (n * n)
                    hess[m, i, j] = h


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
             forms: np.ndarray, tension: float, scale: float, want_force: bool,
             force: np.ndarray, force_target: np.ndarray, want_jacobian: bool,
             jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    local_force = np.empty(28)
    local_jacobian = np.empty((28, 28))
    pa = np.empty(3)
    pb = np.empty(3)
    ja = np.empty((3, 14))
    jb = np.empty((3, 14))
    ha = np.empty((3, 4, 4))
    hb = np.empty((3, 4, 4))
    jd = np.empty((3, 28))
    u = np.empty(3)
    proj = np.empty((3, 3))
    pj = np.empty((3, 28))
    q = np.empty(4)
    gq = np.empty((3, 4))
    g = np.empty(3)
    for e in range(dofs.shape[0]):
        _point(x, dofs, e, 0, weights, constant, forms, pa, ja, ha, want_jacobian, q, gq, g)
        _point(x, dofs, e, 1, weights, constant, forms, pb, jb, hb, want_jacobian, q, gq, g)
        length = 0.0
        for m in range(3):
            u[m] = pb[m] - pa[m]
            length += u[m] * u[m]
        length = np.sqrt(length)
        for m in range(3):
            u[m] /= length
            for a in range(14):
                jd[m, a] = -ja[m, a]
                jd[m, 14 + a] = jb[m, a]
        if want_force:
            for a in range(28):
                value = 0.0
                for m in range(3):
                    value += jd[m, a] * u[m]
                local_force[a] = -tension * value
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            for a in range(3):
                for b in range(3):
                    proj[a, b] = ((1.0 if a == b else 0.0) - u[a] * u[b]) * tension / length
            for a in range(3):
                for k in range(28):
                    value = 0.0
                    for b in range(3):
                        value += proj[a, b] * jd[b, k]
                    pj[a, k] = value
            for k in range(28):
                for j in range(28):
                    value = 0.0
                    for a in range(3):
                        value += jd[a, k] * pj[a, j]
                    local_jacobian[k, j] = -value
            for side in range(2):
                k = e + side
                sign = 1.0 if side == 1 else -1.0
                offset = 14 * side + 6
                for i in range(4):
                    for j in range(4):
                        curvature = 0.0
                        for m in range(3):
                            curvature += u[m] * (hb[m, i, j] if side == 1 else ha[m, i, j])
                        curvature *= sign * tension
                        for a in range(2):
                            for b in range(2):
                                local_jacobian[offset + 4 * a + i, offset + 4 * b + j] -= (
                                    weights[k, 2 + a] * weights[k, 2 + b] * curvature)
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
           forms: np.ndarray, tension: float) -> float:
    """T Σ |p_{k+1} − p_k|."""
    pa = np.empty(3)
    pb = np.empty(3)
    ja = np.empty((3, 14))
    hess = np.empty((3, 4, 4))
    q = np.empty(4)
    gq = np.empty((3, 4))
    g = np.empty(3)
    total = 0.0
    for e in range(dofs.shape[0]):
        _point(x, dofs, e, 0, weights, constant, forms, pa, ja, hess, False, q, gq, g)
        _point(x, dofs, e, 1, weights, constant, forms, pb, ja, hess, False, q, gq, g)
        total += np.sqrt((pb[0] - pa[0]) ** 2 + (pb[1] - pa[1]) ** 2 + (pb[2] - pa[2]) ** 2)
    return tension * total
