"""The routing geometry and the tensions of a string tendon's kernel
(``rodsim.core.kernels.tendon_string``, whose docstring gives the formulas): a routing
point's position and its derivatives in the element's coordinates (``_point``, ``_points``,
``_points_into``), the curvature Σ_m u_m ∂²p[m] contracted with a chord's direction
(``_curvature``), the path's length Σ |p_{k+1} − p_k| (``path_length``), and with
friction the chords' capstan tensions (``_tensions``) and their one-way coupling ∂τ_e/∂x
(``_one_way_coupling``; rodsim/core/tendon_friction.py).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.tendon_friction import KINK_LATERAL, KINK_PLAIN, KINK_SPLIT, ONE_WAY


@njit(cache=True, inline="always")
def _point(x: np.ndarray, dofs: np.ndarray, e: int, side: int, weights: np.ndarray,
           constant: np.ndarray, forms: np.ndarray, p: np.ndarray, jac: np.ndarray,
           q: np.ndarray, gq: np.ndarray, g: np.ndarray) -> float:
    """Position p (3,) and ∂p/∂x_point (3, 14) of point k = e + side, and the small parts
    its second derivatives are built from (``_curvature``): q (4,), G_m q (3, 4), g (3,),
    into row k of each (indexed, not sliced: a view per point costs its reference
    counting); returns n = |q|²."""
    k = e + side
    base = 14 * side
    c0, c1, w0, w1 = weights[k, 0], weights[k, 1], weights[k, 2], weights[k, 3]
    for i in range(4):
        q[k, i] = (w0 * x[dofs[e, base + 6 + i]] + w1 * x[dofs[e, base + 10 + i]]
                   + constant[k, i])
    n = q[k, 0] * q[k, 0] + q[k, 1] * q[k, 1] + q[k, 2] * q[k, 2] + q[k, 3] * q[k, 3]
    for m in range(3):
        value = 0.0
        for i in range(4):
            row = 0.0
            for j in range(4):
                row += forms[k, m, i, j] * q[k, j]
            gq[k, m, i] = row
            value += row * q[k, i]
        g[k, m] = value
    for m in range(3):
        p[k, m] = (c0 * x[dofs[e, base + m]] + c1 * x[dofs[e, base + 3 + m]] + g[k, m] / n)
        for a in range(14):
            jac[k, m, a] = 0.0
        jac[k, m, m] = c0
        jac[k, m, 3 + m] = c1
        for i in range(4):
            grad = 2.0 * gq[k, m, i] / n - 2.0 * g[k, m] * q[k, i] / (n * n)
            jac[k, m, 6 + i] = w0 * grad
            jac[k, m, 10 + i] = w1 * grad
    return n


@njit(cache=True)
def _points(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
            forms: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                        np.ndarray, np.ndarray]:
    """p, ∂p/∂x_point and the small parts q, n, G_m q, g of every routing point, each
    computed once (point k is side 0 of chord k and side 1 of chord k − 1: the same
    numbers)."""
    chords = dofs.shape[0]
    p = np.empty((chords + 1, 3))
    jac = np.empty((chords + 1, 3, 14))
    q = np.empty((chords + 1, 4))
    n = np.empty(chords + 1)
    gq = np.empty((chords + 1, 3, 4))
    g = np.empty((chords + 1, 3))
    _points_into(x, dofs, weights, constant, forms, p, jac, q, n, gq, g)
    return p, jac, q, n, gq, g


@njit(cache=True)
def _points_into(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
                 forms: np.ndarray, p: np.ndarray, jac: np.ndarray, q: np.ndarray,
                 n: np.ndarray, gq: np.ndarray, g: np.ndarray) -> None:
    """``_points`` into the given arrays (one row per routing point)."""
    chords = dofs.shape[0]
    for k in range(chords + 1):
        e, side = (k, 0) if k < chords else (k - 1, 1)
        n[k] = _point(x, dofs, e, side, weights, constant, forms, p, jac, q, gq, g)


@njit(cache=True, inline="always")
def _curvature(forms: np.ndarray, k: int, u: np.ndarray, q: np.ndarray, n: np.ndarray,
               gq: np.ndarray, g: np.ndarray, factor: float, out: np.ndarray) -> None:
    """factor · Σ_m u_m ∇²f_m of point k into ``out`` (4, 4), from row k of the points'
    q, n, G_m q and g (``_points``; indexed, not sliced: a view per call costs its
    reference counting), contracted with u before it
    is built: with G_u = Σ_m u_m G_m, v = G_u q and γ = Σ_m u_m g_m,
    Σ_m u_m ∇²f_m = 2 G_u/n − 4 (v qᵀ + q vᵀ)/n² − 2 γ I/n² + 8 γ q qᵀ/n³ (module
    docstring)."""
    v0 = u[0] * gq[k, 0, 0] + u[1] * gq[k, 1, 0] + u[2] * gq[k, 2, 0]
    v1 = u[0] * gq[k, 0, 1] + u[1] * gq[k, 1, 1] + u[2] * gq[k, 2, 1]
    v2 = u[0] * gq[k, 0, 2] + u[1] * gq[k, 1, 2] + u[2] * gq[k, 2, 2]
    v3 = u[0] * gq[k, 0, 3] + u[1] * gq[k, 1, 3] + u[2] * gq[k, 2, 3]
    gamma = u[0] * g[k, 0] + u[1] * g[k, 1] + u[2] * g[k, 2]
    inverse = 1.0 / n[k]
    a1 = 2.0 * inverse * factor
    a2 = 4.0 * inverse * inverse * factor
    a3 = 2.0 * gamma * inverse * inverse * factor
    a4 = 8.0 * gamma * inverse * inverse * inverse * factor
    for i in range(4):
        vi = v0 if i == 0 else (v1 if i == 1 else (v2 if i == 2 else v3))
        for j in range(i, 4):
            vj = v0 if j == 0 else (v1 if j == 1 else (v2 if j == 2 else v3))
            value = (a1 * (u[0] * forms[k, 0, i, j] + u[1] * forms[k, 1, i, j]
                           + u[2] * forms[k, 2, i, j])
                     - a2 * (vi * q[k, j] + q[k, i] * vj) + a4 * q[k, i] * q[k, j])
            if i == j:
                value -= a3
            out[i, j] = value
            out[j, i] = value


@njit(cache=True)
def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """∠(a, b) of unit vectors, atan2(|a × b|, a·b)."""
    cx = a[1] * b[2] - a[2] * b[1]
    cy = a[2] * b[0] - a[0] * b[2]
    cz = a[0] * b[1] - a[1] * b[0]
    return np.arctan2(np.sqrt(cx * cx + cy * cy + cz * cz),
                      a[0] * b[0] + a[1] * b[1] + a[2] * b[2])


@njit(cache=True)
def _smooth_step(z: float) -> float:
    """3z² − 2z³ on [0, 1] (``rodsim.core.tendon_friction``)."""
    return z * z * (3.0 - 2.0 * z)


@njit(cache=True)
def _entry_weight(a: np.ndarray, ahead: np.ndarray, first: np.ndarray, kink: float,
                  step: float) -> float:
    """The share of the entry's split turn (``rodsim.core.tendon_friction.kink_weight``):
    from kink/step and the kink's share out of the plane of t_in = ``a`` and u_0 =
    ``first``, sin δ / sin ∠(t_in, t⁺)."""
    if kink <= KINK_PLAIN * step:
        return 0.0
    nx = a[1] * first[2] - a[2] * first[1]
    ny = a[2] * first[0] - a[0] * first[2]
    nz = a[0] * first[1] - a[1] * first[0]
    kx = a[1] * ahead[2] - a[2] * ahead[1]
    ky = a[2] * ahead[0] - a[0] * ahead[2]
    kz = a[0] * ahead[1] - a[1] * ahead[0]
    across = np.sqrt(nx * nx + ny * ny + nz * nz) * np.sqrt(kx * kx + ky * ky + kz * kz)
    if across <= 0.0:
        return 0.0
    lateral = np.abs(ahead[0] * nx + ahead[1] * ny + ahead[2] * nz) / across
    if lateral <= 0.0:
        return 0.0
    share = 1.0
    if kink < KINK_SPLIT * step:
        share = _smooth_step((kink / step - KINK_PLAIN) / (KINK_SPLIT - KINK_PLAIN))
    if lateral >= KINK_LATERAL:
        return share
    return share * _smooth_step(lateral / KINK_LATERAL)


@njit(cache=True)
def _entry_turn(a: np.ndarray, first: np.ndarray, second: np.ndarray, plain: float) -> float:
    """The entry's turn from t_in = ``a`` on to chord 0 (u_0 = ``first``, u_1 = ``second``):
    ∠(t_in, u_0) = ``plain``, ∠(t_in, t⁺) + ∠(t⁺, u_0) or between them by ``_entry_weight``."""
    ahead = _extrapolated(first, second, 0.5)
    kink = _angle(a, ahead)
    step = _angle(ahead, first)
    weight = _entry_weight(a, ahead, first, kink, step)
    if weight == 1.0:
        return kink + step
    if weight > 0.0:
        return plain + weight * (kink + step - plain)
    return plain


@njit(cache=True)
def _extrapolated(near: np.ndarray, far: np.ndarray, step: float) -> np.ndarray:
    """The unit vector along near + step (near − far): a chord's tangent carried ``step``
    chords on, away from its neighbour ``far``."""
    out = np.empty(3)
    size = 0.0
    for m in range(3):
        out[m] = near[m] + step * (near[m] - far[m])
        size += out[m] * out[m]
    for m in range(3):
        out[m] /= np.sqrt(size)
    return out


@njit(cache=True)
def entry_quaternion(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray,
                     constant: np.ndarray, q: np.ndarray) -> float:
    """The quaternion at chord 0's entry point into ``q`` (its two segments' quaternions
    weighted, plus the held part ``constant``), unnormalised; returns |q|²."""
    w0, w1 = weights[0, 2], weights[0, 3]
    for i in range(4):
        q[i] = w0 * x[dofs[0, 6 + i]] + w1 * x[dofs[0, 10 + i]] + constant[0, i]
    return q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]


@njit(cache=True)
def _tensions(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
              entry_forms: np.ndarray, entry_slope: np.ndarray, split: np.ndarray,
              p: np.ndarray, tension: float, friction: float, profile: np.ndarray,
              weighted: bool, mu_in: np.ndarray, mu_out: np.ndarray,
              out: np.ndarray, rate: np.ndarray, axis: np.ndarray,
              slide: np.ndarray) -> None:
    """τ_e of every chord into ``out``: T without friction, else
    clip(τ_old_e, T e^{−μΘ_e}, T e^{+μΘ_e}) (rodsim/core/tendon_friction.py; ``weighted``:
    μΘ_e is Σ_{j≤e} μ_j θ_j with μ_in, μ_out per turn for the two bounds); with friction
    also ∂τ_e/∂Θ_e into ``rate`` where the path up to chord e turns one way in one plane from
    a held entry frame (else 0) and d3 at the entry into ``axis``; on every chord
    ∂τ_e/∂W_e into ``slide`` (−τ_e sliding in, +τ_e sliding out, 0 stuck): the factor of
    the coupling to the turns (rodsim/core/kernels/tendon_string_span.py)."""
    chords = dofs.shape[0]
    if friction == 0.0:
        for e in range(chords):
            out[e] = tension
            slide[e] = 0.0
        return
    q = np.empty(4)
    n = entry_quaternion(x, dofs, weights, constant, q)
    d = np.empty((3, 3))
    for k in range(3):
        for m in range(3):
            value = 0.0
            for i in range(4):
                for j in range(4):
                    value += q[i] * entry_forms[k, m, i, j] * q[j]
            d[k, m] = value / n
    for m in range(3):
        axis[m] = d[2, m]
    held = weights[0, 2] == 0.0 and weights[0, 3] == 0.0
    a = np.empty(3)
    for m in range(3):
        a[m] = d[2, m] + entry_slope[0] * d[0, m] + entry_slope[1] * d[1, m]
    size = np.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    for m in range(3):
        a[m] /= size
    plain = _angle(axis, a)
    wrap = plain
    u = np.empty((chords, 3))
    for e in range(chords):
        length = 0.0
        for m in range(3):
            u[e, m] = p[e + 1, m] - p[e, m]
            length += u[e, m] * u[e, m]
        length = np.sqrt(length)
        for m in range(3):
            u[e, m] /= length
    theta = np.empty(chords)
    for e in range(chords):
        theta[e] = _angle(a if e == 0 else u[e - 1], u[e])
    turns = theta.copy()
    if chords >= 2:
        # The entry's turn through t⁺, extrapolated from chords 0 and 1, where the kink
        # t_in → t⁺ is the path's own and leaves the plane of t_in and u_0, blended with the
        # plain angle as it falls to an extrapolation's error or into that plane
        # (rodsim/core/tendon_friction.py, "Split turns").
        theta[0] = _entry_turn(a, u[0], u[1], theta[0])
    for k in range(3, chords - 2):
        if split[k]:
            a1 = _extrapolated(u[k - 2], u[k - 3], 1.0)
            a2 = _extrapolated(u[k - 2], u[k - 3], 1.5)
            b1 = _extrapolated(u[k + 1], u[k + 2], 1.0)
            b2 = _extrapolated(u[k + 1], u[k + 2], 1.5)
            theta[k - 1] = _angle(u[k - 2], a1)
            theta[k] = _angle(a1, a2) + _angle(a2, b2) + _angle(b2, b1)
            theta[k + 1] = _angle(b1, u[k + 1])
    b = np.empty(3)
    wrap_in = 0.0
    wrap_out = 0.0
    for e in range(chords):
        for m in range(3):
            b[m] = u[e, m]
        plain += turns[e]
        turn = theta[e]
        if weighted:
            wrap_in += mu_in[e] * turn
            wrap_out += mu_out[e] * turn
            low = tension * np.exp(-wrap_in)
            high = tension * np.exp(wrap_out)
            rate_in, rate_out = mu_in[e], mu_out[e]
        else:
            wrap += turn
            low = tension * np.exp(-friction * wrap)
            high = tension * np.exp(friction * wrap)
            rate_in, rate_out = friction, friction
        out[e] = min(max(profile[e], low), high)
        slide[e] = -low if low > profile[e] else (high if high < profile[e] else 0.0)
        rate[e] = 0.0
        if (slide[e] != 0.0 and held
                and np.abs(plain - _angle(axis, b)) <= ONE_WAY * max(1.0, plain)):
            rate[e] = (rate_in if slide[e] < 0.0 else rate_out) * slide[e]


@njit(cache=True, inline="always")
def _one_way_coupling(jd: np.ndarray, u: np.ndarray, length: float, axis: np.ndarray,
                      rate: float, count: int, slope: np.ndarray, gradient: np.ndarray,
                      unit_force: np.ndarray) -> bool:
    """The two factors of f ⊗ rate ∂ψ/∂x, which the element Jacobian of a chord on a
    one-way planar path adds: f = −Jdᵀ u into ``unit_force`` and rate ∂ψ/∂x = −rate (d3 −
    (d3·u) u)ᵀ Jd / (|d3 × u| |d|) into ``gradient`` (rodsim/core/tendon_friction.py), on
    the first ``count`` columns of ``jd``; False (nothing to add) where d3 ∥ u."""
    cosine = axis[0] * u[0] + axis[1] * u[1] + axis[2] * u[2]
    cx = axis[1] * u[2] - axis[2] * u[1]
    cy = axis[2] * u[0] - axis[0] * u[2]
    cz = axis[0] * u[1] - axis[1] * u[0]
    sine = np.sqrt(cx * cx + cy * cy + cz * cz)
    if sine == 0.0:
        return False
    for m in range(3):
        slope[m] = -(axis[m] - cosine * u[m]) / (sine * length)
    for k in range(count):
        value = 0.0
        f = 0.0
        for m in range(3):
            value += slope[m] * jd[m, k]
            f -= jd[m, k] * u[m]
        gradient[k] = rate * value
        unit_force[k] = f
    return True


@njit(cache=True)
def path_length(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
                forms: np.ndarray) -> float:
    """The tendon's path length Σ |p_{k+1} − p_k| over its chords (the energy's T ℓ, of one
    tendon alone and of a group's, summed in the same order)."""
    p = _points(x, dofs, weights, constant, forms)[0]
    total = 0.0
    for e in range(dofs.shape[0]):
        total += np.sqrt((p[e + 1, 0] - p[e, 0]) ** 2 + (p[e + 1, 1] - p[e, 1]) ** 2
                         + (p[e + 1, 2] - p[e, 2]) ** 2)
    return total
