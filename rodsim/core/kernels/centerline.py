"""Kernel of ``rodsim.core.terms.centerline``, Eq. (9), on the offset state: per segment
(r_j, r_{j+1}, q_j), with W = K_P l, e = r_{j+1} − r_j, t = e/|e|, P = I − t tᵀ,
q = q⁰ + δ, d3 = d3(q_j) and G = ∂d3/∂q (Eq. 2),

    w = (t − T) − ½ (G(q⁰) + G(q)) δ + m⁰   (= t − d3, formed without cancellation),
    F = (F_e, −F_e, W Gᵀ w),   F_e = W P w / |e|,
    H_ee = W [P − (t wᵀ + w tᵀ) − (w·t)(I − 3 t tᵀ)] / |e|²,   H_eq = −W P G / |e|,
    H_qq = W [Gᵀ G − 2 Σ_m w_m A[2, m]],
    ∂F/∂(r_j, r_{j+1}, q_j) = −[[H_ee, −H_ee, −H_eq], [−H_ee, H_ee, H_eq],
                                [−H_eqᵀ, H_eqᵀ, H_qq]].
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._quaternion import director_and_gradient, form_combination
from rodsim.core.kernels._scatter import add_force, add_jacobian
from rodsim.core.kernels._spring import offset_edge


@njit(cache=True, inline="always")
def _mismatch(x: np.ndarray, dofs: np.ndarray, e: int, rest_edges: np.ndarray,
              rest_lengths: np.ndarray, rest_quaternions: np.ndarray, rest_gradients: np.ndarray,
              rest_mismatch: np.ndarray, t: np.ndarray, q: np.ndarray, w: np.ndarray,
              d3: np.ndarray, gradient: np.ndarray) -> float:
    """|e| of element ``e``; t, q = q⁰ + δ, w (module docstring: the change of d3 is
    ½ (G(q⁰) + G(q)) δ, G(q⁰) = ``rest_gradients[e]``), and d3(q), G(q) into ``d3`` and
    ``gradient`` (``w`` holds t − T on the way)."""
    norm = offset_edge(x, dofs, e, rest_edges, rest_lengths, t, w)[0]
    for i in range(4):
        q[i] = rest_quaternions[e, i] + x[dofs[e, 6 + i]]
    director_and_gradient(q, 2, d3, gradient)
    for m in range(3):
        change = 0.0
        for i in range(4):
            change += (rest_gradients[e, m, i] + gradient[m, i]) * x[dofs[e, 6 + i]]
        w[m] += rest_mismatch[e, m] - 0.5 * change
    return norm


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, weight: float, rest_edges: np.ndarray,
             rest_lengths: np.ndarray, rest_quaternions: np.ndarray, rest_gradients: np.ndarray,
             rest_mismatch: np.ndarray, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    local_force = np.empty(10)
    local_jacobian = np.empty((10, 10))
    t = np.empty(3)
    q = np.empty(4)
    d3 = np.empty(3)
    gradient = np.empty((3, 4))
    w = np.empty(3)
    projector = np.empty((3, 3))
    curvature = np.empty((4, 4))
    for e in range(dofs.shape[0]):
        norm = _mismatch(x, dofs, e, rest_edges, rest_lengths, rest_quaternions,
                         rest_gradients, rest_mismatch, t, q, w, d3, gradient)
        wt = 0.0
        for a in range(3):
            wt += w[a] * t[a]
        if want_force:
            for a in range(3):
                f_e = weight * (w[a] - wt * t[a]) / norm
                local_force[a] = f_e
                local_force[3 + a] = -f_e
            for i in range(4):
                gw = 0.0
                for m in range(3):
                    gw += gradient[m, i] * w[m]
                local_force[6 + i] = weight * gw
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            for a in range(3):
                for b in range(3):
                    eye = 1.0 if a == b else 0.0
                    tt = t[a] * t[b]
                    projector[a, b] = eye - tt
                    h = weight * (projector[a, b] - (t[a] * w[b] + w[a] * t[b])
                                  - wt * (eye - 3.0 * tt)) / (norm * norm)
                    local_jacobian[a, b] = -h
                    local_jacobian[3 + a, 3 + b] = -h
                    local_jacobian[a, 3 + b] = h
                    local_jacobian[3 + a, b] = h
            for a in range(3):
                for i in range(4):
                    pg = 0.0
                    for b in range(3):
                        pg += projector[a, b] * gradient[b, i]
                    h = -weight * pg / norm
                    local_jacobian[a, 6 + i] = h
                    local_jacobian[3 + a, 6 + i] = -h
                    local_jacobian[6 + i, a] = h
                    local_jacobian[6 + i, 3 + a] = -h
            form_combination(w, 2, curvature)
            for i in range(4):
                for j in range(4):
                    gg = 0.0
                    for m in range(3):
                        gg += gradient[m, i] * gradient[m, j]
                    local_jacobian[6 + i, 6 + j] = -weight * (gg - 2.0 * curvature[i, j])
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, weight: float, rest_edges: np.ndarray,
           rest_lengths: np.ndarray, rest_quaternions: np.ndarray, rest_gradients: np.ndarray,
           rest_mismatch: np.ndarray) -> float:
    """Σ ½ K_P l |w|², w = t − d3(q) formed about the rest state."""
    t = np.empty(3)
    q = np.empty(4)
    w = np.empty(3)
    d3 = np.empty(3)
    gradient = np.empty((3, 4))
    total = 0.0
    for e in range(dofs.shape[0]):
        _mismatch(x, dofs, e, rest_edges, rest_lengths, rest_quaternions, rest_gradients,
                  rest_mismatch, t, q, w, d3, gradient)
        for a in range(3):
            total += 0.5 * weight * w[a] ** 2
    return total
