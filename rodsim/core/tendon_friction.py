"""Coulomb friction between a string tendon and its routing: the capstan law with its history
(issue 34; not in the paper; docs/tendon.md, "Friction").

The string tendon (rodsim/core/terms/tendon_string.py) runs along a polygon of routing
points p_0 (the entry, s = start) … p_{P−1} (the termination), chord e joining p_e and
p_{e+1} with direction u_e. The tendon turns by

    θ_0 = ∠(d3(start), u_0)     at the entry (it comes in from the actuator along the
                                  catheter's tangent d3 at the entry, Eq. 2),
    θ_k = ∠(u_{k−1}, u_k)       at every routing point k = 1 … P−2 (a node of a lumen, a
                                  spacer disk), computed as atan2(|a × b|, a·b),

and Θ_e = θ_0 + … + θ_e is the wrap from the actuator to chord e. At the termination the
tendon ends: no turn, no friction.

Capstan law. A tendon sliding over a curved support under Coulomb friction μ satisfies
dT/dΘ = ∓μ T (the normal load per unit length is T |dt/ds|, so dT/ds = ∓μ |f_n| is
dT = ∓μ T dΘ), whence T_after = T_before e^{∓μθ} across a turn θ: the loss of the
lumen's continuous wrap, lumped at each node, and the eyelet of a spacer disk (the tendon
wraps the hole's rounded edge). Chord e then carries τ_e = T_0 e^{−μΘ_e} while the tendon
is pulled in (sliding toward the actuator), T_0 e^{+μΘ_e} while it is let out. On a lumen
of curvature κ the chord's Θ_e is the continuum's wrap at the chord's midpoint (half a
segment's turn at the entry, a whole one at each node), so τ_e is the continuum tension
there to O(h²).

Sticking and history. While the tendon does not slide at a routing point, the tensions on
its two sides may differ by anything the friction there can hold:

    τ_{k−1} e^{−μθ_k} ≤ τ_k ≤ τ_{k−1} e^{+μθ_k}     (τ_{−1} = T_0, the actuator's tension).

The tension a chord holds is state: the profile τ_old of the last converged equilibrium (the
term's anchors, :meth:`rodsim.core.model.Model.anchored`, set by the continuation of track,
fit and reach between steps). The new profile keeps each stored tension where the friction
can hold it and slides where it cannot — the projection onto the cones, swept from the
actuator:

    τ_e = clip(τ_old_e, τ_{e−1} e^{−μθ_e}, τ_{e−1} e^{+μθ_e}),   e = 0 … P−2.

For an admissible τ_old (one inside its cones, which every profile this rule makes is on
the geometry it was made on) and a base tension raised from T_old to T_0 ≥ T_old, this is
τ_e = max(τ_old_e, T_0 e^{−μΘ_e}): ln τ_old_e + μΘ_e is non-decreasing in e (the lower
cone), so the chords where T_0 e^{−μΘ_e} exceeds τ_old_e are a prefix — the slip zone,
sliding at the capstan bound — and beyond its front the stored tensions hold and stay
admissible. Lowered, it is τ_e = min(τ_old_e, T_0 e^{+μΘ_e}) by the same argument. The
termination's tension is therefore unchanged after a reversal from T_max until
T_0 e^{μΘ} falls below T_max e^{−μΘ}: a dead zone of ratio e^{2μΘ} in the actuator's
tension (Θ the total wrap, measured on the state). A cold solve assumes the tendon was
pulled in from slack, monotonically: τ_old = 0, so τ_e = T_0 e^{−μΘ_e} everywhere.

The rule is evaluated at the current shape (the turning angles of the state being solved:
the implicit, backward quasi-static step, as contact friction's slip is, docs/contact.md).
What it leaves out: the tendon's own elasticity (a stuck chord keeps its tension while the
catheter bends under it; an elastic tendon would stretch with the path), rate effects, and
stiction above the kinetic coefficient (one μ).

These are the numpy reference's functions; the compiled kernel
(rodsim/core/kernels/tendon_string.py) evaluates the same formulas.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_FRICTION", "chord_tensions", "turning_angles"]

#: Largest friction coefficient a scene may set (tendon_string.friction's range): steel on
#: PTFE ~0.05–0.1, braided polymer on steel disks ~0.1–0.3; 2 is already a tendon that
#: barely slides.
MAX_FRICTION = 2.0


def turning_angles(entry: np.ndarray, p: np.ndarray) -> np.ndarray:
    """θ_e, e = 0 … P−2 (module docstring): the entry's turn from the unit direction
    ``entry`` (d3 at the entry) to the first chord, then the turn at each routing point
    between its two chords, for the polygon ``p`` (P, 3) [rad]."""
    d = np.diff(p, axis=0)
    u = d / np.linalg.norm(d, axis=1)[:, None]
    before = np.concatenate([entry[None, :], u[:-1]])
    cross = np.linalg.norm(np.cross(before, u), axis=1)
    return np.arctan2(cross, np.einsum("ei,ei->e", before, u))


def chord_tensions(tension: float, friction: float, theta: np.ndarray,
                   profile: np.ndarray) -> np.ndarray:
    """τ_e of every chord [N] from the actuator's tension T_0 = ``tension``, μ =
    ``friction``, the turning angles ``theta`` and the stored profile τ_old = ``profile``
    (module docstring: the cone projection swept from the actuator)."""
    out = np.empty(len(theta))
    before = float(tension)
    for e in range(len(theta)):
        ratio = np.exp(friction * theta[e])
        before = min(max(float(profile[e]), before / ratio), before * ratio)
        out[e] = before
    return out
