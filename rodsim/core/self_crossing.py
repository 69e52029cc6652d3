"""Does a rod's state pass through itself? A cheap check, not self-contact.

rodsim has no self-contact (docs/contact.md, "What is not modelled"): nothing stops a rod
from passing through itself, and an integrator can return such a state as an equilibrium
(CVODE on a contact scene: a 3 mm rod folded with two nodes 0.1 mm apart). This module only
flags it. Two pieces of one rod whose centerlines come closer than one radius overlap by
more than half their thickness: not a state a solid rod can take. Pieces close along the
rod are always near each other, so a pair counts only when its segments lie more than
π r + h apart in arc length (π r: the arc of the tightest hairpin whose legs just touch, a
U-turn of bend radius r; h: a segment of margin).

Method: the segment midpoints in a k-d tree (scipy ``cKDTree``), the pairs whose midpoints
lie within r + h (two segments within r have midpoints within r + h), and for those the
exact distance between the two segments (the closest points of two segments, clamped to
their ends). O(N log N).

A rod of at most ``SCREEN_SEGMENTS`` segments is first screened without the tree: when no
pair of far segments has midpoints within (r + h)(1 + 1e-9) (all pairs at once, O(N²) but
N small), the tree could find none either and the answer is None, without importing
scipy.spatial (~0.06 s of CPU, with scipy.special: docs/benchmarks.md, "Start-up"). Any
closer pair goes through the tree as before, so the answer is the same in every case.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Crossing", "self_crossing", "SCREEN_SEGMENTS"]

#: Rods of at most this many segments are screened pair by pair before the k-d tree.
SCREEN_SEGMENTS = 400


@dataclass(frozen=True)
class Crossing:
    """The closest pair of a rod's segments that pass through each other."""

    first: int
    second: int
    distance: float
    radius: float

    def text(self, rod: str) -> str:
        return (f"rod {rod!r} passes through itself: segments {self.first} and "
                f"{self.second} lie {self.distance:.3g} m apart, less than its radius "
                f"{self.radius:.3g} m (rodsim has no self-contact: the state is not one a "
                "solid rod can take)")


def _segment_distances(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray,
                       b1: np.ndarray) -> np.ndarray:
    """Distances between the segments [a0, a1] and [b0, b1], row by row, (P, 3) each."""
    u, v, w = a1 - a0, b1 - b0, a0 - b0
    a = np.einsum("ij,ij->i", u, u)
    b = np.einsum("ij,ij->i", u, v)
    c = np.einsum("ij,ij->i", v, v)
    d = np.einsum("ij,ij->i", u, w)
    e = np.einsum("ij,ij->i", v, w)
    denominator = a * c - b * b
    tiny = 1e-300
    s = np.where(denominator > 1e-12 * a * c, (b * e - c * d) / np.maximum(denominator, tiny),
                 0.0)
    s = np.clip(s, 0.0, 1.0)
    t = (b * s + e) / np.maximum(c, tiny)
    # t outside [0, 1]: clamp it, and s becomes the closest point to that end.
    s = np.where(t < 0.0, np.clip(-d / np.maximum(a, tiny), 0.0, 1.0),
                 np.where(t > 1.0, np.clip((b - d) / np.maximum(a, tiny), 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    gap = w + s[:, None] * u - t[:, None] * v
    return np.sqrt(np.einsum("ij,ij->i", gap, gap))


def self_crossing(positions: np.ndarray, radius: float) -> Crossing | None:
    """The closest pair of segments of the centerline ``positions`` (N, 3) [m] of a rod of
    ``radius`` [m] that pass through each other (module docstring), or None."""
    points = np.asarray(positions, dtype=float)
    if len(points) < 4 or not np.all(np.isfinite(points)):
        return None
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    h = float(np.max(lengths))
    middle = 0.5 * (points[:-1] + points[1:])
    centre = 0.5 * (arc[:-1] + arc[1:])
    if len(middle) <= SCREEN_SEGMENTS and _clear(middle, centre, radius, h):
        return None
    from scipy.spatial import cKDTree

    pairs = cKDTree(middle).query_pairs(radius + h, output_type="ndarray")
    if len(pairs) == 0:
        return None
    i, j = pairs[:, 0], pairs[:, 1]
    far = np.abs(centre[j] - centre[i]) > math.pi * radius + h
    i, j = i[far], j[far]
    if len(i) == 0:
        return None
    distance = _segment_distances(points[i], points[i + 1], points[j], points[j + 1])
    k = int(np.argmin(distance))
    if distance[k] >= radius:
        return None
    first, second = sorted((int(i[k]), int(j[k])))
    return Crossing(first, second, float(distance[k]), float(radius))


def _clear(middle: np.ndarray, centre: np.ndarray, radius: float, h: float) -> bool:
    """Whether no two segments far apart along the rod (arc distance of their centres above
    π r + h) have midpoints within (r + h)(1 + 1e-9): then no pair the k-d tree returns
    survives the arc-distance filter (the margin covers the tree's own rounding)."""
    far = np.abs(centre[:, None] - centre[None, :]) > math.pi * radius + h
    if not far.any():
        return True
    gaps = middle[:, None, :] - middle[None, :, :]
    distance = np.sqrt(np.einsum("ijk,ijk->ij", gaps, gaps))
    return not bool(np.any(distance[far] <= (radius + h) * (1.0 + 1e-9)))
