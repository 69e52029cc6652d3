"""Kernel of :mod:`rodsim.terms.stretch`, Eq. (6): per segment (r_j, r_{j+1}),

    F = K_s ε t (on r_j, minus on r_{j+1}),  ε = |e|/l − 1,
    H_e = K_s [t tᵀ / l + (ε / |e|)(I − t tᵀ)],  ∂F/∂(r_j, r_{j+1}) = [[−H, H], [H, −H]].
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.kernels._scatter import add_force, add_jacobian


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, stiffness: float, rest: float, scale: float,
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
        strain = norm / rest - 1.0
        if want_force:
            for a in range(3):
                tension = stiffness * strain * t[a]
                local_force[a] = tension
                local_force[3 + a] = -tension
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            ratio = strain / norm
            for a in range(3):
                for b in range(3):
                    tt = t[a] * t[b]
                    h = stiffness * (tt / rest + ratio * ((1.0 if a == b else 0.0) - tt))
                    local_jacobian[a, b] = -h
                    local_jacobian[3 + a, 3 + b] = -h
                    local_jacobian[a, 3 + b] = h
                    local_jacobian[3 + a, b] = h
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)
