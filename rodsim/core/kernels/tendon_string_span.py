"""Kernel of a string tendon with friction as one element on the coordinates of its span
(rodsim/core/terms/tendon_string.py, "Friction"; rodsim/core/terms/_string_span.py), so
that its Jacobian holds the coupling of each chord's tension to every turn up to it.

Chord e carries τ_e = clip(τ_old_e, T e^{−W_in,e}, T e^{+W_out,e}), W_e = Σ_{j≤e} μ_j θ_j
(rodsim/core/tendon_friction.py; one μ: μ_j = μ). Where it slides,

    ∂τ_e/∂x = σ_e Σ_{j≤e} μ_j ∂θ_j/∂x,   σ_e = ∂τ_e/∂W_e = −τ_e (in), +τ_e (out),

and 0 where it sticks; θ_j is the turn at point j in 3-D, as ``turning_angles`` makes it
(the entry's blended split turn, the split points), its gradient by the unit vectors it is
made of (rodsim/core/turn_gradient.py, compiled in rodsim/core/kernels/tendon_string_turns.py)
passed to x through ∂u_i/∂x = (I − u_i u_iᵀ) Jd_i / |d_i| and the entry's frame. The chords'
forces and their Jacobians at frozen tension are ``rodsim.core.kernels.tendon_string``'s,
accumulated into the span through ``chord_local`` and ``chord_pairs`` (each chord
coordinate's position in the span, and its flattened pairs); this kernel adds
Σ_e f_e ⊗ ∂τ_e/∂x, f_e = −Jd_eᵀ u_e the chord's force per unit tension, through the running
sums Σ_{j≤e} μ_j ∂θ_j/∂x of each side (one pass, O(E m)).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels import tendon_string
from rodsim.core.kernels._scatter import add_force, add_jacobian
from rodsim.core.kernels.tendon_string_path import _points, _tensions
from rodsim.core.kernels.tendon_string_turns import entry_frame, turn_coupling, turn_gradients


@njit(cache=True)
def _coupling(x: np.ndarray, chord_dofs: np.ndarray, weights: np.ndarray,
              constant: np.ndarray, forms: np.ndarray, tension: float, friction: float,
              profile: np.ndarray, weighted: bool, mu_in: np.ndarray, mu_out: np.ndarray,
              entry_forms: np.ndarray, entry_slope: np.ndarray, split: np.ndarray,
              chord_local: np.ndarray, out: np.ndarray) -> None:
    """out (m, m) += Σ_e f_e ⊗ ∂τ_e/∂x (module docstring), in span coordinates."""
    chords = chord_dofs.shape[0]
    p, jac, q, n, gq, g = _points(x, chord_dofs, weights, constant, forms)
    chord_tension = np.empty(chords)
    rate = np.zeros(chords)
    axis = np.zeros(3)
    slide = np.zeros(chords)
    _tensions(x, chord_dofs, weights, constant, entry_forms, entry_slope, split, p, tension,
              friction, profile, weighted, mu_in, mu_out, chord_tension, rate, axis, slide)
    u = np.empty((chords, 3))
    jd = np.empty((chords, 3, 28))
    length = np.empty(chords)
    for e in range(chords):
        length[e] = tendon_string._chord(p, jac, e, u[e], jd[e])
    tangent = np.empty(3)
    entry_jacobian = np.empty((2, 3, 28))
    entry_frame(x, chord_dofs, weights, constant, entry_forms, entry_slope, axis, tangent,
                entry_jacobian)
    near, entry = turn_gradients(axis, tangent, u, split)
    turn_coupling(slide, mu_in, mu_out, near, entry, u, jd, length, entry_jacobian,
                  chord_local, out)


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, chord_dofs: np.ndarray, weights: np.ndarray,
             constant: np.ndarray, forms: np.ndarray, tension: float, friction: float,
             profile: np.ndarray, weighted: bool, mu_in: np.ndarray, mu_out: np.ndarray,
             entry_forms: np.ndarray, entry_slope: np.ndarray, split: np.ndarray,
             chord_local: np.ndarray, chord_pairs: np.ndarray, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    """F and ∂F/∂x of the span element (module docstring)."""
    if tension == 0.0:
        return
    m = dofs.shape[1]
    unused = np.empty(0)
    unused_target = np.empty((0, 0, 0), dtype=np.int64)
    if want_force:
        local_force = np.zeros(m)
        tendon_string._evaluate_tendon(x, chord_dofs, weights, constant, forms, tension,
                                       friction, profile, weighted, mu_in, mu_out,
                                       entry_forms, entry_slope, split, 1.0, True,
                                       local_force, chord_local, False, unused,
                                       unused_target, False)
        add_force(force, force_target, 0, local_force, scale)
    if want_jacobian:
        flat = np.zeros(m * m)
        unused_force_target = np.empty((0, 0), dtype=np.int64)
        tendon_string._evaluate_tendon(x, chord_dofs, weights, constant, forms, tension,
                                       friction, profile, weighted, mu_in, mu_out,
                                       entry_forms, entry_slope, split, 1.0, False, unused,
                                       unused_force_target, True, flat, chord_pairs, False)
        local_jacobian = flat.reshape((m, m))
        _coupling(x, chord_dofs, weights, constant, forms, tension, friction, profile,
                  weighted, mu_in, mu_out, entry_forms, entry_slope, split, chord_local,
                  local_jacobian)
        add_jacobian(jacobian, jacobian_target, 0, local_jacobian, scale)
