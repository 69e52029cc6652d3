"""The lumen terms' registration rule (§4.1; rodsim/core/terms/lumen.py) compiled: which
tendon points switch parent at a state, for both couplings.

The numpy methods ``_switches`` of ``rodsim.core.terms.lumen.Lumen`` (nearest lumen
point, paper coupling) and ``rodsim.core.terms.lumen_conserving.ConservingLumen`` (the
lumen segment a point lies alongside, from the normal planes of the lumen curve at the
interior nodes) are the reference. Registration is a discrete choice: it must pick the same
parents as the reference, not merely close numbers. The kernels compute the same quantities
(distances, signed distances beyond the planes) in another order of operations, so they
differ from the reference by round-off; wherever a comparison that decides a parent lies
within ``TIE`` × the coordinates' magnitude of its threshold, a kernel answers
``UNDECIDED`` and the term applies the numpy rule instead (a point exactly on a plane,
the rest state of a tendon with the catheter's node count). Away from such ties both
decide every comparison alike. tests/test_kernels.py compares the two.

Each kernel writes every point's new parent into ``out`` and returns ``UNCHANGED``,
``CHANGED`` or ``UNDECIDED``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._quaternion import _FORMS

__all__ = ["CHANGED", "TIE", "UNCHANGED", "UNDECIDED", "nearest_node_switches",
           "segment_switches"]

#: No point changes parent.
UNCHANGED = 0
#: Some point changes parent (``out`` holds the new parents).
CHANGED = 1
#: A deciding comparison lies within round-off of its threshold: apply the numpy rule.
UNDECIDED = 2
#: A comparison is undecided within this fraction of the largest coordinate magnitude
#: involved (the kernels' values differ from the reference's by a few 1e-16 of it).
TIE = 1e-12


@njit(cache=True)
def _director(q: np.ndarray, alpha: float, beta: float, gamma: float, out: np.ndarray) -> float:
    """out ← qᵀ(α A[0] + β A[1] + γ A[2])q (3,), unnormalised; returns |q|²."""
    for m in range(3):
        value = 0.0
        for i in range(4):
            row = 0.0
            for j in range(4):
                row += (alpha * _FORMS[0, m, i, j] + beta * _FORMS[1, m, i, j]
                        + gamma * _FORMS[2, m, i, j]) * q[j]
            value += q[i] * row
        out[m] = value
    norm2 = 0.0
    for a in range(4):
        norm2 += q[a] * q[a]
    return norm2


@njit(cache=True)
def _tie(x: np.ndarray, points: np.ndarray, magnitude: float) -> float:
    """TIE times the largest of ``magnitude`` (the lumen's coordinates and offset) and the
    held points' coordinates: a deciding comparison within it is left to the numpy rule."""
    for i in range(points.shape[0]):
        for m in range(3):
            magnitude = max(magnitude, abs(x[points[i, m]]))
    return TIE * magnitude


@njit(cache=True)
def segment_switches(x: np.ndarray, position_index: np.ndarray, quaternion_index: np.ndarray,
                     points: np.ndarray, alpha: float, beta: float, offset: float,
                     parent: np.ndarray, margin: float, out: np.ndarray) -> int:
    """The conserving coupling's rule (``ConservingLumen._switches``): the catheter's node
    positions ``position_index`` (N, 3) and segment quaternions ``quaternion_index``
    (N − 1, 4), the held tendon points ``points`` (P, 3) (indices into the full state ``x``),
    d_t = α d1 + β d2 at offset r_L. Interior node k (1 … N − 2) has the bisector frame of
    s = q_{k−1} + q_k: L_k = r_k + r_L d_t(s)/|s|², τ_k = d3(s)/|s|²; a point's segment is
    the number of planes (L_k, τ_k) it lies on or beyond, and it switches to it when it lies
    beyond its segment's far plane or before its near one by ``margin``."""
    nodes = position_index.shape[0]
    planes = nodes - 2
    lumen = np.empty((max(planes, 0), 3))
    tangent = np.empty((max(planes, 0), 3))
    s = np.empty(4)
    d = np.empty(3)
    magnitude = abs(offset)
    for k in range(planes):
        for a in range(4):
            s[a] = x[quaternion_index[k, a]] + x[quaternion_index[k + 1, a]]
        norm2 = _director(s, alpha, beta, 0.0, d)
        for m in range(3):
            r = x[position_index[k + 1, m]]
            lumen[k, m] = r + offset * (d[m] / norm2)
            magnitude = max(magnitude, abs(r))
        _director(s, 0.0, 0.0, 1.0, d)
        for m in range(3):
            tangent[k, m] = d[m] / norm2
    tie = _tie(x, points, magnitude)
    beyond = np.empty(max(planes, 0))
    changed = False
    for i in range(points.shape[0]):
        nearest = 0
        for k in range(planes):
            value = 0.0
            for m in range(3):
                value += (x[points[i, m]] - lumen[k, m]) * tangent[k, m]
            if not np.isfinite(value) or abs(value) <= tie:
                return UNDECIDED
            beyond[k] = value
            if value >= 0.0:
                nearest += 1
        own = parent[i]
        out[i] = own
        if nearest == own:
            continue
        switch = False
        if own < planes:  # the far plane, node own + 1
            far = beyond[own]
            if abs(far - margin) <= tie:
                return UNDECIDED
            switch = far > margin
        if own >= 1:  # the near plane, node own
            near = beyond[own - 1]
            if abs(near + margin) <= tie:
                return UNDECIDED
            switch = switch or near < -margin
        if switch:
            out[i] = nearest
            changed = True
    return CHANGED if changed else UNCHANGED


@njit(cache=True)
def nearest_node_switches(x: np.ndarray, position_index: np.ndarray,
                          quaternion_index: np.ndarray, points: np.ndarray, alpha: float,
                          beta: float, offset: float, parent: np.ndarray, margin: float,
                          out: np.ndarray) -> int:
    """The paper coupling's rule (``Lumen._switches``): the lumen point of catheter node j is
    L_j = r_j + r_L d_t(q_{min(j, N − 2)}) (``Tendon.lumen_points``); a point switches to
    its nearest lumen point (the first of equal ones) when that is closer than its parent's
    by ``margin``."""
    nodes = position_index.shape[0]
    lumen = np.empty((nodes, 3))
    d = np.empty(3)
    q = np.empty(4)
    magnitude = abs(offset)
    for j in range(nodes):
        segment = min(j, nodes - 2)
        for a in range(4):
            q[a] = x[quaternion_index[segment, a]]
        _director(q, alpha, beta, 0.0, d)
        for m in range(3):
            r = x[position_index[j, m]]
            lumen[j, m] = r + offset * d[m]
            magnitude = max(magnitude, abs(r))
    tie = _tie(x, points, magnitude)
    distance = np.empty(nodes)
    changed = False
    for i in range(points.shape[0]):
        nearest = 0
        for j in range(nodes):
            square = 0.0
            for m in range(3):
                delta = lumen[j, m] - x[points[i, m]]
                square += delta * delta
            value = np.sqrt(square)
            if not np.isfinite(value):
                return UNDECIDED
            distance[j] = value
            if value < distance[nearest]:
                nearest = j
        for j in range(nodes):  # the nearest must be nearest by more than round-off
            if j != nearest and distance[j] - distance[nearest] <= tie:
                return UNDECIDED
        own = parent[i]
        out[i] = own
        if nearest == own:
            continue
        gap = distance[own] - margin - distance[nearest]
        if abs(gap) <= tie:
            return UNDECIDED
        if gap > 0.0:
            out[i] = nearest
            changed = True
    return CHANGED if changed else UNCHANGED
