"""Kernel of ``rodsim.core.terms.lumen_conserving`` (the conserving coupling), Eqs. (24)–(27),
(32)–(35) with docs/design.md, erratum 13 (``rodsim.core.terms._lumen_segment``): per
tendon point p on lumen segment j, local coordinates (p, r_j, r_{j+1}, q_{j−1}, q_j, q_{j+1}),

    L_j = r_j + r_L u(s_j),  τ_j = t(s_j),  s_j = Σ_k weights[e, 0, k] q_slot k  (j + 1 likewise),
    K_j = K_{j+1} = K_T = (e₊ − e₋)/l_T  (the tendon's turn at the stencil p_{b−1}, p_b, p_{b+1},
    local coordinates 21–29, present when the chord correction is on; else 0),
    L(σ) = Σ_b w_b(σ) y_b over y = (L_j, L_{j+1}, τ_j, τ_{j+1}, K_j, K_{j+1}),
    w = (h00, h01, l̄ h10, l̄ h11, c (1 − σ), c σ)  (c = ``sagitta[e]``, the chord correction;
    on the last segment (c g(σ), 0), g = 1 + 2σ − 3σ²),
    σ: (L(σ) − p)·L′(σ) = 0 (Newton),   Δ = L(σ) − p,   E = ½ k |Δ|²,
    f_y = k w ⊗ Δ (w_p = −1),   f_yy = k w wᵀ ⊗ I,   f_yσ = k (w′ ⊗ Δ + w ⊗ L′),
    f_σσ = k (L′·L′ + Δ·L″),   ∇²_y E = f_yy − f_yσ f_yσᵀ / f_σσ,

pulled back through the chain G = ∂y/∂x (21 × width, y = (p, L_j, L_{j+1}, τ_j, τ_{j+1}, K_j,
K_{j+1})), plus Σ_m f_{K,m} ∂²K_T,m on the stencil (f_K = f_{K_j} + f_{K_{j+1}}):
F = −Gᵀ f_y,  ∂F/∂x = −(Gᵀ ∇²_y E G + Σ over both nodes of r_L Σ_m f_{L,m} ∂²u_m/∂s²
+ Σ_m f_{τ,m} ∂²t_m/∂s² on the node's two quaternions), u, t and their derivatives from
``rodsim.core.kernels._node_frame``. k = K_L × the point's share of the tendon's length, one
value per element; ``ends`` marks elements on the catheter's first and last segment, where
the lumen goes on straight beyond the catheter (``rodsim.core.terms._lumen_segment.hermite``);
``weights`` (n, 2, 3) are ``rodsim.core.terms._lumen_segment.node_weights``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._node_frame import node_director, node_director_hessian, raw_directors
from rodsim.core.kernels._scatter import add_force, add_jacobian

SIGMA_TOLERANCE = 1e-12
SIGMA_ITERATIONS = 50


@njit(cache=True)
def hermite(sigma: float, before: bool, after: bool, length: float, sagitta: float,
            w: np.ndarray, w1: np.ndarray, w2: np.ndarray) -> None:
    """w, w′, w″ (7,) of y = (p, L_j, L_{j+1}, τ_j, τ_{j+1}, K_j, K_{j+1}) at σ, in place;
    ``after`` marks the catheter's last segment (the offset tapers to 0 at its tip)."""
    s2 = sigma * sigma
    s3 = s2 * sigma
    w[0] = -1.0
    w1[0] = 0.0
    w2[0] = 0.0
    if before and sigma < 0.0:
        w[1], w[2], w[3], w[4] = 1.0, 0.0, length * sigma, 0.0
        w1[1], w1[2], w1[3], w1[4] = 0.0, 0.0, length, 0.0
        w2[1], w2[2], w2[3], w2[4] = 0.0, 0.0, 0.0, 0.0
        w[5], w[6] = sagitta, 0.0
        w1[5], w1[6] = 0.0, 0.0
        w2[5], w2[6] = 0.0, 0.0
    elif after and sigma > 1.0:
        w[1], w[2], w[3], w[4] = 0.0, 1.0, 0.0, length * (sigma - 1.0)
        w1[1], w1[2], w1[3], w1[4] = 0.0, 0.0, 0.0, length
        w2[1], w2[2], w2[3], w2[4] = 0.0, 0.0, 0.0, 0.0
        w[5], w[6] = 0.0, 0.0
        w1[5], w1[6] = 0.0, 0.0
        w2[5], w2[6] = 0.0, 0.0
    else:
        w[1] = 2.0 * s3 - 3.0 * s2 + 1.0
        w[2] = -2.0 * s3 + 3.0 * s2
        w[3] = length * (s3 - 2.0 * s2 + sigma)
        w[4] = length * (s3 - s2)
        w1[1] = 6.0 * s2 - 6.0 * sigma
        w1[2] = -6.0 * s2 + 6.0 * sigma
        w1[3] = length * (3.0 * s2 - 4.0 * sigma + 1.0)
        w1[4] = length * (3.0 * s2 - 2.0 * sigma)
        w2[1] = 12.0 * sigma - 6.0
        w2[2] = -12.0 * sigma + 6.0
        w2[3] = length * (6.0 * sigma - 4.0)
        w2[4] = length * (6.0 * sigma - 2.0)
        if after:
            # The catheter's last segment: the offset c g(σ) K_j, g = 1 + 2σ − 3σ², falls
            # to 0 at the tip, where the tendon's endpoint is held at no offset.
            w[5] = sagitta * (1.0 + 2.0 * sigma - 3.0 * s2)
            w[6] = 0.0
            w1[5] = sagitta * (2.0 - 6.0 * sigma)
            w1[6] = 0.0
            w2[5] = -6.0 * sagitta
            w2[6] = 0.0
        else:
            w[5] = sagitta * (1.0 - sigma)
            w[6] = sagitta * sigma
            w1[5] = -sagitta
            w1[6] = sagitta
            w2[5] = 0.0
            w2[6] = 0.0


@njit(cache=True)
def _curve(y: np.ndarray, w: np.ndarray, w1: np.ndarray, w2: np.ndarray, delta: np.ndarray,
           slope: np.ndarray, bend: np.ndarray) -> None:
    """Δ = Σ w_b y_b (with w_p = −1), L′ and L″ at the weights, in place."""
    for m in range(3):
        d = 0.0
        s1 = 0.0
        s2 = 0.0
        for b in range(7):
            d += w[b] * y[b, m]
            s1 += w1[b] * y[b, m]
            s2 += w2[b] * y[b, m]
        delta[m] = d
        slope[m] = s1
        bend[m] = s2


@njit(cache=True)
def _tendon_turn(x: np.ndarray, dofs: np.ndarray, e: int, length: float, value: np.ndarray,
                 grad: np.ndarray, unit: np.ndarray, norm: np.ndarray) -> None:
    """K_T = (e₊ − e₋)/l_T from the stencil at local coordinates 21–29, its gradient
    (3, 9) and the chord unit vectors e₊, e₋ and lengths, in place."""
    for side in range(2):  # 0: d₊ = p_{b+1} − p_b, 1: d₋ = p_b − p_{b−1}
        first = 24 if side == 0 else 21
        r2 = 0.0
        for m in range(3):
            d = x[dofs[e, first + 3 + m]] - x[dofs[e, first + m]]
            unit[side, m] = d
            r2 += d * d
        norm[side] = np.sqrt(r2)
        for m in range(3):
            unit[side, m] /= norm[side]
    for m in range(3):
        value[m] = (unit[0, m] - unit[1, m]) / length
        for n in range(3):
            projector_p = ((1.0 if m == n else 0.0) - unit[0, m] * unit[0, n]) / (
                norm[0] * length)
            projector_m = ((1.0 if m == n else 0.0) - unit[1, m] * unit[1, n]) / (
                norm[1] * length)
            grad[m, n] = projector_m
            grad[m, 3 + n] = -projector_p - projector_m
            grad[m, 6 + n] = projector_p


@njit(cache=True)
def _subtract_turn_hessian(g: np.ndarray, length: float, unit: np.ndarray, norm: np.ndarray,
                           local_jacobian: np.ndarray) -> None:
    """local_jacobian[21:30, 21:30] −= ∂²(g·K_T)/∂stencil²: for e = d/r, P = I − e eᵀ,
    ∂²(g·e)/∂d² = −((e·g) P + e (P g)ᵀ + (P g) eᵀ)/r²; d₊ enters K_T with +1, d₋ with −1."""
    pg = np.empty(3)
    block = np.empty((3, 3))
    for side in range(2):
        sign = 1.0 if side == 0 else -1.0
        first = 24 if side == 0 else 21
        along = 0.0
        for m in range(3):
            along += unit[side, m] * g[m]
        for m in range(3):
            pg[m] = g[m] - unit[side, m] * along
        factor = -sign / (norm[side] * norm[side] * length)
        for m in range(3):
            for n in range(3):
                projector = (1.0 if m == n else 0.0) - unit[side, m] * unit[side, n]
                block[m, n] = factor * (along * projector + unit[side, m] * pg[n]
                                        + pg[m] * unit[side, n])
        for m in range(3):
            for n in range(3):
                local_jacobian[first + m, first + n] -= block[m, n]
                local_jacobian[first + 3 + m, first + 3 + n] -= block[m, n]
                local_jacobian[first + m, first + 3 + n] += block[m, n]
                local_jacobian[first + 3 + m, first + n] += block[m, n]


@njit(cache=True)
def _locate(x: np.ndarray, dofs: np.ndarray, e: int, offset: float, length: float,
            ends: np.ndarray, weights: np.ndarray, sagitta: np.ndarray, tendon_length: float,
            corrected: bool, lumen_c: np.ndarray, tangent_c: np.ndarray, s: np.ndarray,
            norm2: np.ndarray, directors: np.ndarray, gradients: np.ndarray, u: np.ndarray,
            u_grad: np.ndarray, t: np.ndarray, t_grad: np.ndarray, turn: np.ndarray,
            turn_grad: np.ndarray, unit: np.ndarray, norm: np.ndarray, y: np.ndarray,
            w: np.ndarray, w1: np.ndarray, w2: np.ndarray, delta: np.ndarray,
            slope: np.ndarray, bend: np.ndarray) -> None:
    """Element ``e``'s node frames, tendon turn, y, the closest point σ and the weights,
    Δ = L(σ) − p, L′ and L″ at σ, all in place (what ``evaluate`` and ``energy``
    share)."""
    for node in range(2):
        for a in range(4):
            value = 0.0
            for slot in range(3):
                value += weights[e, node, slot] * x[dofs[e, 9 + 4 * slot + a]]
            s[node, a] = value
        norm2[node] = raw_directors(s[node], directors[node], gradients[node])
        node_director(s[node], norm2[node], directors[node], gradients[node], lumen_c,
                      u[node], u_grad[node])
        node_director(s[node], norm2[node], directors[node], gradients[node], tangent_c,
                      t[node], t_grad[node])
    if corrected:
        _tendon_turn(x, dofs, e, tendon_length, turn, turn_grad, unit, norm)
    for m in range(3):
        y[5, m] = turn[m]
        y[6, m] = turn[m]
    for m in range(3):
        y[0, m] = x[dofs[e, m]]
        y[1, m] = x[dofs[e, 3 + m]] + offset * u[0, m]
        y[2, m] = x[dofs[e, 6 + m]] + offset * u[1, m]
        y[3, m] = t[0, m]
        y[4, m] = t[1, m]
    # σ by Newton from the projection on the chord.
    ac = 0.0
    cc = 0.0
    for m in range(3):
        chord = y[2, m] - y[1, m]
        ac += (y[0, m] - y[1, m]) * chord
        cc += chord * chord
    sigma = ac / cc
    before = ends[e, 0]
    after = ends[e, 1]
    for _ in range(SIGMA_ITERATIONS):
        hermite(sigma, before, after, length, sagitta[e], w, w1, w2)
        _curve(y, w, w1, w2, delta, slope, bend)
        numerator = 0.0
        denominator = 0.0
        for m in range(3):
            numerator += delta[m] * slope[m]
            denominator += slope[m] * slope[m] + delta[m] * bend[m]
        step = numerator / denominator
        sigma -= step
        if abs(step) < SIGMA_TOLERANCE:
            break
    hermite(sigma, before, after, length, sagitta[e], w, w1, w2)
    _curve(y, w, w1, w2, delta, slope, bend)


@njit(cache=True, inline="always")
def _fill_chain(e: int, offset: float, weights: np.ndarray, u_grad: np.ndarray,
                t_grad: np.ndarray, corrected: bool, turn_grad: np.ndarray,
                chain: np.ndarray) -> None:
    """Element ``e``'s entries of the chain G = ∂y/∂x that depend on the state (the frame
    rows of L_j, L_{j+1}, τ_j, τ_{j+1} on the three quaternion slots; K_j, K_{j+1} on the
    stencil when corrected), in place."""
    for slot in range(3):
        first = 9 + 4 * slot
        for m in range(3):
            for a in range(4):
                chain[3 + m, first + a] = weights[e, 0, slot] * offset * u_grad[0, m, a]
                chain[6 + m, first + a] = weights[e, 1, slot] * offset * u_grad[1, m, a]
                chain[9 + m, first + a] = weights[e, 0, slot] * t_grad[0, m, a]
                chain[12 + m, first + a] = weights[e, 1, slot] * t_grad[1, m, a]
    if corrected:
        for m in range(3):
            for a in range(9):
                chain[15 + m, 21 + a] = turn_grad[m, a]
                chain[18 + m, 21 + a] = turn_grad[m, a]


@njit(cache=True, inline="always")
def _reduced_hessian(k: float, w: np.ndarray, w1: np.ndarray, delta: np.ndarray,
                     slope: np.ndarray, bend: np.ndarray, f_ys: np.ndarray,
                     h_y: np.ndarray) -> None:
    """∇²_y E = f_yy − f_yσ f_yσᵀ / f_σσ (module docstring) into ``h_y``, in place."""
    f_ss = 0.0
    for m in range(3):
        f_ss += slope[m] * slope[m] + delta[m] * bend[m]
    f_ss *= k
    for b in range(7):
        for m in range(3):
            f_ys[3 * b + m] = k * (w1[b] * delta[m] + w[b] * slope[m])
    for b in range(7):
        for m in range(3):
            for c in range(7):
                for n in range(3):
                    value = -f_ys[3 * b + m] * f_ys[3 * c + n] / f_ss
                    if m == n:
                        value += k * w[b] * w[c]
                    h_y[3 * b + m, 3 * c + n] = value


@njit(cache=True, inline="always")
def _pull_back(h_y: np.ndarray, chain: np.ndarray, width: int, product: np.ndarray,
               local_jacobian: np.ndarray) -> None:
    """``local_jacobian`` ← −Gᵀ ∇²_y E G, in place."""
    for i in range(21):
        for a in range(width):
            value = 0.0
            for j in range(21):
                value += h_y[i, j] * chain[j, a]
            product[i, a] = value
    for a in range(width):
        for b in range(width):
            value = 0.0
            for i in range(21):
                value += chain[i, a] * product[i, b]
            local_jacobian[a, b] = -value


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, alpha: float, beta: float, offset: float,
             stiffness: np.ndarray, length: float, ends: np.ndarray, weights: np.ndarray,
             sagitta: np.ndarray, tendon_length: float, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    lumen_c = np.array([alpha, beta, 0.0])
    tangent_c = np.array([0.0, 0.0, 1.0])
    s = np.empty((2, 4))
    norm2 = np.empty(2)
    directors = np.empty((2, 3, 3))
    gradients = np.empty((2, 3, 3, 4))
    u = np.empty((2, 3))
    u_grad = np.empty((2, 3, 4))
    t = np.empty((2, 3))
    t_grad = np.empty((2, 3, 4))
    width = dofs.shape[1]
    corrected = width > 21
    turn = np.zeros(3)
    turn_grad = np.empty((3, 9))
    unit = np.empty((2, 3))
    norm = np.empty(2)
    y = np.empty((7, 3))
    w = np.empty(7)
    w1 = np.empty(7)
    w2 = np.empty(7)
    delta = np.empty(3)
    slope = np.empty(3)
    bend = np.empty(3)
    g = np.empty(21)
    g_k = np.empty(3)
    f_ys = np.empty(21)
    h_y = np.empty((21, 21))
    chain = np.zeros((21, width))
    for m in range(3):
        for block in range(3):
            chain[3 * block + m, 3 * block + m] = 1.0
    product = np.empty((21, width))
    block_h = np.empty((4, 4))
    block_t = np.empty((4, 4))
    scratch = np.empty((4, 4))
    scaled = np.empty(3)
    local_force = np.empty(width)
    local_jacobian = np.empty((width, width))
    for e in range(dofs.shape[0]):
        _locate(x, dofs, e, offset, length, ends, weights, sagitta, tendon_length, corrected,
                lumen_c, tangent_c, s, norm2, directors, gradients, u, u_grad, t, t_grad,
                turn, turn_grad, unit, norm, y, w, w1, w2, delta, slope, bend)
        k = stiffness[e]
        for b in range(7):
            for m in range(3):
                g[3 * b + m] = k * w[b] * delta[m]
        _fill_chain(e, offset, weights, u_grad, t_grad, corrected, turn_grad, chain)
        if want_force:
            for a in range(width):
                value = 0.0
                for i in range(21):
                    value += chain[i, a] * g[i]
                local_force[a] = -value
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            _reduced_hessian(k, w, w1, delta, slope, bend, f_ys, h_y)
            _pull_back(h_y, chain, width, product, local_jacobian)
            for node in range(2):
                node_director_hessian(s[node], norm2[node], lumen_c, u[node], u_grad[node],
                                      g[3 + 3 * node:6 + 3 * node], block_h, scratch, scaled)
                node_director_hessian(s[node], norm2[node], tangent_c, t[node], t_grad[node],
                                      g[9 + 3 * node:12 + 3 * node], block_t, scratch, scaled)
                for i in range(3):
                    for j in range(3):
                        both = weights[e, node, i] * weights[e, node, j]
                        if both != 0.0:
                            for a in range(4):
                                for b in range(4):
                                    local_jacobian[9 + 4 * i + a, 9 + 4 * j + b] -= both * (
                                        offset * block_h[a, b] + block_t[a, b])
            if corrected:
                for m in range(3):
                    g_k[m] = g[15 + m] + g[18 + m]
                _subtract_turn_hessian(g_k, tendon_length, unit, norm, local_jacobian)
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, alpha: float, beta: float, offset: float,
           stiffness: np.ndarray, length: float, ends: np.ndarray, weights: np.ndarray,
           sagitta: np.ndarray, tendon_length: float) -> float:
    """E = Σ_e ½ k_e |Δ_e|², Δ at the closest point σ (the numpy reference:
    ``rodsim.core.terms._lumen_segment.PointOnLumenCurve.energy``)."""
    lumen_c = np.array([alpha, beta, 0.0])
    tangent_c = np.array([0.0, 0.0, 1.0])
    s = np.empty((2, 4))
    norm2 = np.empty(2)
    directors = np.empty((2, 3, 3))
    gradients = np.empty((2, 3, 3, 4))
    u = np.empty((2, 3))
    u_grad = np.empty((2, 3, 4))
    t = np.empty((2, 3))
    t_grad = np.empty((2, 3, 4))
    corrected = dofs.shape[1] > 21
    turn = np.zeros(3)
    turn_grad = np.empty((3, 9))
    unit = np.empty((2, 3))
    norm = np.empty(2)
    y = np.empty((7, 3))
    w = np.empty(7)
    w1 = np.empty(7)
    w2 = np.empty(7)
    delta = np.empty(3)
    slope = np.empty(3)
    bend = np.empty(3)
    total = 0.0
    for e in range(dofs.shape[0]):
        _locate(x, dofs, e, offset, length, ends, weights, sagitta, tendon_length, corrected,
                lumen_c, tangent_c, s, norm2, directors, gradients, u, u_grad, t, t_grad,
                turn, turn_grad, unit, norm, y, w, w1, w2, delta, slope, bend)
        total += 0.5 * stiffness[e] * (delta[0] * delta[0] + delta[1] * delta[1]
                                       + delta[2] * delta[2])
    return total
