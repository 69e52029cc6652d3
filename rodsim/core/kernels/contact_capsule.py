"""Contact kernel of the capsule (rodsim/core/obstacles/capsule.py): the node's nearest
point on the segment, then φ = |p − q| − R and its derivatives (the obstacle's module
docstring); the law, friction and scatter are shared (rodsim/core/kernels/_contact.py)."""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._contact import add_node, node_energy, workspace


@njit(cache=True)
def _gap(p: np.ndarray, start: np.ndarray, end: np.ndarray, capsule_radius: float,
         grad: np.ndarray, hess: np.ndarray) -> float:
    w2 = 0.0
    along = 0.0
    for i in range(3):
        w = end[i] - start[i]
        w2 += w * w
        along += (p[i] - start[i]) * w
    t = along / w2
    beside = 0.0 < t < 1.0
    t = min(max(t, 0.0), 1.0)
    e = np.empty(3)
    d = 0.0
    for i in range(3):
        e[i] = p[i] - (start[i] + t * (end[i] - start[i]))
        d += e[i] * e[i]
    d = max(np.sqrt(d), 1e-300)
    length = np.sqrt(w2)
    for i in range(3):
        e[i] /= d
    for i in range(3):
        grad[i] = e[i]
        a_i = (end[i] - start[i]) / length if beside else 0.0
        for j in range(3):
            a_j = (end[j] - start[j]) / length if beside else 0.0
            hess[i, j] = ((1.0 if i == j else 0.0) - e[i] * e[j] - a_i * a_j) / d
    return d - capsule_radius


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, start: np.ndarray, end: np.ndarray,
             capsule_radius: float, radius: float, stiffness: float, delta: float,
             friction: float, slip: float, anchors: np.ndarray, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    p, grad, hess, local, block = workspace()
    for e in range(dofs.shape[0]):
        for m in range(3):
            p[m] = x[dofs[e, m]]
        phi = _gap(p, start, end, capsule_radius, grad, hess)
        add_node(e, p, phi, grad, hess, radius, stiffness, delta, friction, slip, anchors,
                 scale, want_force, force, force_target, want_jacobian, jacobian,
                 jacobian_target, local, block)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, start: np.ndarray, end: np.ndarray,
           capsule_radius: float, radius: float, stiffness: float, delta: float,
           friction: float, slip: float, anchors: np.ndarray) -> float:
    p, grad, hess, _, _ = workspace()
    total = 0.0
    for e in range(dofs.shape[0]):
        for m in range(3):
            p[m] = x[dofs[e, m]]
        total += node_energy(_gap(p, start, end, capsule_radius, grad, hess), radius, delta)
    return stiffness * total
