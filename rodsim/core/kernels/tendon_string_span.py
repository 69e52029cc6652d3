"""Kernel of a string tendon whose friction coefficient varies between its routing points
(``friction_points``, ``friction_profile``, stiction: rodsim/core/terms/tendon_string.py,
"Friction"), as one element on the coordinates of its span, so that its Jacobian holds the
coupling of each chord's tension to the turns upstream of it.

Chord e carries τ_e = T e^{∓W_e}, W_e = Σ_{j≤e} μ_j θ_j (rodsim/core/tendon_friction.py;
θ_0 the entry's turn, its split part blended in continuously, 0 in the entry's plane).
On a path that turns one way in one plane from a held entry frame θ_j = ψ_j − ψ_{j−1},
ψ_j = ∠(d3, u_j) (ψ_{−1} = 0), so

    ∂W_e/∂x = μ_e ∂ψ_e/∂x + Σ_{j<e} (μ_j − μ_{j+1}) ∂ψ_j/∂x,

each ∂ψ_j/∂x on chord j's own coordinates. The chords' forces and their Jacobians with the
first term (the chord's own coupling) are ``rodsim.core.kernels.tendon_string``'s,
accumulated into the span through ``chord_local`` and ``chord_pairs`` (each chord
coordinate's position in the span, and its flattened pairs); this kernel adds the sum,
f_e ⊗ σ_e Σ_{j<e} (μ_j − μ_{j+1}) ∂ψ_j/∂x with f_e = −Jd_eᵀ u_e the chord's force per unit
tension and σ_e = ∂τ_e/∂W_e (−τ_e sliding in with μ_in, +τ_e sliding out with μ_out, 0
stuck: ``_tensions``' ``slide``), through the running sums G_e = Σ_{j<e} (μ_j − μ_{j+1})
∂ψ_j/∂x of each side (one pass, O(E m)). With one μ every difference is zero and the sum
vanishes: the chord kernel's Jacobian alone.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels import tendon_string
from rodsim.core.kernels._scatter import add_force, add_jacobian
from rodsim.core.kernels.tendon_string_path import _points, _tensions


@njit(cache=True)
def _upstream_coupling(x: np.ndarray, chord_dofs: np.ndarray, weights: np.ndarray,
                       constant: np.ndarray, forms: np.ndarray, tension: float,
                       friction: float, profile: np.ndarray, mu_in: np.ndarray,
                       mu_out: np.ndarray, entry_forms: np.ndarray, entry_slope: np.ndarray,
                       split: np.ndarray, chord_local: np.ndarray, out: np.ndarray) -> None:
    """out (m, m) += Σ_e f_e ⊗ σ_e G_e (module docstring), in span coordinates."""
    chords = chord_dofs.shape[0]
    m = out.shape[0]
    p, jac, q, n, gq, g = _points(x, chord_dofs, weights, constant, forms)
    chord_tension = np.empty(chords)
    rate = np.zeros(chords)
    axis = np.zeros(3)
    slide = np.zeros(chords)
    _tensions(x, chord_dofs, weights, constant, entry_forms, entry_slope, split, p, tension,
              friction, profile, True, mu_in, mu_out, chord_tension, rate, axis, slide)
    running_in = np.zeros(m)
    running_out = np.zeros(m)
    u = np.empty(3)
    jd = np.empty((3, 28))
    for e in range(chords):
        length = tendon_string._chord(p, jac, e, u, jd)
        cosine = axis[0] * u[0] + axis[1] * u[1] + axis[2] * u[2]
        cx = axis[1] * u[2] - axis[2] * u[1]
        cy = axis[2] * u[0] - axis[0] * u[2]
        cz = axis[0] * u[1] - axis[1] * u[0]
        sine = np.sqrt(cx * cx + cy * cy + cz * cz)
        sigma = slide[e]
        if sigma != 0.0:
            running = running_in if sigma < 0.0 else running_out
            for a in range(28):
                f = 0.0
                for k in range(3):
                    f -= jd[k, a] * u[k]
                if f == 0.0:
                    continue
                row = chord_local[e, a]
                for b in range(m):
                    out[row, b] += sigma * f * running[b]
        if e + 1 == chords or sine == 0.0:
            continue
        step_in = mu_in[e] - mu_in[e + 1]
        step_out = mu_out[e] - mu_out[e + 1]
        if step_in == 0.0 and step_out == 0.0:
            continue
        for a in range(28):
            value = 0.0
            for k in range(3):
                value -= (axis[k] - cosine * u[k]) / (sine * length) * jd[k, a]
            column = chord_local[e, a]
            running_in[column] += step_in * value
            running_out[column] += step_out * value


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, chord_dofs: np.ndarray, weights: np.ndarray,
             constant: np.ndarray, forms: np.ndarray, tension: float, friction: float,
             profile: np.ndarray, mu_in: np.ndarray, mu_out: np.ndarray,
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
        tendon_string.evaluate(x, chord_dofs, weights, constant, forms, tension, friction,
                               profile, True, mu_in, mu_out, entry_forms, entry_slope, split,
                               1.0, True, local_force, chord_local, False, unused,
                               unused_target)
        add_force(force, force_target, 0, local_force, scale)
    if want_jacobian:
        flat = np.zeros(m * m)
        unused_force_target = np.empty((0, 0), dtype=np.int64)
        tendon_string.evaluate(x, chord_dofs, weights, constant, forms, tension, friction,
                               profile, True, mu_in, mu_out, entry_forms, entry_slope, split,
                               1.0, False, unused, unused_force_target, True, flat,
                               chord_pairs)
        local_jacobian = flat.reshape((m, m))
        _upstream_coupling(x, chord_dofs, weights, constant, forms, tension, friction,
                           profile, mu_in, mu_out, entry_forms, entry_slope, split,
                           chord_local, local_jacobian)
        add_jacobian(jacobian, jacobian_target, 0, local_jacobian, scale)
