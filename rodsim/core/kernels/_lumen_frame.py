"""The lumen frame of Eq. (32) for the tendon kernels, one quaternion at a time.

    d_t = α d1 + β d2,   d_n = α d2 − β d1 (= d3 × d_t),   D = ∂d/∂q likewise,

from the directors of Eq. (2) (``rodsim.core.kernels._quaternion``). Every director is a
quadratic form of q, so the q-Hessian of a weighted sum w1·d1 + w2·d2 (with constant
weights) is the constant 2 Σ_m (w1_m A[0, m] + w2_m A[1, m]), A = ``DIRECTOR_FORMS``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._quaternion import director_and_gradient, form_combination


@njit(cache=True)
def lumen_frame(q: np.ndarray, alpha: float, beta: float, d_t: np.ndarray, grad_dt: np.ndarray,
                d_n: np.ndarray, grad_dn: np.ndarray) -> None:
    """d_t, ∂d_t/∂q (3, 4), d_n, ∂d_n/∂q (3, 4), written in place."""
    director_and_gradient(q, 0, d_t, grad_dt)
    director_and_gradient(q, 1, d_n, grad_dn)
    for m in range(3):
        d1 = d_t[m]
        d2 = d_n[m]
        d_t[m] = alpha * d1 + beta * d2
        d_n[m] = alpha * d2 - beta * d1
        for a in range(4):
            g1 = grad_dt[m, a]
            g2 = grad_dn[m, a]
            grad_dt[m, a] = alpha * g1 + beta * g2
            grad_dn[m, a] = alpha * g2 - beta * g1


@njit(cache=True)
def director_hessian(w1: np.ndarray, w2: np.ndarray, out: np.ndarray,
                     scratch: np.ndarray) -> None:
    """out ← ∂²(w1·d1 + w2·d2)/∂q² = 2 Σ_m (w1_m A[0, m] + w2_m A[1, m]) (4, 4)."""
    form_combination(w1, 0, out)
    form_combination(w2, 1, scratch)
    for a in range(4):
        for b in range(4):
            out[a, b] = 2.0 * (out[a, b] + scratch[a, b])
