"""Kernel of ``rodsim.core.terms.tendon_string_displacement`` with friction: one element, the m
coordinates of the tendon's span (rodsim/core/displacement_friction.py derives it).

The bounds' factors e^{∓μΘ_e} are the tension-controlled kernel's chord tensions at unit
tension against a stored profile of 0 (the lower) and of +∞ (the upper)
(``tendon_string_path._tensions``, which also marks the chords up to which the path turns
one way in one plane from a held entry frame); the actuator's tension T_0 is the root of
the length constraint with the chords' states (``actuator_tension``, ``chord_states``:
compiled here from their one source); each chord's force and Jacobian at its τ_e are the
frictionless chord kernel's (``rodsim.core.kernels.tendon_string``, one chord per call),
accumulated into the span through ``chord_local`` and ``chord_pairs``; on the span are
added each sliding chord's own coupling f_e ⊗ ∂τ_e/∂x|_{T_0} and the coupling through
dT_0/dx:

    ∂F/∂x += (Σ_e s_e ∇ℓ_e) ⊗ (Σ_e (w_e ∇ℓ_e − v_e ∂τ_e/∂x|_{T_0})) / (∂G/∂T_0).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core import displacement_friction
from rodsim.core.kernels import tendon_string
from rodsim.core.kernels._scatter import add_force, add_jacobian
from rodsim.core.kernels.tendon_string import _chord
from rodsim.core.kernels.tendon_string_path import _one_way_coupling, _points, _tensions

_actuator_tension = njit(cache=True)(displacement_friction.actuator_tension)
_chord_states = njit(cache=True)(displacement_friction.chord_states)


@njit(cache=True)
def _bounds(x: np.ndarray, chord_dofs: np.ndarray, weights: np.ndarray,
            constant: np.ndarray, entry_forms: np.ndarray, entry_slope: np.ndarray,
            split: np.ndarray, p: np.ndarray, friction: float, low: np.ndarray,
            high: np.ndarray, lengths: np.ndarray, one_way: np.ndarray,
            axis: np.ndarray) -> None:
    """e^{−μΘ_e}, e^{+μΘ_e}, ℓ_e and whether the path up to chord e turns one way in one
    plane from a held entry frame, of every chord, into ``low``, ``high``, ``lengths`` and
    ``one_way``; d3 at the entry into ``axis``."""
    chords = chord_dofs.shape[0]
    unused = np.empty(0)
    rate = np.zeros(chords)
    slide = np.empty(chords)
    _tensions(x, chord_dofs, weights, constant, entry_forms, entry_slope, split, p, 1.0,
              friction, np.zeros(chords), False, unused, unused, low, rate, axis, slide)
    for e in range(chords):
        one_way[e] = rate[e] != 0.0
    _tensions(x, chord_dofs, weights, constant, entry_forms, entry_slope, split, p, 1.0,
              friction, np.full(chords, np.inf), False, unused, unused, high, rate, axis,
              slide)
    for e in range(chords):
        total = 0.0
        for m in range(3):
            total += (p[e + 1, m] - p[e, m]) ** 2
        lengths[e] = np.sqrt(total)


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, chord_dofs: np.ndarray, weights: np.ndarray,
             constant: np.ndarray, forms: np.ndarray, chord_local: np.ndarray,
             chord_pairs: np.ndarray, stiffness: float, free_length: float, friction: float,
             profile: np.ndarray, pattern: np.ndarray, clamp: bool, last_tension: float,
             entry_forms: np.ndarray, entry_slope: np.ndarray, split: np.ndarray,
             scale: float, want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    m = dofs.shape[1]
    chords = chord_dofs.shape[0]
    unused = np.empty(0)
    p, jac, _, _, _, _ = _points(x, chord_dofs, weights, constant, forms)
    low = np.empty(chords)
    high = np.empty(chords)
    lengths = np.empty(chords)
    one_way = np.zeros(chords, dtype=np.bool_)
    axis = np.zeros(3)
    _bounds(x, chord_dofs, weights, constant, entry_forms, entry_slope, split, p, friction,
            low, high, lengths, one_way, axis)
    tension = _actuator_tension(lengths, low, high, profile, pattern, stiffness,
                                free_length, last_tension, clamp)
    states = np.empty(chords)
    _chord_states(tension, low, high, profile, pattern, states)
    tau = np.empty(chords)
    for e in range(chords):
        tau[e] = (tension * low[e] if states[e] < 0.0 else tension * high[e]
                  if states[e] > 0.0 else profile[e])
    local_force = np.zeros(m)
    flat = np.zeros(m * m)
    for e in range(chords):
        if tau[e] == 0.0:
            continue
        tendon_string.evaluate(x, chord_dofs[e:e + 1], weights[e:e + 2], constant[e:e + 2],
                               forms[e:e + 2], tau[e], 0.0, unused, False, unused, unused,
                               entry_forms, entry_slope, split, 1.0, want_force,
                               local_force, chord_local[e:e + 1], want_jacobian, flat,
                               chord_pairs[e:e + 1])
    if want_force:
        add_force(force, force_target, 0, local_force, scale)
    if not want_jacobian:
        return
    held = weights[0, 2] == 0.0 and weights[0, 3] == 0.0
    dg = np.zeros(m)  # ∂G/∂x
    c = np.zeros(m)  # Σ s_e ∇ℓ_e
    slope_g = 0.0
    u = np.empty(3)
    jd = np.empty((3, 28))
    slope = np.empty(3)
    gradient = np.zeros(28)
    unit_force = np.empty(28)
    for e in range(chords):
        length = _chord(p, jac, e, u, jd)
        share = 1.0 / (1.0 + tau[e] / stiffness)
        v = length * share * share / stiffness
        s = low[e] if states[e] < 0.0 else high[e] if states[e] > 0.0 else 0.0
        slope_g -= v * s
        rate = 0.0
        if held and one_way[e] and states[e] != 0.0:
            rate = friction * (-tension * low[e] if states[e] < 0.0 else tension * high[e])
        coupled = False
        if rate != 0.0:
            coupled = _one_way_coupling(jd, u, length, axis, rate, 28, slope, gradient,
                                        unit_force)
        for k in range(28):
            grad = jd[0, k] * u[0] + jd[1, k] * u[1] + jd[2, k] * u[2]
            at = chord_local[e, k]
            dg[at] += share * grad - (v * gradient[k] if coupled else 0.0)
            c[at] += s * grad
            if coupled:
                row = at * m
                f = unit_force[k]
                for j in range(28):
                    flat[row + chord_local[e, j]] += f * gradient[j]
    if slope_g != 0.0 and not (clamp and tension == 0.0):
        for a in range(m):
            factor = c[a] / slope_g
            if factor == 0.0:
                continue
            for b in range(m):
                flat[a * m + b] += factor * dg[b]
    add_jacobian(jacobian, jacobian_target, 0, flat.reshape((m, m)), scale)
