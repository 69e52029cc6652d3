"""Kernel of ``rodsim.core.terms.tendon_string``: V = T ℓ, one element per chord of the
tendon's path between routing points A and B (28 coordinates: r_m, r_{m+1}, Q_0, Q_1 of A,
then of B). For a point with weights (c0, c1, w0, w1), constant quaternion q_c and forms G_m,

    q = w0 Q_0 + w1 Q_1 + q_c,  n = |q|²,  g_m = qᵀ G_m q,  p = c0 r_m + c1 r_{m+1} + g / n,
    ∂p/∂q = 2 G q / n − 2 g qᵀ / n²,
    ∂²p_m/∂q² = 2 G_m/n − 4 (G_m q qᵀ + q qᵀ G_m)/n² − 2 g_m I/n² + 8 g_m q qᵀ/n³;

with d = p_B − p_A, u = d/|d|: F = −T Jdᵀ u and ∂F/∂x = −T [Jdᵀ (I − u uᵀ) Jd / |d|
+ Σ_m u_m (∂²p_B[m] − ∂²p_A[m])], Jd = [−J_A, J_B].

With friction μ > 0 each chord carries its own tension τ_e in place of T — the capstan
profile with the stored history ``profile`` (rodsim/core/tendon_friction.py: the entry's
turn from d3 to the path's tangent d3 + ρ′_y d1 + ρ′_z d2 (d_k = qᵀ A_k q / n of the entry
point, ρ′ = ``entry_slope``) and on, the turns at the points, split at the entry and at
the points ``split`` marks, the actuator's bounds) —
and the Jacobian is the one at frozen τ_e plus, on a chord up to which the path turns one
way in one plane from a held entry frame, f ⊗ ∂τ_e/∂x with ∂τ_e/∂x = (∂τ_e/∂Θ_e) ∂ψ_e/∂x,
ψ_e = ∠(d3, u_e) (rodsim/core/terms/tendon_string.py, "Friction"). With μ = 0 every τ_e is
T and the coupling is skipped: the frictionless numbers, bitwise.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._scatter import add_force
from rodsim.core.tendon_friction import ONE_WAY


@njit(cache=True)
def _point(x: np.ndarray, dofs: np.ndarray, e: int, side: int, weights: np.ndarray,
           constant: np.ndarray, forms: np.ndarray, p: np.ndarray, jac: np.ndarray,
           hess: np.ndarray, want_hessian: bool, q: np.ndarray, gq: np.ndarray,
           g: np.ndarray) -> None:
    """Position p (3,), ∂p/∂x_point (3, 14) and ∇²f (3, 4, 4) of point e + side; q (4,),
    gq (3, 4) and g (3,) are scratch."""
    k = e + side
    base = 14 * side
    c0, c1, w0, w1 = weights[k, 0], weights[k, 1], weights[k, 2], weights[k, 3]
    for i in range(4):
        q[i] = w0 * x[dofs[e, base + 6 + i]] + w1 * x[dofs[e, base + 10 + i]] + constant[k, i]
    n = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]
    for m in range(3):
        value = 0.0
        for i in range(4):
            row = 0.0
            for j in range(4):
                row += forms[k, m, i, j] * q[j]
            gq[m, i] = row
            value += row * q[i]
        g[m] = value
    for m in range(3):
        p[m] = (c0 * x[dofs[e, base + m]] + c1 * x[dofs[e, base + 3 + m]] + g[m] / n)
        for a in range(14):
            jac[m, a] = 0.0
        jac[m, m] = c0
        jac[m, 3 + m] = c1
        for i in range(4):
            grad = 2.0 * gq[m, i] / n - 2.0 * g[m] * q[i] / (n * n)
            jac[m, 6 + i] = w0 * grad
            jac[m, 10 + i] = w1 * grad
        if want_hessian:
            for i in range(4):
                for j in range(4):
                    h = (2.0 * forms[k, m, i, j] / n
                         - 4.0 * (gq[m, i] * q[j] + q[i] * gq[m, j]) / (n * n)
                         + 8.0 * g[m] * q[i] * q[j] / (n * n * n))
                    if i == j:
                        h -= 2.0 * g[m] / (n * n)
                    hess[m, i, j] = h


@njit(cache=True)
def _points(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
            forms: np.ndarray, want_hessian: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """p, ∂p/∂x_point and ∇²f of every routing point, each computed once (point k is side 0
    of chord k and side 1 of chord k − 1: the same numbers)."""
    chords = dofs.shape[0]
    p = np.empty((chords + 1, 3))
    jac = np.empty((chords + 1, 3, 14))
    hess = np.empty((chords + 1 if want_hessian else 1, 3, 4, 4))
    q = np.empty(4)
    gq = np.empty((3, 4))
    g = np.empty(3)
    for k in range(chords + 1):
        e, side = (k, 0) if k < chords else (k - 1, 1)
        _point(x, dofs, e, side, weights, constant, forms, p[k], jac[k],
               hess[k if want_hessian else 0], want_hessian, q, gq, g)
    return p, jac, hess


@njit(cache=True)
def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """∠(a, b) of unit vectors, atan2(|a × b|, a·b)."""
    cx = a[1] * b[2] - a[2] * b[1]
    cy = a[2] * b[0] - a[0] * b[2]
    cz = a[0] * b[1] - a[1] * b[0]
    return np.arctan2(np.sqrt(cx * cx + cy * cy + cz * cz),
                      a[0] * b[0] + a[1] * b[1] + a[2] * b[2])


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
def _tensions(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
              entry_forms: np.ndarray, entry_slope: np.ndarray, split: np.ndarray,
              p: np.ndarray, tension: float, friction: float, profile: np.ndarray,
              out: np.ndarray, rate: np.ndarray, axis: np.ndarray) -> None:
    """τ_e of every chord into ``out``: T without friction, else
    clip(τ_old_e, T e^{−μΘ_e}, T e^{+μΘ_e}) (rodsim/core/tendon_friction.py); with friction
    also ∂τ_e/∂Θ_e into ``rate`` where the path up to chord e turns one way in one plane from
    a held entry frame (else 0) and d3 at the entry into ``axis``."""
    chords = dofs.shape[0]
    if friction == 0.0:
        for e in range(chords):
            out[e] = tension
        return
    w0, w1 = weights[0, 2], weights[0, 3]
    q = np.empty(4)
    for i in range(4):
        q[i] = w0 * x[dofs[0, 6 + i]] + w1 * x[dofs[0, 10 + i]] + constant[0, i]
    n = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]
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
        # The entry's turn through t⁺, extrapolated from chords 0 and 1, unless t_in, t⁺ and
        # u_0 lie in one plane (rodsim/core/tendon_friction.py, "Split turns").
        ahead = _extrapolated(u[0], u[1], 0.5)
        volume = (a[0] * (ahead[1] * u[0, 2] - ahead[2] * u[0, 1])
                  + a[1] * (ahead[2] * u[0, 0] - ahead[0] * u[0, 2])
                  + a[2] * (ahead[0] * u[0, 1] - ahead[1] * u[0, 0]))
        if np.abs(volume) > ONE_WAY:
            theta[0] = _angle(a, ahead) + _angle(ahead, u[0])
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
    for e in range(chords):
        for m in range(3):
            b[m] = u[e, m]
        plain += turns[e]
        turn = theta[e]
        wrap += turn
        low = tension * np.exp(-friction * wrap)
        high = tension * np.exp(friction * wrap)
        out[e] = min(max(profile[e], low), high)
        rate[e] = 0.0
        if held and np.abs(plain - _angle(axis, b)) <= ONE_WAY * max(1.0, plain):
            if low > profile[e]:
                rate[e] = -friction * low
            elif high < profile[e]:
                rate[e] = friction * high


@njit(cache=True)
def _one_way_coupling(jd: np.ndarray, u: np.ndarray, length: float, axis: np.ndarray,
                      rate: float, columns: np.ndarray, active: int, slope: np.ndarray,
                      gradient: np.ndarray, unit_force: np.ndarray,
                      local_jacobian: np.ndarray) -> None:
    """Add f ⊗ rate ∂ψ/∂x of a chord on a one-way planar path to its element Jacobian:
    f = −Jdᵀ u, ∂ψ/∂x = −(d3 − (d3·u) u)ᵀ Jd / (|d3 × u| |d|) (rodsim/core/tendon_friction.py)."""
    cosine = axis[0] * u[0] + axis[1] * u[1] + axis[2] * u[2]
    cx = axis[1] * u[2] - axis[2] * u[1]
    cy = axis[2] * u[0] - axis[0] * u[2]
    cz = axis[0] * u[1] - axis[1] * u[0]
    sine = np.sqrt(cx * cx + cy * cy + cz * cz)
    if sine == 0.0:
        return
    for m in range(3):
        slope[m] = -(axis[m] - cosine * u[m]) / (sine * length)
    for c in range(active):
        k = columns[c]
        g = 0.0
        f = 0.0
        for m in range(3):
            g += slope[m] * jd[m, k]
            f -= jd[m, k] * u[m]
        gradient[k] = rate * g
        unit_force[k] = f
    for c in range(active):
        k = columns[c]
        for d in range(active):
            j = columns[d]
            local_jacobian[k, j] += unit_force[k] * gradient[j]


@njit(cache=True)
def _active(weights: np.ndarray, e: int, columns: np.ndarray) -> int:
    """The element's local columns whose weight is not zero (the others of ∂d/∂x are exact
    zeros, and so are their rows and columns of the element Jacobian): their count, the
    columns in ``columns``."""
    count = 0
    for side in range(2):
        for group in range(4):
            if weights[e + side, group] != 0.0:
                first = 14 * side + (3 * group if group < 2 else 6 + 4 * (group - 2))
                for a in range(3 if group < 2 else 4):
                    columns[count] = first + a
                    count += 1
    return count


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
             forms: np.ndarray, tension: float, friction: float, profile: np.ndarray,
             entry_forms: np.ndarray, entry_slope: np.ndarray, split: np.ndarray,
             scale: float, want_force: bool,
             force: np.ndarray, force_target: np.ndarray, want_jacobian: bool,
             jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    if tension == 0.0:
        return  # a slack tendon: every entry is zero (its tension is a factor of each)
    local_force = np.empty(28)
    local_jacobian = np.empty((28, 28))
    columns = np.empty(28, dtype=np.int64)
    jd = np.empty((3, 28))
    u = np.empty(3)
    proj = np.empty((3, 3))
    pj = np.empty((3, 28))
    p, jac, hess = _points(x, dofs, weights, constant, forms, want_jacobian)
    chord_tension = np.empty(dofs.shape[0])
    rate = np.zeros(dofs.shape[0])
    axis = np.zeros(3)
    _tensions(x, dofs, weights, constant, entry_forms, entry_slope, split, p, tension,
              friction, profile, chord_tension, rate, axis)
    slope = np.empty(3)
    gradient = np.empty(28)
    unit_force = np.empty(28)
    for e in range(dofs.shape[0]):
        pull = chord_tension[e]
        pa, pb, ja, jb = p[e], p[e + 1], jac[e], jac[e + 1]
        length = 0.0
        for m in range(3):
            u[m] = pb[m] - pa[m]
            length += u[m] * u[m]
        length = np.sqrt(length)
        for m in range(3):
            u[m] /= length
            for a in range(14):
                jd[m, a] = -ja[m, a]
                jd[m, 14 + a] = jb[m, a]
        if want_force:
            for a in range(28):
                value = 0.0
                for m in range(3):
                    value += jd[m, a] * u[m]
                local_force[a] = -pull * value
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            # Only the columns with a weight: the rest of the element Jacobian is zero.
            active = _active(weights, e, columns)
            for a in range(3):
                for b in range(3):
                    proj[a, b] = ((1.0 if a == b else 0.0) - u[a] * u[b]) * pull / length
            for a in range(3):
                for c in range(active):
                    k = columns[c]
                    value = 0.0
                    for b in range(3):
                        value += proj[a, b] * jd[b, k]
                    pj[a, k] = value
            for c in range(active):
                k = columns[c]
                for d in range(active):
                    j = columns[d]
                    value = 0.0
                    for a in range(3):
                        value += jd[a, k] * pj[a, j]
                    local_jacobian[k, j] = -value
            for side in range(2):
                k = e + side
                h = hess[k]
                sign = 1.0 if side == 1 else -1.0
                offset = 14 * side + 6
                for i in range(4):
                    for j in range(4):
                        curvature = 0.0
                        for m in range(3):
                            curvature += u[m] * h[m, i, j]
                        curvature *= sign * pull
                        for a in range(2):
                            for b in range(2):
                                weight = weights[k, 2 + a] * weights[k, 2 + b]
                                if weight != 0.0:
                                    local_jacobian[offset + 4 * a + i, offset + 4 * b + j] -= (
                                        weight * curvature)
            if rate[e] != 0.0:
                _one_way_coupling(jd, u, length, axis, rate[e], columns, active, slope,
                                  gradient, unit_force, local_jacobian)
            for c in range(active):
                k = columns[c]
                for d in range(active):
                    j = columns[d]
                    jacobian[jacobian_target[e, k, j]] += scale * local_jacobian[k, j]


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
           forms: np.ndarray, tension: float, friction: float, profile: np.ndarray,
           entry_forms: np.ndarray, entry_slope: np.ndarray, split: np.ndarray) -> float:
    """T Σ |p_{k+1} − p_k| (frictionless; with friction the model asks for no energy)."""
    if tension == 0.0:
        return 0.0
    p, _, _ = _points(x, dofs, weights, constant, forms, False)
    total = 0.0
    for e in range(dofs.shape[0]):
        total += np.sqrt((p[e + 1, 0] - p[e, 0]) ** 2 + (p[e + 1, 1] - p[e, 1]) ** 2
                         + (p[e + 1, 2] - p[e, 2]) ** 2)
    return tension * total
