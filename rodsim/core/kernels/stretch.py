"""Kernel of :mod:`rodsim.core.terms.stretch`, Eq. (6), on the offset state: per segment
(r_j, r_{j+1}) the energy ½ K_s l (|e|/l − 1)² is a spring of stiffness k = K_s / l whose
stretch |e| − l is formed as |e| − |E| from the displacements without cancellation
(:func:`rodsim.core.kernels._spring.offset_edge`, E the rest edge): F = k (|e| − |E|) ê on
r_j, minus on r_{j+1}; H = k [ê êᵀ + ((|e| − |E|) / |e|)(I − ê êᵀ)],
∂F/∂(r_j, r_{j+1}) = [[−H, H], [H, −H]].
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._scatter import add_force, add_jacobian
from rodsim.core.kernels._spring import offset_edge


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, stiffness: np.ndarray, rest: float,
             rest_edges: np.ndarray, rest_lengths: np.ndarray, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    local_force = np.empty(6)
    local_jacobian = np.empty((6, 6))
    t = np.empty(3)
    turn = np.empty(3)
    for e in range(dofs.shape[0]):
        norm, stretch = offset_edge(x, dofs, e, rest_edges, rest_lengths, t, turn)
        k = stiffness[e] / rest
        if want_force:
            for a in range(3):
                pull = k * stretch * t[a]
                local_force[a] = pull
                local_force[3 + a] = -pull
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            ratio = stretch / norm
            for a in range(3):
                for b in range(3):
                    tt = t[a] * t[b]
                    h = k * (tt + ratio * ((1.0 if a == b else 0.0) - tt))
                    local_jacobian[a, b] = -h
                    local_jacobian[3 + a, 3 + b] = -h
                    local_jacobian[a, 3 + b] = h
                    local_jacobian[3 + a, b] = h
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, stiffness: np.ndarray, rest: float,
           rest_edges: np.ndarray, rest_lengths: np.ndarray) -> float:
    """Σ ½ K_s l ε² = Σ ½ (K_s / l)(|e| − |E|)²."""
    t = np.empty(3)
    turn = np.empty(3)
    total = 0.0
    for e in range(dofs.shape[0]):
        stretch = offset_edge(x, dofs, e, rest_edges, rest_lengths, t, turn)[1]
        total += 0.5 * (stiffness[e] / rest) * stretch * stretch
    return total
