"""Friction on a string tendon under displacement control: the actuator's tension as the root
of the tendon's length constraint with the capstan profile (issue 34 item 2; not in the
paper; docs/tendon.md, "Friction under displacement control").

A motor that has wound the tendon in by d leaves ℓ* = ℓ₀ − d of its free (unstretched)
length between the entry and the termination (rodsim/core/terms/tendon_string_displacement.py).
Chord e of the path, of length ℓ_e(x), carries τ_e and holds the free length
ℓ_e / (1 + τ_e / E A) of tendon (a linear spring per unit free length, the frictionless
term's law: with one tension T, ℓ / (1 + T / E A) = ℓ* is T = (E A / ℓ*)(ℓ − ℓ*)). With
friction the chords' tensions are the capstan profile of the tension-controlled string
(rodsim/core/tendon_friction.py) at an actuator tension T_0 that is not given:

    τ_e(T_0) = clip(τ_old_e, T_0 e^{−μΘ_e}, T_0 e^{+μΘ_e}),
    G(T_0) = Σ_e ℓ_e / (1 + τ_e(T_0) / E A) − ℓ* = 0.

Each τ_e is non-decreasing in T_0, so G is continuous and non-increasing: its root is
unique where some chord slides, and G(0) = ℓ − ℓ* ≤ 0 is a slack tendon (T_0 = 0, every
chord 0). Where every chord sticks over an interval of T_0 (a reversal repeating its last
value) G is flat there and the root nearest the last equilibrium's T_0 is taken: the
forces do not depend on T_0 inside such an interval.

Derivatives at the root (the Jacobian, rodsim/core/terms/tendon_string_displacement.py):
with w_e = 1 / (1 + τ_e / E A), v_e = ℓ_e w_e² / E A and s_e = ∂τ_e/∂T_0 (e^{∓μΘ_e}
sliding in/out, 0 stuck),

    ∂G/∂x = Σ_e (w_e ∇ℓ_e − v_e ∂τ_e/∂x|_{T_0}),   ∂G/∂T_0 = −Σ_e v_e s_e,
    dT_0/dx = −(∂G/∂x) / (∂G/∂T_0),

and the force F = −Σ_e τ_e ∇ℓ_e gains −(Σ_e s_e ∇ℓ_e) ⊗ dT_0/dx over the
tension-controlled Jacobian at T_0. ∂τ_e/∂x|_{T_0} is the tension-controlled string's:
exact on a path that turns one way in one plane from a held entry frame, left out
elsewhere. With μ = 0 this is the frictionless term's −(E A / ℓ*) ∇ℓ ∇ℓᵀ.

The functions here are plain Python on numpy arrays, compiled as they are by the kernel
(rodsim/core/kernels/tendon_string_displacement_friction.py): one root, both paths.
"""

from __future__ import annotations

import numpy as np

__all__ = ["EPS", "MAX_ROOT_ITERATIONS", "actuator_tension", "chord_states"]

#: The machine epsilon of float64 (a constant: the kernel compiles this module's functions).
EPS = 2.220446049250313e-16

#: Most safeguarded Newton steps of the root (each at least halves the bracket once the
#: root is bracketed; measured: 3–8 on the tests' robots).
MAX_ROOT_ITERATIONS = 200


def chord_states(tension: float, low: np.ndarray, high: np.ndarray, profile: np.ndarray,
                 pattern: np.ndarray, out: np.ndarray) -> None:
    """The state each chord takes at the actuator tension ``tension`` into ``out``: the
    frozen ``pattern`` (−1 sliding in, 0 stuck, +1 sliding out) where it is set, the clip
    rule where it is NaN (−1 where T_0 e^{−μΘ_e} > τ_old_e, +1 where T_0 e^{+μΘ_e} <
    τ_old_e, else 0)."""
    for e in range(profile.shape[0]):
        if pattern[e] == pattern[e]:
            out[e] = pattern[e]
        elif tension * low[e] > profile[e]:
            out[e] = -1.0
        elif tension * high[e] < profile[e]:
            out[e] = 1.0
        else:
            out[e] = 0.0


def actuator_tension(lengths: np.ndarray, low: np.ndarray, high: np.ndarray,
                     profile: np.ndarray, pattern: np.ndarray, stiffness: float,
                     free_length: float, last: float, clamp: bool) -> float:
    """T_0, the root of G (module docstring) nearest ``last`` (the last equilibrium's
    actuator tension); ``low``, ``high`` the bounds' factors e^{∓μΘ_e}, ``lengths`` the
    chords' ℓ_e, ``profile`` the stored τ_old_e, ``pattern`` each chord's frozen state (NaN:
    the clip rule; ``chord_states``). With ``clamp`` T_0 ≥ 0: 0 for a slack tendon
    (G(0) ≤ 0). Without, a frozen pattern's root may be negative (a tendon that pushes:
    never an accepted equilibrium, ``TendonStringDisplacement.freed``; it keeps G smooth
    through slack for Newton's iterates). ``last`` where no chord slides (G does not
    depend on T_0); else safeguarded Newton on a bracket grown from ``last`` (or from the
    frictionless tension E A (ℓ/ℓ* − 1) when ``last`` is 0), a bisection where the Newton
    step leaves the bracket, to a step of round-off. Self-contained (no calls) so that
    numba compiles it as it is."""
    chords = lengths.shape[0]
    total = 0.0
    slack = -free_length  # G(0): every chord at 0, or at τ_old where frozen stuck
    factor = 0.0  # the largest e^{±μΘ_e} of a sliding chord
    for e in range(chords):
        total += lengths[e]
        if pattern[e] == 0.0:
            slack += lengths[e] / (1.0 + profile[e] / stiffness)
        else:
            slack += lengths[e]
            factor = max(factor, high[e] if pattern[e] != -1.0 else low[e])
    if clamp and slack <= 0.0:
        return 0.0
    if factor == 0.0:
        return last
    tension = last if last != 0.0 else stiffness * (total / free_length - 1.0)
    # G → +∞ where a sliding chord's τ reaches −E A.
    lo, hi = (0.0, np.inf) if clamp else (-stiffness / factor, np.inf)
    if tension <= lo:
        tension = max(0.0, 0.5 * lo)
    for _ in range(MAX_ROOT_ITERATIONS):
        excess = -free_length  # G(T_0)
        slope = 0.0  # ∂G/∂T_0 = −Σ_e v_e s_e
        for e in range(chords):
            below, above = tension * low[e], tension * high[e]
            state = pattern[e]
            if state != state:  # the clip rule
                state = -1.0 if below > profile[e] else 1.0 if above < profile[e] else 0.0
            tau = below if state < 0.0 else above if state > 0.0 else profile[e]
            share = 1.0 / (1.0 + tau / stiffness)
            excess += lengths[e] * share
            if state != 0.0:
                slope -= lengths[e] * share * share / stiffness * (
                    low[e] if state < 0.0 else high[e])
        if excess == 0.0:
            return tension
        if excess > 0.0:
            lo = tension
        else:
            hi = tension
        step = tension - excess / slope if slope < 0.0 else np.nan
        if not (lo < step < hi):
            step = 0.5 * (lo + hi) if hi < np.inf else 2.0 * abs(tension) + EPS * stiffness
        if abs(step - tension) <= 4.0 * EPS * abs(tension):
            return step
        tension = step
    return tension
