"""A linear spring of rest length ℓ between two nodes (a, b), edge e = r_b − r_a, shared by
the stretch (Eq. 6, one k per segment: ``springs``) and endpoint-coupling (Eq. 29)
kernels:

    F = k (|e| − ℓ) ê on a, minus that on b,
    H = k [ê êᵀ + ((|e| − ℓ) / |e|)(I − ê êᵀ)],  ∂F/∂(r_a, r_b) = [[−H, H], [H, −H]].
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._scatter import add_force, add_jacobian


@njit(cache=True, inline="always")
def edge_tangent(x: np.ndarray, dofs: np.ndarray, e: int, tangent: np.ndarray) -> float:
    """|e| of element ``e``'s edge from its first node (dofs 0–2) to its second (3–5); the
    unit tangent ê goes into ``tangent``."""
    norm2 = 0.0
    for a in range(3):
        tangent[a] = x[dofs[e, 3 + a]] - x[dofs[e, a]]
        norm2 += tangent[a] * tangent[a]
    norm = np.sqrt(norm2)
    for a in range(3):
        tangent[a] /= norm
    return norm


@njit(cache=True, inline="always")
def offset_edge(u: np.ndarray, dofs: np.ndarray, e: int, rest_edges: np.ndarray,
                rest_lengths: np.ndarray, tangent: np.ndarray,
                turn: np.ndarray) -> tuple[float, float]:
    """(|e|, |e| − |E|) of element ``e``'s edge on the offset state ``u`` (its nodes'
    displacements, dofs 0–2 and 3–5, from the rest edge E = ``rest_edges[e]`` of length
    ``rest_lengths[e]``); the unit tangent goes into ``tangent`` and t − T into ``turn``,
    both changes formed from the displacements without cancellation
    (rodsim/core/terms/_segment.py, Segments.about)."""
    norm2 = 0.0
    dot = 0.0
    square = 0.0
    for a in range(3):
        delta = u[dofs[e, 3 + a]] - u[dofs[e, a]]
        edge = rest_edges[e, a] + delta
        turn[a] = delta
        tangent[a] = edge
        norm2 += edge * edge
        dot += rest_edges[e, a] * delta
        square += delta * delta
    norm = np.sqrt(norm2)
    rest = rest_lengths[e]
    change = (2.0 * dot + square) / (norm + rest)
    ratio = change / rest
    inverse = 1.0 / norm
    for a in range(3):
        tangent[a] *= inverse
        turn[a] = (turn[a] - rest_edges[e, a] * ratio) * inverse
    return norm, change


@njit(cache=True, inline="always")
def add_spring(k: float, stretch: float, norm: float, t: np.ndarray, e: int, scale: float,
               want_force: bool, force: np.ndarray, force_target: np.ndarray,
               want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray,
               local_force: np.ndarray, local_jacobian: np.ndarray) -> None:
    """Accumulate element ``e``'s spring of stiffness ``k``, stretch |e| − ℓ, length |e| and
    unit tangent ``t`` (the module docstring's F and ∂F/∂(r_a, r_b)), through the work
    arrays ``local_force`` (6,) and ``local_jacobian`` (6, 6)."""
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
def spring(x: np.ndarray, dofs: np.ndarray, stiffness: float, rest: float, scale: float,
           want_force: bool, force: np.ndarray, force_target: np.ndarray,
           want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    """Every element's spring (k = ``stiffness``, ℓ = ``rest``), accumulated as the package
    docstring describes."""
    springs(x, dofs, np.full(dofs.shape[0], stiffness), rest, scale, want_force, force,
            force_target, want_jacobian, jacobian, jacobian_target)


@njit(cache=True)
def springs(x: np.ndarray, dofs: np.ndarray, stiffness: np.ndarray, rest: float, scale: float,
            want_force: bool, force: np.ndarray, force_target: np.ndarray,
            want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    """``spring`` with one k per element, ``stiffness[e]``."""
    local_force = np.empty(6)
    local_jacobian = np.empty((6, 6))
    t = np.empty(3)
    for e in range(dofs.shape[0]):
        norm = edge_tangent(x, dofs, e, t)
        stretch = norm - rest
        k = stiffness[e]
        add_spring(k, stretch, norm, t, e, scale, want_force, force, force_target,
                   want_jacobian, jacobian, jacobian_target, local_force, local_jacobian)


@njit(cache=True)
def spring_energy(x: np.ndarray, dofs: np.ndarray, stiffness: float, rest: float) -> float:
    """Σ ½ k (|e| − ℓ)² over the elements."""
    return springs_energy(x, dofs, np.full(dofs.shape[0], stiffness), rest)


@njit(cache=True)
def springs_energy(x: np.ndarray, dofs: np.ndarray, stiffness: np.ndarray,
                   rest: float) -> float:
    """Σ ½ k_e (|e| − ℓ)² over the elements."""
    t = np.empty(3)
    total = 0.0
    for e in range(dofs.shape[0]):
        stretch = edge_tangent(x, dofs, e, t) - rest
        total += 0.5 * stiffness[e] * stretch * stretch
    return total
