"""What every obstacle type's contact kernel shares (rodsim/core/kernels/contact_<type>.py):
the penalty law (compiled from its one source, rodsim/core/contact_penalty.py), a node's
normal force and Jacobian, the regularised Coulomb friction, and the node's scatter into the
model's force and Jacobian. A type's kernel only finds each node's gap φ, ∇φ and ∇²φ
(rodsim/core/terms/contact.py; docs/architecture.md, "How to add an obstacle type")."""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core import contact_penalty
from rodsim.core.kernels._scatter import add_force, add_jacobian

_onset = njit(cache=True)(contact_penalty.onset)
_linear = njit(cache=True)(contact_penalty.linear)


@njit(cache=True)
def penalty(pen: float, delta: float) -> tuple[float, float, float]:
    """ψ, ψ′, ψ″ at penetration ``pen`` (rodsim/core/contact_penalty.py)."""
    if pen <= 0.0:
        return 0.0, 0.0, 0.0
    if pen < delta:
        return _onset(pen, delta)
    return _linear(pen, delta)


@njit(cache=True)
def workspace() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A node's point p (3,), ∇φ (3,), ∇²φ (3, 3), force (3,) and Jacobian block (3, 3)."""
    return np.empty(3), np.empty(3), np.empty((3, 3)), np.empty(3), np.empty((3, 3))


@njit(cache=True)
def node_energy(phi: float, radius: float, delta: float) -> float:
    """ψ(r − φ) of one node (the kernel multiplies the sum by k)."""
    return penalty(radius - phi, delta)[0]


@njit(cache=True)
def add_node(e: int, p: np.ndarray, phi: float, grad: np.ndarray, hess: np.ndarray,
             radius: float, stiffness: float, delta: float, friction: float, slip: float,
             anchors: np.ndarray, scale: float, want_force: bool, force: np.ndarray,
             force_target: np.ndarray, want_jacobian: bool, jacobian: np.ndarray,
             jacobian_target: np.ndarray, local: np.ndarray, block: np.ndarray) -> None:
    """Node ``e`` at ``p`` with gap ``phi``, ``grad``, ``hess``: F = k ψ′ ∇φ and
    ∂F/∂r = k (ψ′ ∇²φ − ψ″ ∇φ ∇φᵀ), plus friction when μ > 0, times ``scale`` into the
    model's outputs (nothing where the node does not touch)."""
    pen = radius - phi
    if pen <= 0.0:
        return
    _, d1, d2 = penalty(pen, delta)
    for i in range(3):
        local[i] = stiffness * d1 * grad[i]
    if want_jacobian:
        for i in range(3):
            for j in range(3):
                block[i, j] = stiffness * (d1 * hess[i, j] - d2 * grad[i] * grad[j])
    if friction > 0.0:  # skipped without friction: the frictionless numbers, bitwise
        _friction(p, anchors[e], grad, hess, d1, d2, stiffness, friction, slip, local,
                  block, want_jacobian)
    if want_force:
        add_force(force, force_target, e, local, scale)
    if want_jacobian:
        add_jacobian(jacobian, jacobian_target, e, block, scale)


@njit(cache=True)
def _friction(p: np.ndarray, anchor: np.ndarray, grad: np.ndarray, hess: np.ndarray,
              d1: float, d2: float, stiffness: float, friction: float, slip: float,
              local: np.ndarray, block: np.ndarray, want_jacobian: bool) -> None:
    """Add the regularised Coulomb friction force −μ |f_n| v/√(|v|² + ε²) to ``local`` and
    its exact derivative to ``block`` (rodsim/core/terms/contact.py)."""
    size = 0.0
    for i in range(3):
        size += grad[i] * grad[i]
    size = np.sqrt(size)
    n = np.empty(3)
    d = np.empty(3)
    along = 0.0
    for i in range(3):
        n[i] = grad[i] / size
        d[i] = p[i] - anchor[i]
        along += n[i] * d[i]
    v = np.empty(3)
    v2 = 0.0
    for i in range(3):
        v[i] = d[i] - along * n[i]
        v2 += v[i] * v[i]
    q = np.sqrt(v2 + slip * slip)
    normal_force = stiffness * d1 * size
    for i in range(3):
        local[i] -= friction * normal_force * v[i] / q
    if not want_jacobian:
        return
    # ∂n/∂r = P H / |∇φ|, P = I − n nᵀ
    hn = np.empty(3)
    for i in range(3):
        hn[i] = 0.0
        for j in range(3):
            hn[i] += hess[i, j] * n[j]
    dn = np.empty((3, 3))
    for i in range(3):
        for k in range(3):
            dn[i, k] = (hess[i, k] - n[i] * hn[k]) / size
    ddn = np.empty(3)  # dᵀ ∂n/∂r
    for k in range(3):
        ddn[k] = 0.0
        for j in range(3):
            ddn[k] += d[j] * dn[j, k]
    dfn = np.empty(3)  # ∂|f_n|/∂r
    for k in range(3):
        dfn[k] = stiffness * (-d2 * size * size * n[k] + d1 * hn[k])
    dv = np.empty((3, 3))
    for i in range(3):
        for k in range(3):
            dv[i, k] = ((1.0 if i == k else 0.0) - n[i] * n[k] - along * dn[i, k]
                        - n[i] * ddn[k])
    for i in range(3):
        for k in range(3):
            gdv = 0.0
            for j in range(3):
                gdv += ((1.0 if i == j else 0.0) - v[i] * v[j] / (q * q)) * dv[j, k]
            block[i, k] -= friction * (v[i] / q * dfn[k] + normal_force * gdv / q)


