"""Contact kernel of the sphere (rodsim/core/obstacles/sphere.py): φ = |p − c| − R,
∇φ = e, ∇²φ = (I − e eᵀ)/|p − c|; the law, friction and scatter are shared
(rodsim/core/kernels/_contact.py)."""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._contact import add_node, node_energy, workspace


@njit(cache=True)
def ball_gap(p: np.ndarray, center: np.ndarray, ball_radius: float, grad: np.ndarray,
             hess: np.ndarray) -> float:
    """φ of a ball of radius ``ball_radius`` around ``center``; ∇φ into grad, ∇²φ into hess
    (the capsule's ends use it too)."""
    e = np.empty(3)
    d = 0.0
    for i in range(3):
        e[i] = p[i] - center[i]
        d += e[i] * e[i]
    d = max(np.sqrt(d), 1e-300)
    for i in range(3):
        e[i] /= d
    for i in range(3):
        grad[i] = e[i]
        for j in range(3):
            hess[i, j] = ((1.0 if i == j else 0.0) - e[i] * e[j]) / d
    return d - ball_radius


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, center: np.ndarray, sphere_radius: float,
             radius: float, stiffness: float, delta: float, friction: float, slip: float,
             anchors: np.ndarray, scale: float, want_force: bool,
             force: np.ndarray, force_target: np.ndarray, want_jacobian: bool,
             jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    p, grad, hess, local, block = workspace()
    for e in range(dofs.shape[0]):
        for m in range(3):
            p[m] = x[dofs[e, m]]
        phi = ball_gap(p, center, sphere_radius, grad, hess)
        add_node(e, p, phi, grad, hess, radius, stiffness, delta, friction, slip, anchors,
                 scale, want_force, force, force_target, want_jacobian, jacobian,
                 jacobian_target, local, block)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, center: np.ndarray, sphere_radius: float,
           radius: float, stiffness: float, delta: float, friction: float, slip: float,
           anchors: np.ndarray) -> float:
    p, grad, hess, _, _ = workspace()
    total = 0.0
    for e in range(dofs.shape[0]):
        for m in range(3):
            p[m] = x[dofs[e, m]]
        total += node_energy(ball_gap(p, center, sphere_radius, grad, hess), radius, delta)
    return stiffness * total
