"""The gradient of a string tendon's turning angles θ_j (rodsim/core/tendon_friction.py,
``turning_angles``) with respect to the unit vectors they are made of: the catheter's axis
d3 and the path's tangent t_in at the entry, and the chords' directions u_i (issue 34, "the
Jacobian stays exact"; docs/tendon.md, "Jacobian").

Every turn is a sum of angles ∠(a, b) = atan2(|a × b|, a·b) between unit vectors, each a
chord's direction, d3, t_in or a tangent extrapolated from two chords,
v = (near + s (near − far)) / |near + s (near − far)|. With c = a·b and S = |a × b|,

    ∂∠/∂a = −(b − c a)/S,   ∂∠/∂b = −(a − c b)/S

(orthogonal to a and b; ∠ is unchanged by the vectors' lengths), and a gradient g with
respect to v passes to the unnormalised w = near + s (near − far) as (g − (g·v) v)/|w|,
then (1 + s) g to ``near`` and −s g to ``far``. At S = 0 (a straight path: the angle's kink)
the gradient taken is 0, the subgradient of the turn's minimum.

The entry's turn θ_0 = ∠(d3, t_in) + P + w (K + S − P), P = ∠(t_in, u_0), K = ∠(t_in, t⁺),
S = ∠(t⁺, u_0), t⁺ the tangent extrapolated half a chord back from u_0, u_1, and the blend
w = S(r) S(q) of ``kink_weight``: dθ_0 = d∠(d3, t_in) + (1 − w) dP + w (dK + dS)
+ (K + S − P) dw, with dw from the C¹ ramps S′(z) = 6 z (1 − z) of r = K/S and of the
kink's share out of the plane q = |t⁺·n| / (|n| |t_in × t⁺|), n = t_in × u_0 (``_weight``).
Where a ramp is flat (w = 0 or 1 or a factor saturated) its derivative is 0, as the ramp's.

Layout (``turn_gradients``): turn j touches the chords i = j − 3 … j + 2 at most (a split
point k moves the turns k − 1, k, k + 1 onto the chords k − 3, k − 2, k + 1, k + 2), so
``near`` (E, 6, 3) holds ∂θ_j/∂u_{j−3+r} in row (j, r), and ``entry`` (2, 3) ∂θ_0/∂d3 and
∂θ_0/∂t_in. Pure numpy and plain loops: the compiled kernel
(rodsim/core/kernels/tendon_string_turns.py) runs these same functions compiled.
"""

from __future__ import annotations

import numpy as np

from rodsim.core.tendon_friction import KINK_LATERAL, KINK_PLAIN, KINK_SPLIT

__all__ = ["WINDOW", "angle_gradient", "extrapolated", "turn_gradients", "unit_back"]

#: Chords each turn's gradient may reach: j − 3 … j + 2.
WINDOW = 6


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.empty(3)
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]
    return out


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def angle_gradient(a: np.ndarray, b: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(∠(a, b), ∂∠/∂a, ∂∠/∂b) of unit vectors a, b (module docstring); zero gradients
    where a ∥ b."""
    cross = _cross(a, b)
    sine = np.sqrt(_dot(cross, cross))
    cosine = _dot(a, b)
    angle = np.arctan2(sine, cosine)
    ga = np.zeros(3)
    gb = np.zeros(3)
    if sine == 0.0:
        return angle, ga, gb
    for m in range(3):
        ga[m] = -(b[m] - cosine * a[m]) / sine
        gb[m] = -(a[m] - cosine * b[m]) / sine
    return angle, ga, gb


def extrapolated(near: np.ndarray, far: np.ndarray, step: float) -> tuple[np.ndarray, float]:
    """(v, |w|): the unit vector v along w = near + step (near − far), and |w|."""
    w = np.empty(3)
    for m in range(3):
        w[m] = near[m] + step * (near[m] - far[m])
    size = np.sqrt(_dot(w, w))
    for m in range(3):
        w[m] /= size
    return w, size


def unit_back(g: np.ndarray, v: np.ndarray, size: float) -> np.ndarray:
    """A gradient g with respect to v = w/|w| as one with respect to w: (g − (g·v) v)/|w|."""
    along = _dot(g, v)
    out = np.empty(3)
    for m in range(3):
        out[m] = (g[m] - along * v[m]) / size
    return out


def _ramp(z: float) -> tuple[float, float]:
    """(3z² − 2z³, 6z(1 − z)) on [0, 1]: ``kink_weight``'s C¹ step and its slope."""
    return z * z * (3.0 - 2.0 * z), 6.0 * z * (1.0 - z)


def _weight(t: np.ndarray, ahead: np.ndarray, first: np.ndarray, kink: float, step: float,
            dkink_t: np.ndarray, dkink_a: np.ndarray, dstep_a: np.ndarray,
            dstep_f: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """(w, ∂w/∂t_in, ∂w/∂t⁺, ∂w/∂u_0) of ``kink_weight`` (module docstring), from the kink
    K = ∠(t_in, t⁺) and the step S = ∠(t⁺, u_0) with their gradients."""
    gt, ga, gf = np.zeros(3), np.zeros(3), np.zeros(3)
    if kink <= KINK_PLAIN * step:
        return 0.0, gt, ga, gf
    normal = _cross(t, first)
    bent = _cross(t, ahead)
    size_n = np.sqrt(_dot(normal, normal))
    size_k = np.sqrt(_dot(bent, bent))
    across = size_n * size_k
    if across <= 0.0:
        return 0.0, gt, ga, gf
    number = _dot(ahead, normal)
    lateral = abs(number) / across
    if lateral <= 0.0:
        return 0.0, gt, ga, gf
    share, dshare = 1.0, 0.0
    if kink < KINK_SPLIT * step:
        width = KINK_SPLIT - KINK_PLAIN
        share, slope = _ramp((kink / step - KINK_PLAIN) / width)
        dshare = slope / width
    if dshare != 0.0:  # dr = dK/S − K dS/S²
        for m in range(3):
            gt[m] = dshare * dkink_t[m] / step
            ga[m] = dshare * (dkink_a[m] / step - kink * dstep_a[m] / (step * step))
            gf[m] = -dshare * kink * dstep_f[m] / (step * step)
    if lateral >= KINK_LATERAL:
        return share, gt, ga, gf
    factor, slope = _ramp(lateral / KINK_LATERAL)
    dlateral = share * slope / KINK_LATERAL
    sign = 1.0 if number > 0.0 else -1.0
    unit_n = normal / size_n
    unit_k = bent / size_k
    # d(t⁺·n), d|n| (n = t_in × u_0), d|k| (k = t_in × t⁺) by t_in, t⁺ and u_0.
    num_t, num_a, num_f = _cross(first, ahead), normal, _cross(ahead, t)
    n_t, n_f = _cross(first, unit_n), _cross(unit_n, t)
    k_t, k_a = _cross(ahead, unit_k), _cross(unit_k, t)
    for m in range(3):
        gt[m] = factor * gt[m] + dlateral * (sign * num_t[m] / across - lateral * (
            n_t[m] / size_n + k_t[m] / size_k))
        ga[m] = factor * ga[m] + dlateral * (sign * num_a[m] / across
                                             - lateral * k_a[m] / size_k)
        gf[m] = factor * gf[m] + dlateral * (sign * num_f[m] / across
                                             - lateral * n_f[m] / size_n)
    return share * factor, gt, ga, gf


def _entry(axis: np.ndarray, tangent: np.ndarray, u: np.ndarray, near: np.ndarray,
           entry: np.ndarray) -> None:
    """∂θ_0 into ``entry`` (d3, t_in) and ``near[0]`` (u_0, u_1 at rows 3, 4)."""
    _, g_axis, g_in = angle_gradient(axis, tangent)
    plain, p_in, p_first = angle_gradient(tangent, u[0])
    for m in range(3):
        entry[0, m] = g_axis[m]
    if u.shape[0] < 2:
        for m in range(3):
            entry[1, m] = g_in[m] + p_in[m]
            near[0, 3, m] = p_first[m]
        return
    ahead, size = extrapolated(u[0], u[1], 0.5)
    kink, k_in, k_ahead = angle_gradient(tangent, ahead)
    step, s_ahead, s_first = angle_gradient(ahead, u[0])
    w, w_in, w_ahead, w_first = _weight(tangent, ahead, u[0], kink, step, k_in, k_ahead,
                                        s_ahead, s_first)
    excess = kink + step - plain
    g_ahead = np.empty(3)
    for m in range(3):
        entry[1, m] = g_in[m] + (1.0 - w) * p_in[m] + w * k_in[m] + excess * w_in[m]
        near[0, 3, m] = (1.0 - w) * p_first[m] + w * s_first[m] + excess * w_first[m]
        g_ahead[m] = w * (k_ahead[m] + s_ahead[m]) + excess * w_ahead[m]
    back = unit_back(g_ahead, ahead, size)
    for m in range(3):
        near[0, 3, m] += 1.5 * back[m]
        near[0, 4, m] = -0.5 * back[m]


def _split(u: np.ndarray, k: int, near: np.ndarray) -> None:
    """The turns k − 1, k, k + 1 of a split point k (tendon_friction.turning_angles):
    their rows of ``near`` replaced."""
    a1, size_a1 = extrapolated(u[k - 2], u[k - 3], 1.0)
    a2, size_a2 = extrapolated(u[k - 2], u[k - 3], 1.5)
    b1, size_b1 = extrapolated(u[k + 1], u[k + 2], 1.0)
    b2, size_b2 = extrapolated(u[k + 1], u[k + 2], 1.5)
    for j in (k - 1, k, k + 1):
        near[j] = 0.0
    _, g_u, g_a1 = angle_gradient(u[k - 2], a1)  # θ_{k−1}: u_{k−2} at row 2 of j = k − 1
    near[k - 1, 2] += g_u
    back = unit_back(g_a1, a1, size_a1)
    near[k - 1, 2] += 2.0 * back
    near[k - 1, 1] -= back
    # θ_k = ∠(a1, a2) + ∠(a2, b2) + ∠(b2, b1): u_{k−3}, u_{k−2}, u_{k+1}, u_{k+2} at rows
    # 0, 1, 4, 5 of j = k.
    _, x1, x2 = angle_gradient(a1, a2)
    _, y2, z2 = angle_gradient(a2, b2)
    _, w2, w1 = angle_gradient(b2, b1)
    for vector, size, gradient, step, rows in (
            (a1, size_a1, x1, 1.0, (1, 0)), (a2, size_a2, x2 + y2, 1.5, (1, 0)),
            (b2, size_b2, z2 + w2, 1.5, (4, 5)), (b1, size_b1, w1, 1.0, (4, 5))):
        back = unit_back(gradient, vector, size)
        near[k, rows[0]] += (1.0 + step) * back
        near[k, rows[1]] -= step * back
    _, g_b1, g_u = angle_gradient(b1, u[k + 1])  # θ_{k+1}: u_{k+1} at row 3 of j = k + 1
    near[k + 1, 3] += g_u
    back = unit_back(g_b1, b1, size_b1)
    near[k + 1, 3] += 2.0 * back
    near[k + 1, 4] -= back


def turn_gradients(axis: np.ndarray, tangent: np.ndarray, u: np.ndarray,
                   split: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(near (E, 6, 3), entry (2, 3)) of the turns θ_0 … θ_{E−1} of the chords ``u`` (E, 3)
    (module docstring, "Layout"), as ``turning_angles(axis, tangent, p, split)`` makes
    them; ``split`` None: no split point (the entry's turn the plain one too)."""
    chords = u.shape[0]
    near = np.zeros((chords, WINDOW, 3))
    entry = np.zeros((2, 3))
    for j in range(1, chords):
        _, g_before, g_after = angle_gradient(u[j - 1], u[j])
        near[j, 2] = g_before
        near[j, 3] = g_after
    if split is None:
        _, g_axis, g_in = angle_gradient(axis, tangent)
        _, p_in, p_first = angle_gradient(tangent, u[0])
        entry[0] = g_axis
        entry[1] = g_in + p_in
        near[0, 3] = p_first
        return near, entry
    _entry(axis, tangent, u, near, entry)
    for k in range(3, chords - 2):
        if split[k]:
            _split(u, k, near)
    return near, entry
