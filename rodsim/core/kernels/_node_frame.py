"""Node directors of ``rodsim.core.terms._lumen_segment`` for the kernels, one node at a time:
for the unnormalised quaternion sum s = q_{j−1} + q_j and a director combination
d = Σ_k c_k d_{k+1} (forms B_m = Σ_k c_k A[k, m]),

    v = d(s)/|s|² (= d of the bisector frame),   V_m = ∂v_m/∂s = (2/|s|²)(B_m s − v_m s),
    Σ_m w_m ∂²v_m/∂s² = (2/|s|²)(Σ_m w_m B_m − (w·v) I − s (Vᵀw)ᵀ − (Vᵀw) sᵀ),

with the director forms A of ``rodsim.core.kernels._quaternion``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._quaternion import director_and_gradient, form_combination


@njit(cache=True)
def raw_directors(s: np.ndarray, directors: np.ndarray, gradients: np.ndarray) -> float:
    """directors[k] ← sᵀA[k]s (3,) and gradients[k] ← 2 A[k] s (3, 4) for k = 0, 1, 2, in
    place; returns |s|²."""
    for k in range(3):
        director_and_gradient(s, k, directors[k], gradients[k])
    norm2 = 0.0
    for a in range(4):
        norm2 += s[a] * s[a]
    return norm2


@njit(cache=True)
def node_director(s: np.ndarray, norm2: float, directors: np.ndarray, gradients: np.ndarray,
                  c: np.ndarray, value: np.ndarray, grad: np.ndarray) -> None:
    """value ← v (3,) and grad ← V (3, 4) of the combination ``c`` (3,), in place."""
    for m in range(3):
        raw = 0.0
        for k in range(3):
            raw += c[k] * directors[k, m]
        value[m] = raw / norm2
    for m in range(3):
        for a in range(4):
            raw = 0.0
            for k in range(3):
                raw += c[k] * gradients[k, m, a]
            grad[m, a] = (raw - 2.0 * value[m] * s[a]) / norm2


@njit(cache=True)
def node_director_hessian(s: np.ndarray, norm2: float, c: np.ndarray, value: np.ndarray,
                          grad: np.ndarray, weights: np.ndarray, out: np.ndarray,
                          scratch: np.ndarray, scaled: np.ndarray) -> None:
    """out ← Σ_m w_m ∂²v_m/∂s² (4, 4); scratch (4, 4) and scaled (3,) are work space."""
    for a in range(4):
        for b in range(4):
            out[a, b] = 0.0
    for k in range(3):
        if c[k] != 0.0:
            for m in range(3):
                scaled[m] = c[k] * weights[m]
            form_combination(scaled, k, scratch)
            for a in range(4):
                for b in range(4):
                    out[a, b] += scratch[a, b]
    wv = 0.0
    for m in range(3):
        wv += weights[m] * value[m]
    for a in range(4):
        wg_a = 0.0
        for m in range(3):
            wg_a += weights[m] * grad[m, a]
        for b in range(4):
            wg_b = 0.0
            for m in range(3):
                wg_b += weights[m] * grad[m, b]
            entry = out[a, b] - s[a] * wg_b - wg_a * s[b]
            if a == b:
                entry -= wv
            out[a, b] = 2.0 * entry / norm2
