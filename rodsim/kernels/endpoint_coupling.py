"""Kernel of :mod:`rodsim.terms.endpoint_coupling`, Eq. (29): on (r_N, t), edge e = t − r_N,

    F = K_C (|e| − r_L) ê on r_N, minus that on t,
    H = K_C [ê êᵀ + ((|e| − r_L) / |e|)(I − ê êᵀ)],  ∂F/∂(r_N, t) = [[−H, H], [H, −H]].
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.kernels._scatter import add_force, add_jacobian


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, stiffness: float, offset: float, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    local_force = np.empty(6)
    local_jacobian = np.empty((6, 6))
    t = np.empty(3)
    for e in range(dofs.shape[0]):
        norm2 = 0.0
        for a in range(3):
            t[a] = x[dofs[e, 3 + a]] - x[dofs[e, a]]
            norm2 += t[a] * t[a]
        norm = np.sqrt(norm2)
        for a in range(3):
            t[a] /= norm
        stretch = norm - offset
        if want_force:
            for a in range(3):
                pull = stiffness * stretch * t[a]
                local_force[a] = pull
                local_force[3 + a] = -pull
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            ratio = stretch / norm
            for a in range(3):
                for b in range(3):
                    tt = t[a] * t[b]
                    h = stiffness * (tt + ratio * ((1.0 if a == b else 0.0) - tt))
                    local_jacobian[a, b] = -h
                    local_jacobian[3 + a, 3 + b] = -h
                    local_jacobian[a, 3 + b] = h
                    local_jacobian[3 + a, b] = h
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)
