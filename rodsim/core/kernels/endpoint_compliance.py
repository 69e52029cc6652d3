"""Kernel of ``rodsim.core.terms.endpoint_compliance``, Eq. (28): on (t, r_N, q_last),

    Δ = L_N − t = r_N + r_L d_t(q) − t,   ∂Δ/∂(t, r_N, q) = G = [−I, I, r_L D_t],
    paper:       F = (K_E Δ, 0, 0),            ∂F/∂x = K_E G on the t rows, zero elsewhere;
    conserving:  F = −K_E GᵀΔ = (K_E Δ, −K_E Δ, −K_E r_L D_tᵀΔ),
                 ∂F/∂x = −K_E GᵀG − K_E r_L Σ_m Δ_m H_t[m] on the (q, q) block,

with D_t = ∂d_t/∂q and H_t[m] = ∂²d_t[m]/∂q², so Σ_m Δ_m H_t[m] = ∂²(Δ·d_t)/∂q² at frozen Δ
(``rodsim.core.kernels._lumen_frame``). The energy ½ K_E |Δ|² of the conserving coupling
(``energy``; the paper's has none) is what the line searches evaluate: in numpy it was
four calls of ~21 µs in each energy of four-tendons (docs/benchmark-history.md).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._lumen_frame import director_hessian, lumen_frame
from rodsim.core.kernels._scatter import add_force, add_jacobian


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, alpha: float, beta: float, offset: float,
             stiffness: float, conserving: bool, scale: float, want_force: bool,
             force: np.ndarray, force_target: np.ndarray, want_jacobian: bool,
             jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    q = np.empty(4)
    d_t = np.empty(3)
    grad_dt = np.empty((3, 4))
    d_n = np.empty(3)
    grad_dn = np.empty((3, 4))
    delta = np.empty(3)
    w1 = np.empty(3)
    w2 = np.empty(3)
    forms = np.empty((4, 4))
    scratch = np.empty((4, 4))
    gradient = np.zeros((3, 10))
    for m in range(3):
        gradient[m, m] = -1.0
        gradient[m, 3 + m] = 1.0
    local_force = np.zeros(10)
    local_jacobian = np.zeros((10, 10))
    for e in range(dofs.shape[0]):
        for a in range(4):
            q[a] = x[dofs[e, 6 + a]]
        lumen_frame(q, alpha, beta, d_t, grad_dt, d_n, grad_dn)
        for m in range(3):
            delta[m] = x[dofs[e, 3 + m]] + offset * d_t[m] - x[dofs[e, m]]
        if want_force:
            for m in range(3):
                local_force[m] = stiffness * delta[m]
            if conserving:
                for m in range(3):
                    local_force[3 + m] = -stiffness * delta[m]
                for a in range(4):
                    moment = 0.0
                    for m in range(3):
                        moment += grad_dt[m, a] * delta[m]
                    local_force[6 + a] = -stiffness * offset * moment
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            for m in range(3):
                for a in range(4):
                    gradient[m, 6 + a] = offset * grad_dt[m, a]
            if conserving:
                for a in range(10):
                    for b in range(10):
                        product = 0.0
                        for m in range(3):
                            product += gradient[m, a] * gradient[m, b]
                        local_jacobian[a, b] = -stiffness * product
                for m in range(3):
                    w1[m] = alpha * delta[m]
                    w2[m] = beta * delta[m]
                director_hessian(w1, w2, forms, scratch)
                for a in range(4):
                    for b in range(4):
                        local_jacobian[6 + a, 6 + b] -= stiffness * offset * forms[a, b]
            else:
                for m in range(3):
                    for b in range(10):
                        local_jacobian[m, b] = stiffness * gradient[m, b]
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, alpha: float, beta: float, offset: float,
           stiffness: float, conserving: bool) -> float:
    """½ K_E |Δ|² summed over the elements (conserving coupling); NaN for the paper's, which
    has no energy (the model never asks: the term is not conservative)."""
    if not conserving:
        return np.nan
    q = np.empty(4)
    d_t = np.empty(3)
    grad_dt = np.empty((3, 4))
    d_n = np.empty(3)
    grad_dn = np.empty((3, 4))
    total = 0.0
    for e in range(dofs.shape[0]):
        for a in range(4):
            q[a] = x[dofs[e, 6 + a]]
        lumen_frame(q, alpha, beta, d_t, grad_dt, d_n, grad_dn)
        square = 0.0
        for m in range(3):
            delta = x[dofs[e, 3 + m]] + offset * d_t[m] - x[dofs[e, m]]
            square += delta * delta
        total += 0.5 * stiffness * square
    return total
