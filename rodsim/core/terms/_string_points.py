"""The routing points of a string tendon (rodsim/core/terms/tendon_string.py): where the
polygon of its path runs on the catheter, and the points' positions with their derivatives
in the points' coordinates.

Discretisation (the catheter has N nodes r_j, segment length h, quaternion q_j at the
segment midpoint s_j = (j + ½) h): the path is the polygon through

- the entry point at s = start, every node s_j = j h with start + h/4 < s_j < end − h/4,
  every section boundary inside the span where G J changes (unless it lies on a node, the
  entry or the termination, within ``JUMP_AT_NODE`` h) and the termination point at
  s = end. The twist rate jumps with G J, so the continuum path kinks there: a point of its
  own puts the kink's load where it acts (without it, a boundary inside a segment had the
  kink cut by the chord between two nodes, order 1.72, 1.41 at N = 31 → 121 → 481 with the
  boundary a third of a segment past a node; with it 2.01, 2.07, tests/test_robots.py);
- each point p(σ) = (1 − t) r_m + t r_{m+1} + R(q̂(σ)) ρ(σ): the centerline interpolated
  on the segment m holding σ, plus the body-frame offset ρ = (ρ_y, ρ_z) of the routing
  (rodsim/core/routing.py), R(q̂) ρ = (ρ_y d1(q) + ρ_z d2(q)) / |q|² (Eq. 2, normalised);
- q(σ) is interpolated linearly between the frame knots — the base frame at s = 0 (clamps
  'frame' and 'orientation') and the segment midpoints — and held constant beyond the last
  knot (and before the first without a base frame); at a node it is ½ (q_{j−1} + q_j).
  This follows the rod's own discrete kinematics: its bending elements sit between
  consecutive knots, so the half segment past the last midpoint turns rigidly with q_{N−2}.
  On a rod with sections, "linearly" is in the twist compliance ∫ 1/(G J) ds between the
  two knots (rodsim/core/rod/sections.py, ``compliance_fraction``): where G J jumps at a
  node, the element's twist is not shared half and half, and the weight ½ put the node's
  routing point O(h) off the continuum path, whose kink there then fell at the wrong
  place: order 1.68, 1.46, 1.24 at N = 41 → 321 on catheter-pull-ring's tip moment,
  1.94, 1.97, 1.99 with the compliance weight (issue 20). It reads G J of the spans (the
  'corrected' tensor of Eq. 8) even where bend_twist uses CORDE's tensor or a
  twist_stiffness override (sections with those have no reference to check against).

Measured against the Rucker–Webster reference (tests/test_string_tendon.py; tip error / L
on the 0.2 m benchmark backbone at N = 21 → 81, all second order unless said):

| choice | one tendon, 3 N, to the tip | two tendons, one ending at 0.12 m |
|---|---|---|
| points at the segment midpoints ½ (r_j + r_{j+1}) | 2.8e-3 → 1.8e-4 | 3.2e-3 → 2.1e-4 |
| points at the nodes, frame extrapolated past the last knot | 7.4e-4 → 4.6e-5 | 7.5e-4 → 4.7e-5 |
| points at the nodes, frame held past the last knot (this) | 3.6e-5 → 2.3e-6 | 1.1e-5 → 7.2e-7 |
| the segment's own frame at entry and termination | 3.6e-5 → 2.3e-6 | 3.9e-3 → 9.8e-4, order 1 |

(the midpoints sit a sagitta κ h²/8 inside the bent centerline; the segment's own frame puts
a part-way termination's moment arm up to half a segment off).

A point's coordinates are r_m, r_{m+1} and the two knot quaternions Q_0, Q_1 (``POINT_SIZE``);
with q = w_0 Q_0 + w_1 Q_1 + q_c, n = |q|², g_m = qᵀ G_m q, G_m = ρ_y A[0, m] + ρ_z A[1, m]:
p = c_0 r_m + c_1 r_{m+1} + g / n, ∂p/∂q = 2 G q / n − 2 g qᵀ / n² and
∇²f_m = 2G_m/n − 4(G_m q qᵀ + q qᵀ G_m)/n² − 2 g_m I/n² + 8 g_m q qᵀ/n³ (``point_geometry``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rodsim.core.rod.quaternion import DIRECTOR_FORMS
from rodsim.core.routing import Routing
from rodsim.core.tendon import Tendon

#: A change of G J closer than this fraction of a segment to a node (or to the tendon's entry
#: or termination) is taken there: no routing point of its own.
JUMP_AT_NODE = 1e-6

#: Local coordinates of one routing point: r_m, r_{m+1}, the two knot quaternions.
POINT_SIZE = 14


class RoutingPoints(NamedTuple):
    """The routing points of a string tendon (P points), fixed when the term is built."""

    #: Arc length of each point [m], (P,).
    s: np.ndarray
    #: Full-state indices of (r_m, r_{m+1}, Q_0, Q_1), (P, 14).
    dofs: np.ndarray
    #: (1 − t, t, w_0, w_1): weights of the two nodes and of the two knot quaternions, (P, 4).
    weights: np.ndarray
    #: Constant part of q (the base frame's share), (P, 4).
    constant: np.ndarray
    #: Body-frame offset ρ, (P, 2) [m].
    offset: np.ndarray


def routing_points(tendon: Tendon, routing: Routing, start: float,
                   end: float) -> RoutingPoints:
    """The routing points of a string tendon on ``tendon.catheter`` (module docstring)."""
    rod = tendon.catheter
    nodes, h = rod.nodes, rod.geometry.segment_length
    mid = rod.geometry.segment_s
    node_s = rod.geometry.node_s
    inner = np.flatnonzero((node_s > start + 0.25 * h) & (node_s < end - 0.25 * h))
    profile = rod.profile
    jumps = np.zeros(0)
    if profile is not None:  # where G J changes off a node: a point of its own (docstring)
        jumps = profile.changes(profile.shear_modulus * profile.polar_moment)
        taken = np.concatenate([[start, end], node_s])
        jumps = jumps[(jumps > start) & (jumps < end) & (np.min(
            np.abs(jumps[:, None] - taken[None, :]), axis=1) > JUMP_AT_NODE * h)]
    s = np.concatenate([[start], node_s[inner], jumps, [end]])
    at_node = np.zeros(len(s), dtype=bool)
    at_node[1:1 + len(inner)] = True
    order = np.argsort(s, kind="stable")
    s, at_node = s[order], at_node[order]
    segment = np.minimum(np.floor(s / h).astype(int), nodes - 2)
    segment[at_node] = inner
    t = s / h - segment
    t[at_node] = 0.0
    base = rod.support.frame_element
    knots = np.concatenate([[0.0], mid]) if base else mid
    k = np.clip(np.searchsorted(knots, s, side="right") - 1, 0, len(knots) - 2)
    if profile is None:
        w = np.clip((s - knots[k]) / (knots[k + 1] - knots[k]), 0.0, 1.0)
    else:  # in the twist compliance: not ½ at a node where G J jumps (module docstring)
        w = profile.compliance_fraction(profile.shear_modulus * profile.polar_moment,
                                        knots[k], s, knots[k + 1])
    quat = rod.layout.quaternion_index
    pos = rod.layout.position_index
    # Knot i is segment i − 1 with a base frame (knot 0 is the constant base frame).
    first = k - 1 if base else k
    second = k if base else k + 1
    constant = np.zeros((len(s), 4))
    weights = np.stack([1.0 - t, t, 1.0 - w, w], axis=1)
    if base:
        at_base = first < 0
        constant[at_base] = weights[at_base, 2:3] * rod.base_quaternion
        weights[at_base, 2] = 0.0
        first = np.maximum(first, 0)
    dofs = np.concatenate([pos[segment], pos[segment + 1], quat[first], quat[second]],
                          axis=1)
    return RoutingPoints(s, dofs, weights, constant, routing.offsets(s))


class PointGeometry(NamedTuple):
    """Positions of the routing points and their derivatives in the points' coordinates."""

    #: p, (P, 3).
    p: np.ndarray
    #: ∂p/∂x_point, (P, 3, 14).
    jac: np.ndarray
    #: ∇²f_m with respect to q, (P, 3, 4, 4).
    hess: np.ndarray


def point_geometry(points: RoutingPoints, forms: np.ndarray, x: np.ndarray,
                   derivatives: bool = True) -> PointGeometry:
    """p of every routing point at the full state ``x`` and, with ``derivatives``,
    ∂p/∂x_point and ∇²f (else empty arrays); ``forms`` are the points' G_m, (P, 3, 4, 4)."""
    pts = points
    local = x[pts.dofs]
    c0, c1, w0, w1 = pts.weights.T
    q = w0[:, None] * local[:, 6:10] + w1[:, None] * local[:, 10:14] + pts.constant
    n = np.einsum("pi,pi->p", q, q)
    gq = np.einsum("pmij,pj->pmi", forms, q)  # G_m q
    g = np.einsum("pmi,pi->pm", gq, q)
    p = (c0[:, None] * local[:, 0:3] + c1[:, None] * local[:, 3:6]
         + g / n[:, None])
    if not derivatives:
        return PointGeometry(p, np.empty(0), np.empty(0))
    grad = 2.0 * gq / n[:, None, None] - 2.0 * g[:, :, None] * q[:, None, :] / (
        n**2)[:, None, None]
    jac = np.zeros((len(n), 3, POINT_SIZE))
    eye = np.eye(3)
    jac[:, :, 0:3] = c0[:, None, None] * eye
    jac[:, :, 3:6] = c1[:, None, None] * eye
    jac[:, :, 6:10] = w0[:, None, None] * grad
    jac[:, :, 10:14] = w1[:, None, None] * grad
    qq = q[:, :, None] * q[:, None, :]
    gqq = gq[:, :, :, None] * q[:, None, None, :]
    hess = (2.0 * forms / n[:, None, None, None]
            - 4.0 * (gqq + gqq.transpose(0, 1, 3, 2)) / (n**2)[:, None, None, None]
            - 2.0 * g[:, :, None, None] * np.eye(4) / (n**2)[:, None, None, None]
            + 8.0 * g[:, :, None, None] * qq[:, None] / (n**3)[:, None, None, None])
    return PointGeometry(p, jac, hess)


def point_forms(points: RoutingPoints) -> np.ndarray:
    """G_m = ρ_y A[0, m] + ρ_z A[1, m] of every point (A the director forms of Eq. 2),
    (P, 3, 4, 4)."""
    return np.einsum("pa,amij->pmij", points.offset, DIRECTOR_FORMS[:2])


def entry_directions(points: RoutingPoints, slope: np.ndarray,
                     x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(d3, t_in) at the entry point (the first) at the full state ``x``: the catheter's
    axis and the path's tangent t_in ∝ d3 + ρ′_y d1 + ρ′_z d2, ρ′ = ``slope`` (2,)."""
    local = x[points.dofs[0]]
    _, _, w0, w1 = points.weights[0]
    q = w0 * local[6:10] + w1 * local[10:14] + points.constant[0]
    d = np.einsum("i,kmij,j->km", q, DIRECTOR_FORMS, q) / float(q @ q)
    tangent = d[2] + slope[0] * d[0] + slope[1] * d[1]
    return d[2], tangent / np.linalg.norm(tangent)


def entry_jacobian(points: RoutingPoints, slope: np.ndarray, x: np.ndarray) -> np.ndarray:
    """∂d3/∂x and ∂t_in/∂x (2, 3, 28) on the first chord's coordinates (the entry point's
    knot quaternions, columns 6 … 13) at the full state ``x``: d_k[m] = qᵀ A_km q / |q|²
    has ∂d_k[m]/∂q = 2 (A_km q − d_k[m] q)/|q|², and t_in = a/|a|, a = d3 + ρ′_y d1 + ρ′_z d2
    (``entry_directions``); zero where the entry's frame is held."""
    out = np.zeros((2, 3, 28))
    _, _, w0, w1 = points.weights[0]
    if w0 == 0.0 and w1 == 0.0:
        return out
    local = x[points.dofs[0]]
    q = w0 * local[6:10] + w1 * local[10:14] + points.constant[0]
    n = float(q @ q)
    forms_q = np.einsum("kmij,j->kmi", DIRECTOR_FORMS, q)
    d = forms_q @ q / n
    dq = 2.0 * (forms_q - d[:, :, None] * q[None, None, :]) / n  # (3, 3, 4)
    raw = d[2] + slope[0] * d[0] + slope[1] * d[1]
    size = float(np.linalg.norm(raw))
    tangent = raw / size
    d_raw = dq[2] + slope[0] * dq[0] + slope[1] * dq[1]
    d_tangent = (d_raw - np.outer(tangent, tangent @ d_raw)) / size
    for which, gradient in enumerate((dq[2], d_tangent)):
        out[which, :, 6:10] = w0 * gradient
        out[which, :, 10:14] = w1 * gradient
    return out
