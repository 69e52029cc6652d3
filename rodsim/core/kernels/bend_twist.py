"""Kernel of ``rodsim.core.terms.bend_twist``, Eqs. (3), (7), (8): per element (a, b) =
(q_{i−1}, q_i), or a frame element with one side a support's constant frame (``fixed[e]``
= 1: a = ``frames[e]``, as (q_c, q_0) at a clamped base; 2: b = ``frames[e]``; 0: neither),
with the element's stiffness K_k of Eq. (8) (``stiffness[e, k]``) and the dual length l̄,

    f_k = (B_k a)·b,   c = (2/l̄) / (|a||b|),   u_k = c f_k,   E = ½ l̄ Σ_k K_k u_k²,
    ∇u_k = c h_k,   h_k = (B_kᵀ b − f_k a/|a|², B_k a − f_k b/|b|²),
    F = −Σ_k w_k h_k,   w_k = l̄ K_k u_k c,
    −∂F/∂(a, b) = Σ_k l̄ K_k c² h_k h_kᵀ + [[H_aa, H_ab], [H_abᵀ, H_bb]], with φ = Σ_k w_k f_k,
    γ_a = Σ_k w_k B_kᵀ b, γ_b = Σ_k w_k B_k a and
    H_aa = −[γ_a aᵀ + a γ_aᵀ + φ I − 3 φ a aᵀ/|a|²] / |a|²  (H_bb likewise with b, γ_b),
    H_ab = Σ_k w_k B_kᵀ − γ_a bᵀ/|b|² − a γ_bᵀ/|a|² + φ a bᵀ/(|a|²|b|²).

A frame element's constant side has zero force and Jacobian entries (its ``dofs`` repeat the
free side's there, so exact zeros are added to real slots).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._scatter import add_force, add_jacobian
from rodsim.core.rod.quaternion import B

_B = np.ascontiguousarray(B)


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, dual_lengths: np.ndarray,
             stiffness: np.ndarray, fixed: np.ndarray, frames: np.ndarray, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    local_force = np.empty(8)
    local_jacobian = np.empty((8, 8))
    q = np.empty(8)  # (a, b)
    f = np.empty(3)
    w = np.empty(3)
    gauss_newton = np.empty(3)
    g = np.empty((3, 8))  # (∂f_k/∂a, ∂f_k/∂b) = (B_kᵀ b, B_k a)
    h = np.empty((3, 8))  # ∇u_k / c
    wg = np.empty(8)  # (γ_a, γ_b)
    for e in range(dofs.shape[0]):
        side = fixed[e]
        for i in range(4):
            q[i] = frames[e, i] if side == 1 else x[dofs[e, i]]
            q[4 + i] = frames[e, i] if side == 2 else x[dofs[e, 4 + i]]
        na2 = 0.0
        nb2 = 0.0
        for i in range(4):
            na2 += q[i] * q[i]
            nb2 += q[4 + i] * q[4 + i]
        lbar = dual_lengths[e]
        c = 2.0 / (lbar * np.sqrt(na2 * nb2))
        for k in range(3):
            fk = 0.0
            for i in range(4):
                bt_b = 0.0
                b_a = 0.0
                for j in range(4):
                    bt_b += _B[k, j, i] * q[4 + j]
                    b_a += _B[k, i, j] * q[j]
                g[k, i] = bt_b
                g[k, 4 + i] = b_a
                fk += b_a * q[4 + i]
            f[k] = fk
            w[k] = lbar * c * stiffness[e, k] * (c * fk)
            gauss_newton[k] = lbar * c * c * stiffness[e, k]
            for i in range(4):
                h[k, i] = g[k, i] - fk / na2 * q[i]
                h[k, 4 + i] = g[k, 4 + i] - fk / nb2 * q[4 + i]
        if want_force:
            for i in range(8):
                local_force[i] = -(w[0] * h[0, i] + w[1] * h[1, i] + w[2] * h[2, i])
            if side == 1:
                local_force[:4] = 0.0
            elif side == 2:
                local_force[4:] = 0.0
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            phi = w[0] * f[0] + w[1] * f[1] + w[2] * f[2]
            for i in range(8):
                wg[i] = w[0] * g[0, i] + w[1] * g[1, i] + w[2] * g[2, i]
                for j in range(8):
                    local_jacobian[i, j] = -(gauss_newton[0] * h[0, i] * h[0, j]
                                             + gauss_newton[1] * h[1, i] * h[1, j]
                                             + gauss_newton[2] * h[2, i] * h[2, j])
            nab = na2 * nb2
            for i in range(4):
                a_i = q[i]
                b_i = q[4 + i]
                for j in range(4):
                    a_j = q[j]
                    b_j = q[4 + j]
                    eye = phi if i == j else 0.0
                    h_aa = -(wg[i] * a_j + a_i * wg[j] + eye
                             - 3.0 * (phi / na2) * (a_i * a_j)) / na2
                    h_bb = -(wg[4 + i] * b_j + b_i * wg[4 + j] + eye
                             - 3.0 * (phi / nb2) * (b_i * b_j)) / nb2
                    h_ab = (w[0] * _B[0, j, i] + w[1] * _B[1, j, i] + w[2] * _B[2, j, i]
                            - wg[i] * b_j / nb2 - a_i * wg[4 + j] / na2
                            + phi / nab * (a_i * b_j))
                    local_jacobian[i, j] -= h_aa
                    local_jacobian[4 + i, 4 + j] -= h_bb
                    local_jacobian[i, 4 + j] -= h_ab
                    local_jacobian[4 + j, i] -= h_ab
            if side == 1:
                local_jacobian[:4, :] = 0.0
                local_jacobian[:, :4] = 0.0
            elif side == 2:
                local_jacobian[4:, :] = 0.0
                local_jacobian[:, 4:] = 0.0
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, dual_lengths: np.ndarray, stiffness: np.ndarray,
           fixed: np.ndarray, frames: np.ndarray) -> float:
    """Σ_elements ½ l̄ Σ_k K_k u_k², u_k = (2/l̄)(B_k a)·b / (|a||b|)."""
    a = np.empty(4)
    b = np.empty(4)
    total = 0.0
    for e in range(dofs.shape[0]):
        side = fixed[e]
        na2 = 0.0
        nb2 = 0.0
        for i in range(4):
            a[i] = frames[e, i] if side == 1 else x[dofs[e, i]]
            b[i] = frames[e, i] if side == 2 else x[dofs[e, 4 + i]]
            na2 += a[i] * a[i]
            nb2 += b[i] * b[i]
        lbar = dual_lengths[e]
        c = 2.0 / (lbar * np.sqrt(na2 * nb2))
        for k in range(3):
            fk = 0.0
            for i in range(4):
                for j in range(4):
                    fk += _B[k, i, j] * a[j] * b[i]
            u = c * fk
            total += 0.5 * lbar * stiffness[e, k] * u * u
    return total
