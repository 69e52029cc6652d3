"""Where each rod's coordinates sit in the global state vector (paper Eqs. 18 and 30).

A rod with N control points owns ``7N − 4`` consecutive coordinates, interleaved as in
Eq. (18) — ``r_0, q_0, r_1, q_1, …, q_{N-2}, r_{N-1}`` — so every energy term couples only
coordinates a few places apart and the Jacobian is banded (Eq. 20). Several rods are
concatenated (Eq. 30); the model may reorder the free coordinates afterwards to keep the
system banded when rods are coupled.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

__all__ = ["RodLayout", "COORDS_PER_NODE"]

#: Three position coordinates plus four quaternion coordinates per control point (Eq. 18).
COORDS_PER_NODE = 7


@dataclass(frozen=True)
class RodLayout:
    """Global indices of one rod's coordinates.

    Parameters
    ----------
    nodes
        Number of control points N.
    offset
        Index of the rod's first coordinate in the global state.
    """

    nodes: int
    offset: int = 0

    @property
    def size(self) -> int:
        """Number of coordinates of the rod, 3N + 4(N − 1)."""
        return COORDS_PER_NODE * self.nodes - 4

    @cached_property
    def position_index(self) -> np.ndarray:
        """Indices of the positions, shape (N, 3)."""
        base = self.offset + COORDS_PER_NODE * np.arange(self.nodes)
        return base[:, None] + np.arange(3)

    @cached_property
    def quaternion_index(self) -> np.ndarray:
        """Indices of the segment quaternions, shape (N − 1, 4)."""
        base = self.offset + COORDS_PER_NODE * np.arange(self.nodes - 1) + 3
        return base[:, None] + np.arange(4)
