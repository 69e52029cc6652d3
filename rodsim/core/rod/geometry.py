"""Rest geometry of one discretised rod (paper §2.2, Fig. 3).

``N`` control points ``r_0 … r_{N-1}`` split the rod into ``N−1`` equal segments; each
segment carries one quaternion at its midpoint. Arc length ``s`` is the rest arc length in
metres (docs/design.md, erratum 3: the paper's σ ∈ [0, 1] is replaced by s ∈ [0, L]).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

__all__ = ["RodGeometry"]


@dataclass(frozen=True)
class RodGeometry:
    """Rest lengths and arc-length coordinates of a straight rod with ``nodes`` points.

    Parameters
    ----------
    nodes
        Number of control points N (≥ 3).
    length
        Rest length L [m].
    """

    nodes: int
    length: float

    @property
    def segments(self) -> int:
        """Number of segments (and of quaternions), N − 1."""
        return self.nodes - 1

    @property
    def segment_length(self) -> float:
        """Rest length of one segment, l = L / (N − 1) [m]."""
        return self.length / self.segments

    @property
    def node_s(self) -> np.ndarray:
        """Arc length of every control point [m], shape (N,) (a copy of the one made at
        the first call: each Result's rod shape asks, and np.linspace costs ~5 µs)."""
        return self._node_s.copy()

    @cached_property
    def _node_s(self) -> np.ndarray:
        return np.linspace(0.0, self.length, self.nodes)

    @property
    def segment_s(self) -> np.ndarray:
        """Arc length of every segment midpoint, where the quaternions sit [m], shape (N−1,)."""
        return (np.arange(self.segments) + 0.5) * self.segment_length

    @property
    def node_mass_fraction(self) -> np.ndarray:
        """Length of rod lumped on each control point [m] (half segments at both ends)."""
        share = np.full(self.nodes, self.segment_length)
        share[[0, -1]] *= 0.5
        return share

    def hat_integrals(self, start: float, end: float) -> np.ndarray:
        """∫_start^end N_i(s) ds for every control point i [m], shape (N,): N_i is the hat
        function of the linear interpolation between control points (1 at s_i, 0 at its
        neighbours). A load per length q on [start, end] puts q × this on the control points
        (the consistent share of its virtual work); on [0, L] it equals
        ``node_mass_fraction``."""
        seg = self.segment_length
        left = np.arange(self.segments) * seg
        t0 = np.clip((start - left) / seg, 0.0, 1.0)
        t1 = np.clip((end - left) / seg, 0.0, 1.0)
        t1 = np.maximum(t1, t0)
        second = 0.5 * (t1**2 - t0**2)
        out = np.zeros(self.nodes)
        out[:-1] += seg * ((t1 - t0) - second)
        out[1:] += seg * second
        return out
