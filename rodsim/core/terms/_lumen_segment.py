"""The lumen as a smooth curve through the node lumen points, for the momentum-conserving
lumen penalty (paper Eqs. 24–27, 32–35, with docs/design.md, erratum 13).

**Node frames.** The catheter's quaternions live on its segments (segment j, between nodes j
and j + 1, has q_j). Node j takes the *bisector* frame of the two segments that meet there,

    Q_j = normalise(q_{j−1} + q_j),   Q_0 = normalise(3 q_0 − q_1),
    Q_{N−1} = normalise(3 q_{N−2} − q_{N−3})   (extrapolated to the end nodes),
    L_j = r_j + r_L d_t(Q_j),   τ_j = d3(Q_j),   d_t = α d1 + β d2   (Eqs. 24, 32),

the frame at s_j to second order; q_j alone (the paper's "parent element") is half a segment
off. At the end nodes q_0 and q_{N−2} alone are half a segment off too: the lumen would
leave the catheter's base tilted by half the first segment's turning, and a tendon pulled
out of it would load the base with an O(l) moment error; the linear extrapolation of the
quaternions to s = 0 and s = L is second order and, unlike the clamp's fixed frame, turns
with the state, so the coupling stays free of net moment. Each director is a quadratic form
of the quaternion, so d(Q) = d(s)/|s|² for the weighted sum s of the node's quaternions; for
any director combination v(s) = d(s)/|s|² with forms B_m (d_m = qᵀB_m q):

    ∂v_m/∂s = (2/|s|²)(B_m s − v_m s) =: V_m,
    ∂²v_m/∂s² = (2/|s|²)(B_m − v_m I − s V_mᵀ − V_m sᵀ).

Neighbouring quaternions stay on one hemisphere (q_{j−1}·q_j > 0): the state moves
continuously from the rest state, where they are equal, and a sign change needs a 180° kink.

**The lumen curve.** Between L_j and L_{j+1} the lumen is the cubic Hermite curve with the
node tangents, L(σ) = h00 L_j + h01 L_{j+1} + l̄ (h10 τ_j + h11 τ_{j+1}) (l̄ the catheter's
rest segment length), so the curve is tangent to τ_j at every node: its normal planes — and
so the offset of a point from it — pass continuously from one segment to the next. Beyond
the catheter's ends it goes on straight along τ_0 and τ_{N−1} (where a sliding tendon
leaves the catheter; ``hermite``). A
straight segment between the lumen points would push the tendon at right angles to the
chord rather than to the tendon, which changes the tension by T φ² (½ − σ) at every point
(φ the turning per segment): a first-order error when the points sit off the segments'
middles, as a sliding tendon's do.

**The chord correction.** Both rods are chains of chords, and the two chains measure the
lumen differently: over a catheter segment (chord l_C, fixed by the stretch term) turned by
φ the curve is l_C φ²/24 longer than its chord, and a tendon chord l_T inscribed in the
curve covers l_T φ_T²/24 more curve than its own length. By virtual work the tendon's
moment T r_L is off by T κ (l_T² − l_C²)/12 — 0.8 % of κ at N_T = 10, N_C = 30, and a
dependence on N_T that the paper's Fig. 15 says a model should not have. Offsetting the curve
along its curvature vector by v changes its length by −v·κ per unit length, and a chain of
chords inscribed in it changes by Σ_chords (δ_a + δ_b) sin(φ_chord/2) with δ the offsets of
its ends. So the curve a tendon point is held to is

    M(σ) = L(σ) + c K_T,   c = (l_C² − l_T²)/24,

K_T = (e₊ − e₋)/l_T the curvature vector of the tendon's own chain at the point (e± the
unit vectors of its chords after and before it; at the base point the turn at the next
vertex; ``TendonTurn``; l_C, l_T the rest segment lengths): a chain of l_T chords in M
is as long as a chain of l_C chords in L, whatever N_T. c = 0 when N_T = N_C. On the
catheter's last segment the offset tapers to 0 at the tip, c g(σ) K_T with
g = 1 + 2σ − 3σ² (∫₀¹ g = 1), because the tendon's endpoint is held there by Eqs. (28)–(29)
at no offset (a jump to 0 over one tendon chord would cost δ²/l_T, which grows as l_T
falls); and when the tendon's chords are longer than the catheter's, its last lumen-held
point takes c × 3/2 (``TIP_SHARE``), the share of the chord to the unshifted endpoint
(a chain computed apart, 2-D with a continuous catheter, balances uniform curvature at 1.41
for N_T = 10).

*Why the tendon's turn and not the catheter's curvature.* The offset's virtual work is a
moment on whatever sets K. With the catheter's discrete curvature at the point it is a
moment on the one or two joints next to the point, which dips the catheter's curvature
there (−2 % of κ at N_C = 30, −15 % at 240: the dip's height grows as 1/l_C at a fixed
integral) — and that dip lowers the K the offset is computed from, so the correction
weakened itself as the catheter was refined: N_T = 10 against the arc grew 1.28e-5, 1.65e-5,
2.28e-5, 3.78e-5 L at N_C = 30, 60, 120, 240. The tendon's turn averages over its two
chords, finite in the continuum limit: 4.85e-6, 3.62e-6, 3.27e-6, 3.20e-6 L. The element
then also couples the stencil (p_{b−1}, p_b, p_{b+1}), 30 local coordinates instead of 21;
with c = 0 (N_T = N_C) the stencil is left out and the element is as before. Measured
(tests/test_tendon_convergence.py): with N_C = 30 the tip moves ≤ 4.5e-6 L over
N_T = 10 … 120 (6.5e-4 L without the correction). ``chord_correction = false`` holds the
points on L itself.

**The point on its segment.** A tendon point p registered to lumen segment j is held at its
distance from the curve: σ minimises |L(σ) − p|² (Newton from the chord projection; σ ∈ [0, 1]
when p lies alongside the segment), Δ = L(σ) − p, and

    E = ½ k |Δ|²,   k = K_L w   [N/m],

K_L [N/m²] per unit tendon length and w [m] the point's share of the tendon's rest length.
With f(x, σ) = ½ k |L(σ; x) − p|² and f_σ = 0 at σ, the gradient is f_x (the reaction on the
lumen acts where the tendon touches it) and the Hessian ∇²E = f_xx − f_xσ f_xσᵀ / f_σσ.
(With the chord correction, M in place of L.) In y = (p, L_j, L_{j+1}, τ_j, τ_{j+1},
K_j, K_{j+1}) with weights w = (−1, h00, h01, l̄ h10, l̄ h11, c (1 − σ), c σ):
f_y = k w ⊗ Δ, f_yy = k w wᵀ ⊗ I, f_yσ = k (w′ ⊗ Δ + w ⊗ L′), f_σσ = k (L′·L′ + Δ·L″).

Each element couples (p, r_j, r_{j+1}, q_{j−1}, q_j, q_{j+1}), 21 coordinates (30 with the
tendon stencil of the chord correction); s_j and s_{j+1}
are weighted sums of these three quaternion slots (``node_weights``); at the ends a slot
repeats a segment (the slots' contributions add up).
"""

from __future__ import annotations

import numpy as np

from rodsim.core.rod.quaternion import DIRECTOR_FORMS
from rodsim.core.tendon import Tendon

__all__ = ["PointOnLumenCurve", "TendonTurn", "lumen_nodes", "node_weights", "segment_of",
           "segment_quaternions", "tendon_stencil"]

#: Local coordinates of one element: p, r_j, r_{j+1}, q_{j−1}, q_j, q_{j+1} …
WIDTH = 21
#: … and, when the chord correction is on, the tendon points p_{b−1}, p_b, p_{b+1} whose
#: turn K_T sets the offset (:class:`TendonTurn`).
CORRECTED_WIDTH = 30
#: Newton iterations on σ stop below this step (σ is O(1); quadratic convergence puts σ at
#: round-off then, and a smaller bound would stall on round-off).
SIGMA_TOLERANCE = 1e-12
SIGMA_ITERATIONS = 50
#: The chord correction's share at the tendon's last lumen-held point when l_T > l_C (the
#: chord from it to the endpoint, held at no offset, takes only half of its offset).
TIP_SHARE = 1.5


def segment_quaternions(segment: np.ndarray, segments: int) -> np.ndarray:
    """Segments (j − 1, j, j + 1) whose quaternions orient the ends of ``segment`` j,
    clipped to the rod's ``segments``, shape (n, 3)."""
    segment = np.asarray(segment)
    return np.stack([np.maximum(segment - 1, 0), segment,
                     np.minimum(segment + 1, segments - 1)], axis=1)


def node_weights(segment: np.ndarray, segments: int) -> np.ndarray:
    """Weights of the quaternion slots (q_{j−1}, q_j, q_{j+1}) in the sums s_j and s_{j+1} of
    each element's two nodes, shape (n, 2, 3): (1, 1, 0) and (0, 1, 1) inside; at the base
    node s_0 = 3 q_0 − q_1 (slots q_0, q_0, q_1), at the tip node 3 q_{N−2} − q_{N−3}."""
    segment = np.asarray(segment)
    weights = np.zeros((len(segment), 2, 3))
    weights[:, 0] = (1.0, 1.0, 0.0)
    weights[:, 1] = (0.0, 1.0, 1.0)
    if segments > 1:
        weights[segment == 0, 0] = (0.0, 3.0, -1.0)
        weights[segment == segments - 1, 1] = (-1.0, 3.0, 0.0)
    return weights


def tendon_stencil(points: int) -> np.ndarray:
    """Tendon vertices (b − 1, b, b + 1) whose turn sets the chord correction of each of the
    ``points`` lumen-held points (every tendon point but the endpoint, so the tendon has
    ``points`` + 1): b = i, and b = 1 for the base point, which has no vertex before it.
    Shape (points, 3); needs points ≥ 2."""
    vertex = np.maximum(np.arange(points), 1)
    return np.stack([vertex - 1, vertex, vertex + 1], axis=1)


class TendonTurn:
    """The tendon's discrete curvature vector at a vertex, K_T = (e₊ − e₋)/l_T, from the
    stencil (p_{b−1}, p_b, p_{b+1}) (n, 9), e± the unit vectors along the chords after and
    before p_b and l_T the tendon's rest segment length; its gradient (n, 3, 9) and the
    Hessian of g·K_T (``hessian``). For a unit vector e = d/r (r = |d|) and P = I − e eᵀ:
    ∂e/∂d = P/r and ∂²(g·e)/∂d² = −((e·g) P + e (P g)ᵀ + (P g) eᵀ)/r²."""

    def __init__(self, stencil: np.ndarray, length: float) -> None:
        self.length = length
        before = stencil[:, 3:6] - stencil[:, 0:3]
        after = stencil[:, 6:9] - stencil[:, 3:6]
        self.r = [np.linalg.norm(after, axis=1), np.linalg.norm(before, axis=1)]
        self.e = [after / self.r[0][:, None], before / self.r[1][:, None]]  # e₊, e₋
        self.value = (self.e[0] - self.e[1]) / length
        eye = np.eye(3)[None]
        self.projector = [eye - e[:, :, None] * e[:, None, :] for e in self.e]
        plus = self.projector[0] / (self.r[0] * length)[:, None, None]
        minus = self.projector[1] / (self.r[1] * length)[:, None, None]
        #: ∂K_T/∂(p_{b−1}, p_b, p_{b+1}), shape (n, 3, 9).
        self.grad = np.concatenate([minus, -plus - minus, plus], axis=2)

    def hessian(self, g: np.ndarray) -> np.ndarray:
        """∂²(g·K_T)/∂(p_{b−1}, p_b, p_{b+1})², shape (n, 9, 9)."""
        out = np.zeros((len(g), 9, 9))
        # d₊ = p_{b+1} − p_b enters with sign +1, d₋ = p_b − p_{b−1} with −1 (K_T = (e₊ − e₋)/l).
        for e, projector, r, sign, (first, second) in (
                (self.e[0], self.projector[0], self.r[0], 1.0, (3, 6)),
                (self.e[1], self.projector[1], self.r[1], -1.0, (0, 3))):
            along = np.sum(e * g, axis=1)
            pg = np.einsum("nab,nb->na", projector, g)
            block = -(along[:, None, None] * projector + e[:, :, None] * pg[:, None, :]
                      + pg[:, :, None] * e[:, None, :]) / (r**2)[:, None, None]
            block *= sign / self.length
            # d = p_second − p_first: ∂²/∂p² = [[B, −B], [−B, B]] on (first, second).
            a, b = slice(first, first + 3), slice(second, second + 3)
            out[:, a, a] += block
            out[:, b, b] += block
            out[:, a, b] -= block
            out[:, b, a] -= block
        return out


class NodeDirector:
    """v = d(s)/|s|² for unnormalised quaternion sums s (n, 4) and a director with forms
    B (3, 4, 4); its gradient ``grad`` (n, 3, 4) and weighted Hessian (``hessian``)."""

    def __init__(self, forms: np.ndarray, s: np.ndarray) -> None:
        self.s = s
        self.forms = forms
        self.norm2 = np.sum(s * s, axis=1)
        bs = np.einsum("mab,nb->nma", forms, s)
        self.value = np.einsum("na,nma->nm", s, bs) / self.norm2[:, None]
        self.grad = 2.0 / self.norm2[:, None, None] * (bs - self.value[:, :, None]
                                                       * s[:, None, :])

    def hessian(self, weights: np.ndarray) -> np.ndarray:
        """Σ_m w_m ∂²v_m/∂s² for weights (n, 3), shape (n, 4, 4)."""
        forms = np.einsum("nm,mab->nab", weights, self.forms)
        wv = np.sum(weights * self.value, axis=1)
        wg = np.einsum("nm,nma->na", weights, self.grad)
        outer = self.s[:, :, None] * wg[:, None, :]
        return 2.0 / self.norm2[:, None, None] * (
            forms - wv[:, None, None] * np.eye(4) - outer - outer.transpose(0, 2, 1))


def lumen_forms(tendon: Tendon) -> tuple[np.ndarray, np.ndarray]:
    """Forms of d_t = α d1 + β d2 and of d3."""
    return tendon.alpha * DIRECTOR_FORMS[0] + tendon.beta * DIRECTOR_FORMS[1], DIRECTOR_FORMS[2]


def lumen_nodes(tendon: Tendon, full: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Node lumen points L_j and tangents τ_j with the bisector frames, (N_C, 3) each."""
    catheter = tendon.catheter
    q = full[catheter.layout.quaternion_index]
    nodes = np.arange(catheter.nodes)
    s = q[np.maximum(nodes - 1, 0)] + q[np.minimum(nodes, catheter.nodes - 2)]
    if len(q) > 1:
        s[0] = 3.0 * q[0] - q[1]
        s[-1] = 3.0 * q[-1] - q[-2]
    lumen, tangent = lumen_forms(tendon)
    points = full[catheter.layout.position_index] + tendon.offset * NodeDirector(lumen, s).value
    return points, NodeDirector(tangent, s).value


def segment_of(lumen: np.ndarray, tangent: np.ndarray,
               points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lumen segment each point lies alongside, and the signed distance of every point
    beyond the normal plane of the lumen curve at every interior node.

    The curve's normal plane at L_k (through L_k, normal τ_k) is where the nearest point of
    both segments that meet at L_k is L_k itself, so the offset hands over continuously
    there. A point belongs to segment j when it lies beyond the planes of L_1 … L_j and
    before those of L_{j+1} …; before the first plane it belongs to segment 0, beyond the
    last to segment N − 2. Returns (segment (n,), beyond (n, N − 2)).
    """
    beyond = np.einsum("nkm,km->nk", points[:, None, :] - lumen[None, 1:-1, :], tangent[1:-1])
    return np.sum(beyond >= 0.0, axis=1), beyond


def hermite(sigma: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weights of (L_j, L_{j+1}, τ_j, τ_{j+1}) in L(σ) (τ's without the factor l̄) and their
    first and second σ-derivatives, shape (n, 4) each.

    Hermite's (h00, h01, h10, h11) on the catheter; the lumen goes on straight along the end
    tangent before the first node (σ < 0 on a segment with ``ends[:, 0]``: L_0 + σ l̄ τ_0) and
    after the last (σ > 1 with ``ends[:, 1]``: L_N + (σ − 1) l̄ τ_N), where the tendon leaves
    the catheter: the cubic, extrapolated, would curl away.
    """
    s2, s3 = sigma**2, sigma**3
    # Each column filled by the operations np.stack of the columns took, and the end rows
    # overwritten as np.where chose them (the same numbers, without ~12 array builds per
    # call: this runs in every projection step of the numpy path).
    value, first, second = (np.empty((len(sigma), 4)) for _ in range(3))
    value[:, 0], value[:, 1] = 2 * s3 - 3 * s2 + 1, -2 * s3 + 3 * s2
    value[:, 2], value[:, 3] = s3 - 2 * s2 + sigma, s3 - s2
    first[:, 0], first[:, 1] = 6 * s2 - 6 * sigma, -6 * s2 + 6 * sigma
    first[:, 2], first[:, 3] = 3 * s2 - 4 * sigma + 1, 3 * s2 - 2 * sigma
    second[:, 0], second[:, 1] = 12 * sigma - 6.0, -12 * sigma + 6.0
    second[:, 2], second[:, 3] = 6 * sigma - 4.0, 6 * sigma - 2.0
    before = ends[:, 0] & (sigma < 0.0)
    after = ends[:, 1] & (sigma > 1.0)
    if before.any():
        value[before] = 0.0
        value[before, 0], value[before, 2] = 1.0, sigma[before]
        first[before] = 0.0
        first[before, 2] = 1.0
    if after.any():
        value[after] = 0.0
        value[after, 1], value[after, 3] = 1.0, sigma[after] - 1.0
        first[after] = 0.0
        first[after, 3] = 1.0
    second[before | after] = 0.0
    return value, first, second


class PointOnLumenCurve:
    """E = ½ k |Δ|² of tendon points at their distance from the lumen curve of their
    segment, with gradient and Hessian in the local coordinates
    (p, r_j, r_{j+1}, q_{j−1}, q_j, q_{j+1}) (module docstring)."""

    def __init__(self, tendon: Tendon, local: np.ndarray, stiffness: np.ndarray,
                 segment_length: float, ends: np.ndarray, weights: np.ndarray,
                 sagitta: np.ndarray | None = None, tendon_length: float = 1.0) -> None:
        self.offset = rl = tendon.offset
        self.ends = ends
        self.node_weights = weights
        self.stiffness = stiffness
        self.length = segment_length
        self.width = local.shape[1]
        self.sagitta = np.zeros(len(local)) if sagitta is None else sagitta
        q = local[:, 9:21].reshape(-1, 3, 4)
        sums = np.einsum("nik,nka->nia", weights, q)
        lumen, tangent = lumen_forms(tendon)
        self.directors = [NodeDirector(forms, sums[:, i]) for i in (0, 1)
                          for forms in (lumen, tangent)]  # u_j, τ_j, u_{j+1}, τ_{j+1}
        # The chord correction's curvature: the tendon's turn at its stencil (both K slots).
        self.turn = (TendonTurn(local[:, WIDTH:CORRECTED_WIDTH], tendon_length)
                     if self.width == CORRECTED_WIDTH else None)
        bend = np.zeros((len(local), 3)) if self.turn is None else self.turn.value
        start = local[:, 3:6] + rl * self.directors[0].value
        end = local[:, 6:9] + rl * self.directors[2].value
        # The curve's control vectors, in the order of the weights.
        self.control = np.stack([start, end, self.directors[1].value, self.directors[3].value,
                                 bend, bend], axis=1)
        self.p = local[:, 0:3]
        self.sigma = self._project(end - start)
        self.weights, self.slopes, self.curvatures = self._weights(self.sigma)
        self.delta = np.einsum("nb,nbm->nm", self.weights[:, 1:], self.control) - self.p

    def _weights(self, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """w, w′, w″ of y = (p, L_j, L_{j+1}, τ_j, τ_{j+1}, K_j, K_{j+1}):
        (−1, h00, h01, l̄ h10, l̄ h11, c (1 − σ), c σ), c the chord correction (module
        docstring); on the last segment (c g(σ), 0), beyond the catheter's ends the end
        node's offset (c, 0) before the base and 0 after the tip."""
        scale = np.array([1.0, 1.0, self.length, self.length])
        value, first, second = hermite(sigma, self.ends)
        n = len(sigma)
        c = self.sagitta
        last = self.ends[:, 1]
        before = self.ends[:, 0] & (sigma < 0.0)
        after = last & (sigma > 1.0)
        inside = ~(before | after)
        zero = np.zeros_like(sigma)
        taper = np.where(last, 1.0 + 2.0 * sigma - 3.0 * sigma**2, 1.0 - sigma)
        # Filled column by column with the numbers the stacks and concatenations took.
        w, w1, w2 = (np.empty((n, 7)) for _ in range(3))
        w[:, 0], w1[:, 0], w2[:, 0] = -1.0, 0.0, 0.0
        w[:, 1:5], w1[:, 1:5], w2[:, 1:5] = value * scale, first * scale, second * scale
        w[:, 5] = np.where(before, c, np.where(after, 0.0, c * taper))
        w[:, 6] = np.where(before | after | last, 0.0, c * sigma)
        w1[:, 5] = np.where(inside, c * np.where(last, 2.0 - 6.0 * sigma, -1.0), 0.0)
        w1[:, 6] = np.where(inside & ~last, c, 0.0)
        w2[:, 5], w2[:, 6] = np.where(inside & last, -6.0 * c, 0.0), zero
        return w, w1, w2

    def _project(self, chord: np.ndarray) -> np.ndarray:
        """σ with (L(σ) − p)·L′(σ) = 0, by Newton from the projection on the chord."""
        sigma = (np.sum((self.p - self.control[:, 0]) * chord, axis=1)
                 / np.sum(chord * chord, axis=1))
        for _ in range(SIGMA_ITERATIONS):
            w, w1, w2 = self._weights(sigma)
            delta = np.einsum("nb,nbm->nm", w[:, 1:], self.control) - self.p
            slope = np.einsum("nb,nbm->nm", w1[:, 1:], self.control)
            bend = np.einsum("nb,nbm->nm", w2[:, 1:], self.control)
            step = (np.sum(delta * slope, axis=1)
                    / (np.sum(slope * slope, axis=1) + np.sum(delta * bend, axis=1)))
            sigma = sigma - step
            if np.max(np.abs(step), initial=0.0) < SIGMA_TOLERANCE:
                break
        return sigma

    def energy(self) -> float:
        return float(0.5 * np.sum(self.stiffness * np.sum(self.delta**2, axis=1)))

    def _chain(self) -> np.ndarray:
        """∂y/∂(local coordinates), y = (p, L_j, L_{j+1}, τ_j, τ_{j+1}, K_j, K_{j+1}),
        shape (n, 21, width); both K slots hold the tendon's turn K_T."""
        n, rl = len(self.sigma), self.offset
        chain = np.zeros((n, 21, self.width))
        eye = np.eye(3)
        for block in range(3):
            chain[:, 3 * block:3 * block + 3, 3 * block:3 * block + 3] = eye
        u_start, t_start, u_end, t_end = self.directors
        for rows, director, factor, node in ((slice(3, 6), u_start, rl, 0),
                                             (slice(6, 9), u_end, rl, 1),
                                             (slice(9, 12), t_start, 1.0, 0),
                                             (slice(12, 15), t_end, 1.0, 1)):
            for k in range(3):
                chain[:, rows, 9 + 4 * k:13 + 4 * k] = (
                    factor * self.node_weights[:, node, k, None, None] * director.grad)
        if self.turn is not None:
            chain[:, 15:18, WIDTH:] = self.turn.grad
            chain[:, 18:21, WIDTH:] = self.turn.grad
        return chain

    def _y_gradient(self) -> np.ndarray:
        """f_y = k w ⊗ Δ, shape (n, 21)."""
        k = self.stiffness
        return (k[:, None, None] * self.weights[:, :, None] * self.delta[:, None, :]).reshape(
            len(k), 21)

    def gradient(self) -> np.ndarray:
        """∂E_i/∂(local coordinates), shape (n, width)."""
        return np.einsum("nya,ny->na", self._chain(), self._y_gradient())

    def hessian(self) -> np.ndarray:
        """∂²E_i/∂(local coordinates)², shape (n, width, width)."""
        k = self.stiffness
        n = len(k)
        w, w1, w2 = self.weights, self.slopes, self.curvatures
        slope = np.einsum("nb,nbm->nm", w1[:, 1:], self.control)
        bend = np.einsum("nb,nbm->nm", w2[:, 1:], self.control)
        f_yy = (k[:, None, None, None, None] * w[:, :, None, None, None] * w[:, None, None, :, None]
                * np.eye(3)[None, None, :, None, :]).reshape(n, 21, 21)
        f_ys = (k[:, None, None] * (w1[:, :, None] * self.delta[:, None, :]
                                    + w[:, :, None] * slope[:, None, :])).reshape(n, 21)
        f_ss = k * (np.sum(slope * slope, axis=1) + np.sum(self.delta * bend, axis=1))
        h_y = f_yy - f_ys[:, :, None] * f_ys[:, None, :] / f_ss[:, None, None]
        chain = self._chain()
        hess = np.einsum("nya,nyz,nzb->nab", chain, h_y, chain)
        g_y = self._y_gradient()
        rl = self.offset
        u_start, t_start, u_end, t_end = self.directors
        for node, u, t, g_u, g_t in ((0, u_start, t_start, g_y[:, 3:6], g_y[:, 9:12]),
                                     (1, u_end, t_end, g_y[:, 6:9], g_y[:, 12:15])):
            block = rl * u.hessian(g_u) + t.hessian(g_t)
            w = self.node_weights[:, node]
            for i in range(3):
                for j in range(3):
                    hess[:, 9 + 4 * i:13 + 4 * i, 9 + 4 * j:13 + 4 * j] += (
                        (w[:, i] * w[:, j])[:, None, None] * block)
        if self.turn is not None:
            hess[:, WIDTH:, WIDTH:] += self.turn.hessian(g_y[:, 15:18] + g_y[:, 18:21])
        return hess
