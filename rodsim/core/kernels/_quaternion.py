"""Quaternion algebra of Eq. (2) for the kernels, one quaternion at a time.

Every director is a quadratic form of q, ``d_k[m] = qᵀ A[k, m] q`` with the constant
symmetric matrices ``A = DIRECTOR_FORMS`` (``rodsim.core.rod.quaternion``), so

    ∂d_k[m]/∂q = 2 A[k, m] q,   ∂²(w · d_k)/∂q² = 2 Σ_m w_m A[k, m].

``A`` is a module-level array, which numba freezes into the compiled code as a constant.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.rod.quaternion import DIRECTOR_FORMS

_FORMS = np.ascontiguousarray(DIRECTOR_FORMS)


@njit(cache=True)
def director_and_gradient(q: np.ndarray, k: int, director: np.ndarray,
                          gradient: np.ndarray) -> None:
    """director ← d_{k+1}(q) (3,) and gradient ← ∂d_{k+1}/∂q (3, 4), row m = 2 A[k, m] q."""
    for m in range(3):
        value = 0.0
        for i in range(4):
            row = 0.0
            for j in range(4):
                row += _FORMS[k, m, i, j] * q[j]
            gradient[m, i] = 2.0 * row
            value += q[i] * row
        director[m] = value


@njit(cache=True)
def form_combination(weights: np.ndarray, k: int, out: np.ndarray) -> None:
    """out ← Σ_m weights[m] A[k, m] (4, 4)."""
    for i in range(4):
        for j in range(4):
            out[i, j] = (weights[0] * _FORMS[k, 0, i, j] + weights[1] * _FORMS[k, 1, i, j]
                         + weights[2] * _FORMS[k, 2, i, j])
