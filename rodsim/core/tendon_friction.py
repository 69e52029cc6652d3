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

Split turns. One node's angle ∠(u_{k−1}, u_k) lumps half a chord's wrap on each side of
point k and any kink there; where the wrap turns back at k (an S-shape: a curvature of the
other sign past k), or a kink leaves the wrap's plane, that angle misses O(h) of the
continuum's ∫|dt/ds| ds, a first-order error downstream. There the turn runs through
tangents extrapolated from the chords on each side, which do not straddle k:

- the entry (``split`` given): d3 → t_in → t⁺ → u_0 with t⁺ = (3u_0 − u_1)/2 normalised
  (the tangent at p_0 extrapolated from the chords' midpoints), where the kink t_in → t⁺ is
  the path's own and leaves the plane of t_in and u_0; the plain angle where the kink is an
  extrapolation's error, or lies in that plane (there a path turning one way keeps
  Θ_e = ψ_e, whose gradient the Jacobian takes); between them, continuously,

      θ_0 = ∠(d3, t_in) + ∠(t_in, u_0) + w [∠(t_in, t⁺) + ∠(t⁺, u_0) − ∠(t_in, u_0)],
      w = S(r; KINK_PLAIN, KINK_SPLIT) · S(q; 0, KINK_LATERAL)   (``kink_weight``):

  r = ∠(t_in, t⁺)/∠(t⁺, u_0) the kink over the extrapolation's step (O(h) for the error of
  extrapolating a smooth path, O(1/h) for a kink of the path's own: the shear, the offset's
  u × ρ), q = sin δ / sin ∠(t_in, t⁺) the kink's share out of the plane (δ the angle of t⁺
  off it), S(v; lo, hi) the C¹ step 3z² − 2z³ of z = (v − lo)/(hi − lo) clipped to [0, 1].
  In the plane the plain angle stays whatever the kink, as it did: a step of the state in
  the plane makes kinks of any ratio there (r up to 0.1 at 1e-6 L on the seeded robots of
  the tests), and an extrapolation's error where the curvature vanishes at the entry is
  O(1) of the step too.
  θ_0 is continuous in the state, and C¹ but where t⁺ meets u_0 (u_0 = u_1) or t_in meets
  u_0 (the turning angles' own kinks at a straight path; there the plane is undefined and w
  is 0). Inside t_in → u_0's arc the two paths have the same length (and the same gradient),
  so only a kink that overshoots it, or leaves its plane, counts. It switched on
  |t_in · (t⁺ × u_0)| ≤ 1e-10 before: discontinuous by twice the overshoot where t⁺ lies
  behind t_in in the plane (a released catheter bending more at node 1 than twice the
  entry's turn), which an out-of-plane step of 1e-9 L crossed;
- a marked point k (where another string tendon on the catheter starts or ends: the
  catheter's curvature jumps there, rodsim/core/terms/tendon_string.py): the turns at
  k − 1, k, k + 1 become u_{k−2} → a₁ (at k − 1), a₁ → a → b → b₁ (at k), b₁ → u_{k+1}
  (at k + 1), with a₁, a = u_{k−2} + (1, 3/2)(u_{k−2} − u_{k−3}) and b₁, b = u_{k+1} +
  (1, 3/2)(u_{k+1} − u_{k+2}) normalised: the tangents at the chords' midpoints next to k
  and at k, carried from two chords away. The chords next to k are left out because the
  discrete catheter's shape there carries an O(h) share of the jump (its sum of signed
  turns is right, the sum of their magnitudes is not); extrapolating from one chord away
  left the S-shape first order (measured, docs/tendon.md).

Sticking and history. Where the tendon does not slide, the tension may differ across a
routing point by anything its friction holds: τ_{k−1} e^{−μθ_k} ≤ τ_k ≤ τ_{k−1} e^{+μθ_k}
(τ_{−1} = T_0). The tension a chord holds is state: the profile τ_old of the last converged
equilibrium (the term's anchors, ``rodsim.core.model.Model.anchored``, set by the
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
bounds), rate effects, and elastic stick–slip.

Per-point coefficients and stiction (``friction_points``, ``static_friction``;
docs/tendon.md). With a μ_j per turn the wrap in each bound is W_e = Σ_{j≤e} μ_j θ_j (the
derivation above holds with μΘ_e replaced by W_e: the capstan ratio across point j is
e^{±μ_j θ_j}). With a static μ_s above the kinetic μ_k, each point carries a stick/slip state
from the last equilibrium (−1 sliding in, 0 stuck, +1 sliding out) and its bound toward
each side takes μ_k if it slid that way, μ_s otherwise (``bound_coefficients``): a point
that stuck, or reverses, holds until the tension ratio over it exceeds e^{μ_s θ}. A point
that broke loose in a step slides at μ_k at once: the step is solved again with it
(``TendonString.freed``, ``Model.freed``) until none breaks, so released from a pulled
profile point e breaks iff T_1 < T_max e^{−2μ_kΘ_e − (μ_s−μ_k)θ_e} whatever the steps. The
state at an equilibrium is read off the chords (``slip_states``). μ_s = μ_k and one μ
keep the functions above: the same numbers bitwise.

When in a step of physical time a point breaks loose (``breakaway_margins``): each point's
margin g_e to the bound it would break loose toward, relative to the tension there, is
positive while it holds and ≤ 0 exactly where ``slip_states`` reads it as broken loose (on a
bound other than the side it slid to); a run locates the root of g in the step and splits
the step there (rodsim/solvers/physical/breakaway.py).

A μ per arc length (``friction_profile``; docs/tendon.md). The user's μ(s) is a function
of the catheter's arc length, piecewise linear, and the continuum's wrap is
W(s) = ∫ μ(s′) |κ(s′)| ds′ along the path (capstan: T_out = T_in e^{−W}). The turn θ_j at
point j lumps the path's wrap between the neighbouring chords' midpoints m_{j−1}, m_j,
so point j takes the mean of μ over [m_{j−1}, m_j]: Σ_j μ̄_j θ_j differs from ∫ μ |κ| ds by
O(h²) per unit length for a smooth κ (the covariance of μ and κ over a cell is O(h³)),
also where μ has a kink or a jump inside a cell. The entry's turn is mostly the abrupt one
at s_0 (from the axis to the path's tangent) and takes μ(s_0); its half chord of wrap then
carries an O(h) error in μ over O(h) of wrap: O(h²). So the discrete wrap converges to the
continuum's at second order whatever N, where a μ per routing point changes meaning with N.

These are the numpy reference's functions; the compiled kernel
(rodsim/core/kernels/tendon_string.py) evaluates the same formulas.
"""

from __future__ import annotations

import numpy as np

__all__ = ["KINK_LATERAL", "KINK_PLAIN", "KINK_SPLIT", "MAX_FRICTION", "ONE_WAY", "SLIP_NAMES",
           "SLIP_TIE", "bound_coefficients", "breakaway_margins", "chord_tensions",
           "kink_weight", "profile_coefficients", "slide_rates", "slip_states",
           "turning_angles",
           "weighted_chord_tensions", "weighted_slide_factors", "weighted_slide_rates"]

#: |Θ_e − ψ_e| below which (relative to max(1, Θ_e)) the path up to chord e turns one way
#: in one plane (Θ_e = ψ_e = ∠(d3, u_e)): round-off of the sum of turns.
ONE_WAY = 1e-10

#: The entry's kink ∠(t_in, t⁺) relative to the extrapolation's step ∠(t⁺, u_0) up to which
#: its turn is the plain angle, and from which it is the split one (``kink_weight``; module
#: docstring, "Split turns"): an extrapolation's error is O(h) of the step (measured ≤ 0.0086
#: on the pulled and released robots of the tests, N ≥ 11), a kink of the path's own O(1/h)
#: (≥ 0.021 on tdcr-two-segment's 3-D entry at N = 21, 0.24 on a helical tendon's).
KINK_PLAIN, KINK_SPLIT = 0.01, 0.02

#: The kink's share out of the plane of t_in and u_0 (sin δ / sin ∠(t_in, t⁺)) from which its
#: turn is split whole (``kink_weight``): in that plane (0) the plain angle keeps Θ_e = ψ_e on
#: a path turning one way; tdcr-two-segment's 3-D entry measured 0.013–1 (0.013–0.03 on
#: kinks up to 2.7e-3 rad behind t_in at its low tensions, 0.04–0.1 where t⁺ lies within
#: 1e-5 rad of the arc t_in → u_0, which split and plain angles agree on).
KINK_LATERAL = 0.01


#: Largest friction coefficient a scene may set (tendon_string.friction's range): steel on
#: PTFE ~0.05–0.1, braided polymer on steel disks ~0.1–0.3; 2 is already a tendon that
#: barely slides.
MAX_FRICTION = 2.0

#: Relative margin within which a chord's tension counts as on its sliding bound when the
#: stick/slip state of an equilibrium is read (:func:`slip_states`): a step that repeats the
#: last value reaches the same bound up to round-off, and keeps sliding.
SLIP_TIE = 1e-12

#: Slip states of a routing point (:func:`slip_states`).
SLIDING_IN, STUCK, SLIDING_OUT = -1.0, 0.0, 1.0

#: Each slip state's name (the archives' CF ``flag_meanings``, docs/archive.md).
SLIP_NAMES = {int(SLIDING_IN): "sliding_in", int(STUCK): "stuck", int(SLIDING_OUT): "sliding_out"}


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """∠(a, b) row by row for unit vectors, as atan2(|a × b|, a·b) [rad]."""
    ax, ay, az = np.moveaxis(a, -1, 0)
    bx, by, bz = np.moveaxis(b, -1, 0)
    cross = np.sqrt((ay * bz - az * by) ** 2 + (az * bx - ax * bz) ** 2
                    + (ax * by - ay * bx) ** 2)
    return np.arctan2(cross, ax * bx + ay * by + az * bz)


def _unit(v: np.ndarray) -> np.ndarray:
    """v / |v|."""
    return v / np.linalg.norm(v)


def turning_angles(axis: np.ndarray, tangent: np.ndarray, p: np.ndarray,
                   split: np.ndarray | None = None) -> np.ndarray:
    """θ_e, e = 0 … P−2 (module docstring), of the polygon ``p`` (P, 3): the entry's turn
    from the catheter's axis d3 (``axis``) to the path's tangent t_in there (``tangent``)
    and on to the first chord, then the turn at each routing point between its two chords
    [rad]. With ``split`` (P booleans) the entry's turn, and the turn at each routing point
    k that ``split[k]`` marks, run through the one-sided tangents (module docstring, "Split
    turns"); None: every turn is the chords' plain angle."""
    d = np.diff(p, axis=0)
    u = d / np.linalg.norm(d, axis=1)[:, None]
    theta = _angle(np.concatenate([tangent[None, :], u[:-1]]), u)
    theta[0] += float(_angle(axis, tangent))
    if split is None or len(u) < 2:
        return theta
    ahead = 1.5 * u[:-1] - 0.5 * u[1:]  # t⁺ at point k from chords k, k + 1 (k = 0 … P−3)
    ahead /= np.linalg.norm(ahead, axis=1)[:, None]
    kink, step = _angle(tangent, ahead[0]), _angle(ahead[0], u[0])
    normal = np.cross(tangent, u[0])
    across = float(np.linalg.norm(normal) * np.linalg.norm(np.cross(tangent, ahead[0])))
    lateral = abs(float(ahead[0] @ normal)) / across if across > 0.0 else 0.0
    weight = kink_weight(float(kink), float(step), lateral)
    if weight == 1.0:
        theta[0] = float(_angle(axis, tangent) + kink + step)
    elif weight > 0.0:
        plain = _angle(tangent, u[0])
        theta[0] = float(_angle(axis, tangent) + (plain + weight * (kink + step - plain)))
    for k in np.flatnonzero(split[3:len(u) - 2]) + 3:
        # Across routing point k the turns at k − 1, k, k + 1 are taken from the tangents
        # extrapolated from the chords beyond (k − 3, k − 2 and k + 1, k + 2) to the chords'
        # midpoints next to k and to k itself (module docstring, "Split turns").
        before, after = u[k - 2] - u[k - 3], u[k + 1] - u[k + 2]
        a1, a = _unit(u[k - 2] + before), _unit(u[k - 2] + 1.5 * before)
        b1, b = _unit(u[k + 1] + after), _unit(u[k + 1] + 1.5 * after)
        theta[k - 1] = float(_angle(u[k - 2], a1))
        theta[k] = float(_angle(a1, a) + _angle(a, b) + _angle(b, b1))
        theta[k + 1] = float(_angle(b1, u[k + 1]))
    return theta


def kink_weight(kink: float, step: float, lateral: float) -> float:
    """The share w of the entry's split turn (module docstring, "Split turns"), from the
    kink ∠(t_in, t⁺), the extrapolation's step ∠(t⁺, u_0) and the kink's share out of the
    plane of t_in and u_0, lateral = sin δ / sin ∠(t_in, t⁺) (δ the angle of t⁺ off that
    plane): w = S(r; KINK_PLAIN, KINK_SPLIT) S(lateral; 0, KINK_LATERAL) with r = kink/step
    and S(v; lo, hi) the C¹ step 3z² − 2z³ of z = (v − lo)/(hi − lo) clipped to [0, 1].
    step = 0 (u_0 = u_1, t⁺ = u_0, both turns the same) counts as r = ∞."""
    if kink <= KINK_PLAIN * step or lateral <= 0.0:
        return 0.0
    share = 1.0 if kink >= KINK_SPLIT * step else _smooth_step(
        (kink / step - KINK_PLAIN) / (KINK_SPLIT - KINK_PLAIN))
    return share if lateral >= KINK_LATERAL else share * _smooth_step(lateral / KINK_LATERAL)


def _smooth_step(z: float) -> float:
    """3z² − 2z³ on [0, 1]: 0 and 1 at the ends with zero slope (C¹)."""
    return z * z * (3.0 - 2.0 * z)


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


def _profile_integral(knots: np.ndarray, values: np.ndarray, s: np.ndarray) -> np.ndarray:
    """∫_{knots[0]}^{s} μ of the piecewise-linear μ through (``knots``, ``values``), held
    constant beyond the first and the last knot (negative for s before the first)."""
    cumulative = np.concatenate([[0.0], np.cumsum(np.diff(knots)
                                                  * 0.5 * (values[1:] + values[:-1]))])
    k = np.clip(np.searchsorted(knots, s, side="right") - 1, 0, len(knots) - 1)
    return cumulative[k] + (s - knots[k]) * 0.5 * (values[k] + np.interp(s, knots, values))


def profile_coefficients(knots: np.ndarray, values: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The kinetic μ of each turn θ_0 … θ_{P−2} of the routing points at arc lengths ``s``
    (P,) from a friction profile μ(s), piecewise linear through (``knots``, ``values``)
    (module docstring, "A μ per arc length"): μ(s_0) at the entry, and at point j the mean
    of μ over [m_{j−1}, m_j], m the chords' midpoints."""
    knots = np.asarray(knots, dtype=float)
    values = np.asarray(values, dtype=float)
    middles = 0.5 * (s[1:] + s[:-1])
    integral = _profile_integral(knots, values, middles)
    entry = np.interp(s[:1], knots, values)
    return np.concatenate([entry, np.diff(integral) / np.diff(middles)])


def bound_coefficients(kinetic: np.ndarray, static: float, state: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(μ_in, μ_out) of every turn (module docstring, "Per-point coefficients and
    stiction"): the kinetic μ_k of point e toward the side it slid to at the last
    equilibrium (``state`` −1: in, +1: out), the static μ_s = ``static`` toward any other
    (a point that stuck, or reverses, must break loose first)."""
    mu_in = np.where(state == SLIDING_IN, kinetic, static)
    mu_out = np.where(state == SLIDING_OUT, kinetic, static)
    return mu_in, mu_out


def _bounds(tension: float, mu_in: np.ndarray, mu_out: np.ndarray, theta: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """T_0 e^{−W_in,e} and T_0 e^{+W_out,e}, W_e = Σ_{j≤e} μ_j θ_j."""
    return (tension * np.exp(-np.cumsum(mu_in * theta)),
            tension * np.exp(np.cumsum(mu_out * theta)))


def weighted_chord_tensions(tension: float, mu_in: np.ndarray, mu_out: np.ndarray,
                            theta: np.ndarray, profile: np.ndarray) -> np.ndarray:
    """τ_e = clip(τ_old_e, T_0 e^{−W_in,e}, T_0 e^{+W_out,e}) with a coefficient per turn
    and side (``bound_coefficients``), W_e = Σ_{j≤e} μ_j θ_j: ``chord_tensions``
    with μΘ_e replaced by the weighted wrap."""
    low, high = _bounds(tension, mu_in, mu_out, theta)
    return np.minimum(np.maximum(profile, low), high)


def weighted_slide_rates(tension: float, mu_in: np.ndarray, mu_out: np.ndarray,
                         theta: np.ndarray, profile: np.ndarray) -> np.ndarray:
    """∂τ_e/∂Θ_e at chord e's own coefficient: −μ_in,e τ_e sliding in, +μ_out,e τ_e sliding
    out, 0 stuck (the part of ∂W_e that lies on chord e's turn; exact where μ is the same
    on the turns before it)."""
    low, high = _bounds(tension, mu_in, mu_out, theta)
    return np.where(low > profile, -mu_in * low,
                    np.where(high < profile, mu_out * high, 0.0))


def weighted_slide_factors(tension: float, mu_in: np.ndarray, mu_out: np.ndarray,
                           theta: np.ndarray, profile: np.ndarray) -> np.ndarray:
    """∂τ_e/∂W_e of every chord: −τ_e sliding in (τ_e = T_0 e^{−W_in,e}), +τ_e sliding out,
    0 stuck; the factor of ∂W_e/∂x = Σ_{j≤e} μ_j ∂θ_j/∂x in ∂τ_e/∂x, which reaches every
    turn up to e (rodsim/core/terms/_string_span.py)."""
    low, high = _bounds(tension, mu_in, mu_out, theta)
    return np.where(low > profile, -low, np.where(high < profile, high, 0.0))


def slip_states(tension: float, mu_in: np.ndarray, mu_out: np.ndarray, theta: np.ndarray,
                profile: np.ndarray, state: np.ndarray) -> np.ndarray:
    """The stick/slip state of every routing point at an equilibrium (the next step's
    history): −1 where chord e's tension is on its lower bound (the tendon slides in over
    point e), +1 on its upper bound (slides out), 0 where the stored tension held (stuck);
    on both bounds at once (no wrap up to e) the state it had. "On" is within
    ``SLIP_TIE`` relative."""
    low, high = _bounds(tension, mu_in, mu_out, theta)
    inward = low >= profile * (1.0 - SLIP_TIE)
    outward = high <= profile * (1.0 + SLIP_TIE)
    return np.where(inward & outward, state,
                    np.where(inward, SLIDING_IN, np.where(outward, SLIDING_OUT, STUCK)))


def breakaway_margins(tension: float, mu_in: np.ndarray, mu_out: np.ndarray,
                      theta: np.ndarray, profile: np.ndarray, state: np.ndarray
                      ) -> np.ndarray:
    """g_e of every routing point (module docstring, "Per-point coefficients and
    stiction"): with m_in = (τ_old_e (1 − SLIP_TIE) − T_0 e^{−W_in,e})/S and
    m_out = (T_0 e^{+W_out,e} − τ_old_e (1 + SLIP_TIE))/S (≤ 0: on that bound, as
    ``slip_states`` reads it; S = max(T_0, τ_old_e), 1 if both are 0), a point sliding in
    breaks loose outward, g = max(m_out, −m_in); one sliding out, inward,
    g = max(m_in, −m_out); a stuck one either way, the smaller of the two. g is continuous
    in the state and ≤ 0 exactly where the point broke loose (``slip_states`` gives a state
    other than 0 and other than the one it had); where it reads as on both bounds (no wrap
    up to it: the state is kept) g is the smallest positive number instead."""
    low, high = _bounds(tension, mu_in, mu_out, theta)
    scale = np.maximum(abs(tension), profile)
    scale = np.where(scale > 0.0, scale, 1.0)
    m_in = (profile * (1.0 - SLIP_TIE) - low) / scale
    m_out = (high - profile * (1.0 + SLIP_TIE)) / scale
    outward = np.maximum(m_out, -m_in)
    inward = np.maximum(m_in, -m_out)
    g = np.where(state == SLIDING_IN, outward,
                 np.where(state == SLIDING_OUT, inward, np.minimum(inward, outward)))
    both = (m_in <= 0.0) & (m_out <= 0.0)
    return np.where(both, np.finfo(float).tiny, g)
