"""Kernel of ``rodsim.core.terms.stretch``, Eq. (6), on the offset state: per segment
(r_j, r_{j+1}) the energy ½ K_s l (|e|/l − 1)² is a spring of stiffness k = K_s / l whose
stretch |e| − l is formed as |e| − |E| from the displacements without cancellation
(``rodsim.core.kernels._spring.offset_edge``, E the rest edge): F = k (|e| − |E|) ê on
r_j, minus on r_{j+1}; H = k [ê êᵀ + ((|e| − |E|) / |e|)(I − ê êᵀ)],
∂F/∂(r_j, r_{j+1}) = [[−H, H], [H, −H]].
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._spring import add_spring, offset_edge


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
        add_spring(k, stretch, norm, t, e, scale, want_force, force, force_target,
                   want_jacobian, jacobian, jacobian_target, local_force, local_jacobian)


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
