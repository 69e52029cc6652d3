"""Kernel of ``rodsim.core.terms.tendon_string_displacement``: one element, the m
coordinates of the tendon's span. The chords' lengths, gradients and Hessians are
``rodsim.core.kernels.tendon_string``'s, accumulated into the span through
``chord_local`` (each chord coordinate's position in the span) and ``chord_pairs`` (its
flattened pairs); with ℓ = Σ chords, T = k max(0, ℓ − ℓ*) (k = E A / ℓ*):

    F = −T ∇ℓ,   ∂F/∂x = −T ∇²ℓ − k ∇ℓ ∇ℓᵀ (taut),   V = ½ k max(0, ℓ − ℓ*)².
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels import tendon_string
from rodsim.core.kernels._scatter import add_force, add_jacobian


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, chord_dofs: np.ndarray, weights: np.ndarray,
             constant: np.ndarray, forms: np.ndarray, chord_local: np.ndarray,
             chord_pairs: np.ndarray, spring: float, free_length: float, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    m = dofs.shape[1]
    unused = np.empty(0)
    unused_target = np.empty((0, 0, 0), dtype=np.int64)
    entry_forms = np.zeros((3, 3, 4, 4))  # read only with friction, which this tendon has not
    slope = np.zeros(2)
    split = np.zeros(0, dtype=np.bool_)
    minus_gradient = np.zeros(m)  # −∇ℓ
    tendon_string.evaluate(x, chord_dofs, weights, constant, forms, 1.0, 0.0, unused,
                           False, unused, unused,
                           entry_forms, slope, split, 1.0, True, minus_gradient, chord_local,
                           False,
                           unused, unused_target)
    length = tendon_string.energy(x, chord_dofs, weights, constant, forms, 1.0, 0.0, unused,
                                  False, unused, unused, entry_forms, slope, split)
    stretch = length - free_length
    tension = spring * stretch if stretch > 0.0 else 0.0
    if want_force:
        local_force = np.empty(m)
        for a in range(m):
            local_force[a] = tension * minus_gradient[a]
        add_force(force, force_target, 0, local_force, scale)
    if want_jacobian:
        flat = np.zeros(m * m)
        unused_force_target = np.empty((0, 0), dtype=np.int64)
        tendon_string.evaluate(x, chord_dofs, weights, constant, forms, tension, 0.0, unused,
                               False, unused, unused, entry_forms, slope, split, 1.0, False,
                               unused, unused_force_target,
                               True, flat, chord_pairs)
        local_jacobian = flat.reshape((m, m))
        if stretch > 0.0:
            for a in range(m):
                for b in range(m):
                    local_jacobian[a, b] -= spring * minus_gradient[a] * minus_gradient[b]
        add_jacobian(jacobian, jacobian_target, 0, local_jacobian, scale)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, chord_dofs: np.ndarray, weights: np.ndarray,
           constant: np.ndarray, forms: np.ndarray, chord_local: np.ndarray,
           chord_pairs: np.ndarray, spring: float, free_length: float) -> float:
    """½ k max(0, ℓ − ℓ*)²."""
    length = tendon_string.energy(x, chord_dofs, weights, constant, forms, 1.0, 0.0,
                                  np.empty(0), False, np.empty(0), np.empty(0),
                                  np.zeros((3, 3, 4, 4)), np.zeros(2),
                                  np.zeros(0, dtype=np.bool_))
    stretch = length - free_length
    return 0.5 * spring * stretch * stretch if stretch > 0.0 else 0.0
