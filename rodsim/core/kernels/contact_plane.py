"""Contact kernel of the plane (rodsim/core/obstacles/plane.py): φ = n · (p − p₀),
∇φ = n, ∇²φ = 0; the law, friction and scatter are shared (rodsim/core/kernels/_contact.py).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._contact import add_node, node_energy, workspace


@njit(cache=True)
def _gap(p: np.ndarray, point: np.ndarray, normal: np.ndarray, grad: np.ndarray,
         hess: np.ndarray) -> float:
    phi = 0.0
    for i in range(3):
        phi += (p[i] - point[i]) * normal[i]
        grad[i] = normal[i]
        for j in range(3):
            hess[i, j] = 0.0
    return phi


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, point: np.ndarray, normal: np.ndarray,
             radius: float, stiffness: float, delta: float, friction: float, slip: float,
             anchors: np.ndarray, scale: float, want_force: bool,
             force: np.ndarray, force_target: np.ndarray, want_jacobian: bool,
             jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    p, grad, hess, local, block = workspace()
    for e in range(dofs.shape[0]):
        for m in range(3):
            p[m] = x[dofs[e, m]]
        phi = _gap(p, point, normal, grad, hess)
        add_node(e, p, phi, grad, hess, radius, stiffness, delta, friction, slip, anchors,
                 scale, want_force, force, force_target, want_jacobian, jacobian,
                 jacobian_target, local, block)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, point: np.ndarray, normal: np.ndarray,
           radius: float, stiffness: float, delta: float, friction: float, slip: float,
           anchors: np.ndarray) -> float:
    p, grad, hess, _, _ = workspace()
    total = 0.0
    for e in range(dofs.shape[0]):
        for m in range(3):
            p[m] = x[dofs[e, m]]
        total += node_energy(_gap(p, point, normal, grad, hess), radius, delta)
    return stiffness * total
