"""Coulomb friction between a string tendon and its routing: the capstan law with its history
(issue 34; not in the paper; docs/tendon.md, "Friction").

The string tendon (rodsim/core/terms/tendon_string.py) runs along a polygon of routing
points p_0 (the entry, s = start) … p_{P−1} (the termination), chord e joining p_e and
p_{e+1} with direction u_e. The tendon comes in from the actuator along the catheter's axis
d3 at the entry (Eq. 2), and turns by

    θ_0 = ∠(d3, t_in) + ∠(t_in, u_0)   at the entry: t_in ∝ d3 + ρ′_y d1 + ρ′_z d2 is the
                                         path's tangent there (ρ′ the routing's slope,
                                         rodsim/core/routing.py; t_in = d3 for a constant
                                         offset), then on along the path to the first chord,
    θ_k = ∠(u_{k−1}, u_k)               at every routing point k = 1 … P−2 (a node of a
                                         lumen, a spacer disk),

each angle computed as atan2(|a × b|, a·b); Θ_e = θ_0 + … + θ_e is the wrap from the
actuator to chord e. At the termination the tendon ends: no turn, no friction.

Capstan law. A tendon sliding over a curved support under Coulomb friction μ satisfies
dT/dΘ = ∓μ T (the normal load per unit length is T |dt/ds|, so dT/ds = ∓μ |f_n| is
dT = ∓μ T dΘ), whence T_after = T_before e^{∓μθ} across a turn θ: the loss of the
lumen's continuous wrap, lumped at each node, and the eyelet of a spacer disk (the tendon
wraps the hole's rounded edge). Chord e then carries τ_e = T_0 e^{−μΘ_e} while the tendon
is pulled in (sliding toward the actuator), T_0 e^{+μΘ_e} while it is let out. On a path of
curvature κ the chord's Θ_e is the continuum's wrap at the chord's midpoint (the entry's
abrupt turn plus half a segment's wrap at the entry, a whole one at each node), so τ_e is
the continuum tension there to O(h²) (tests/test_tendon_friction.py: order 2 on a helix).

Sticking and history. Where the tendon does not slide, the tension may differ across a
routing point by anything its friction holds: τ_{k−1} e^{−μθ_k} ≤ τ_k ≤ τ_{k−1} e^{+μθ_k}
(τ_{−1} = T_0). The tension a chord holds is state: the profile τ_old of the last converged
equilibrium (the term's anchors, :meth:`rodsim.core.model.Model.anchored`, set by the
continuation of track, fit and reach between steps), and

    τ_e = clip(τ_old_e, T_0 e^{−μΘ_e}, T_0 e^{+μΘ_e}).

Why: let τ_old be admissible (inside its cones; every profile this rule makes is, on the
shape it was made on) and the actuator's tension go from T_old to T_0 ≥ T_old. The upper
bound is inactive (τ_old_e ≤ T_old e^{μΘ_e} ≤ T_0 e^{μΘ_e}), so τ_e = max(τ_old_e,
T_0 e^{−μΘ_e}); and ln τ_old_e + μΘ_e is non-decreasing in e (the lower cone), so the
chords where T_0 e^{−μΘ_e} exceeds τ_old_e are a prefix — the slip zone, sliding in at the
capstan bound — and beyond its front the stored tensions hold, admissible across the front.
Lowered, τ_e = min(τ_old_e, T_0 e^{+μΘ_e}) the same way: the tendon slides out from the
base. The termination's tension therefore holds after a reversal from T_max until
T_0 e^{μΘ} falls below T_max e^{−μΘ}: a dead zone of ratio e^{2μΘ} in the actuator's
tension on a rigid path (Θ the total wrap, measured on the state); on a catheter the
tendon bends, Θ itself moves with the tension and the ratio is e^{μ(Θ_pull + Θ_release)}.
A cold solve assumes the tendon was pulled in from slack, monotonically: τ_old = 0, so
τ_e = T_0 e^{−μΘ_e} everywhere.

The rule is evaluated at the current shape (the turning angles of the state being solved:
the implicit, backward quasi-static step, as contact friction's slip is, docs/contact.md).
What it leaves out: the tendon's own elasticity (a stuck chord keeps its tension while the
catheter bends under it; an elastic tendon would stretch with the path, and a stuck zone
whose turns change is not re-checked against its own cones, only against the actuator's
bounds), rate effects, and stiction above the kinetic coefficient (one μ).

These are the numpy reference's functions; the compiled kernel
(rodsim/core/kernels/tendon_string.py) evaluates the same formulas.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_FRICTION", "ONE_WAY", "chord_tensions", "slide_rates", "turning_angles"]

#: |Θ_e − ψ_e| below which (relative to max(1, Θ_e)) the path up to chord e turns one way
#: in one plane (Θ_e = ψ_e = ∠(d3, u_e)): round-off of the sum of turns.
ONE_WAY = 1e-10

#: Largest friction coefficient a scene may set (tendon_string.friction's range): steel on
#: PTFE ~0.05–0.1, braided polymer on steel disks ~0.1–0.3; 2 is already a tendon that
#: barely slides.
MAX_FRICTION = 2.0


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """∠(a, b) row by row for unit vectors, as atan2(|a × b|, a·b) [rad]."""
    ax, ay, az = np.moveaxis(a, -1, 0)
    bx, by, bz = np.moveaxis(b, -1, 0)
    cross = np.sqrt((ay * bz - az * by) ** 2 + (az * bx - ax * bz) ** 2
                    + (ax * by - ay * bx) ** 2)
    return np.arctan2(cross, ax * bx + ay * by + az * bz)


def turning_angles(axis: np.ndarray, tangent: np.ndarray, p: np.ndarray) -> np.ndarray:
    """θ_e, e = 0 … P−2 (module docstring), of the polygon ``p`` (P, 3): the entry's turn
    from the catheter's axis d3 (``axis``) to the path's tangent t_in there (``tangent``)
    and on to the first chord, then the turn at each routing point between its two chords
    [rad]."""
    d = np.diff(p, axis=0)
    u = d / np.linalg.norm(d, axis=1)[:, None]
    theta = _angle(np.concatenate([tangent[None, :], u[:-1]]), u)
    theta[0] += float(_angle(axis, tangent))
    return theta


def slide_rates(tension: float, friction: float, theta: np.ndarray, profile: np.ndarray
                ) -> np.ndarray:
    """∂τ_e/∂Θ_e of every chord: −μ τ_e where the tendon slides in (the lower bound
    holds), +μ τ_e where it slides out (the upper), 0 where it sticks."""
    wrap = np.cumsum(theta)
    low = tension * np.exp(-friction * wrap)
    high = tension * np.exp(friction * wrap)
    return np.where(low > profile, -friction * low,
                    np.where(high < profile, friction * high, 0.0))


def chord_tensions(tension: float, friction: float, theta: np.ndarray,
                   profile: np.ndarray) -> np.ndarray:
    """τ_e of every chord [N] from the actuator's tension T_0 = ``tension``, μ =
    ``friction``, the turning angles ``theta`` and the stored profile τ_old = ``profile``:
    clip(τ_old_e, T_0 e^{−μΘ_e}, T_0 e^{+μΘ_e}), Θ_e = θ_0 + … + θ_e (module docstring)."""
    wrap = np.cumsum(theta)
    return np.minimum(np.maximum(profile, tension * np.exp(-friction * wrap)),
                      tension * np.exp(friction * wrap))
