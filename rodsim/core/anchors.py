"""Anchors: a point of one rod tied to a point of another (docs/model.md, "Supports and
anchors").

Two kinds use an anchor:

- a tendon's *termination* (:func:`tendon_termination`): the tendon's last node tied to its
  catheter's node where the tendon ends. The coupling terms that hold the tendon there
  (endpoint compliance Eq. 28, endpoint coupling Eq. 29), the distal actuation (§4.3) and
  the lumen terms (every tendon point before the termination is on the lumen, whose last
  node is the termination's) read the two nodes and the segment orienting the catheter's
  point from the anchor, and from nowhere else;
- a *joint* between two backbone rods (rodsim/core/terms/joint.py): a rod's base tied to a
  node of another rod, in position and, if asked, in orientation.

Nodes are indices of control points; ``rod`` is the anchored rod, ``to`` the rod it is tied
to.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.schema import SceneError

__all__ = ["Anchor", "check_tendon_termination", "tendon_termination"]


@dataclass(frozen=True)
class Anchor:
    """Node ``node`` of rod ``rod`` tied to node ``to_node`` of rod ``to``."""

    rod: Rod
    node: int
    to: Rod
    to_node: int

    @property
    def position_index(self) -> np.ndarray:
        """Global indices of the anchored point r (3,)."""
        return self.rod.layout.position_index[self.node]

    @property
    def to_position_index(self) -> np.ndarray:
        """Global indices of the point it is tied to (3,)."""
        return self.to.layout.position_index[self.to_node]

    @property
    def to_segment(self) -> int:
        """The segment of ``to`` whose quaternion orients the tied point (the segment that
        starts at ``to_node``; the last segment at the last node)."""
        return min(self.to_node, self.to.nodes - 2)

    @property
    def to_quaternion_index(self) -> np.ndarray:
        """Global indices of :attr:`to_segment`'s quaternion (4,)."""
        return self.to.layout.quaternion_index[self.to_segment]


def tendon_termination(tendon: Rod, catheter: Rod) -> Anchor:
    """Where a tendon ends: its last node, tied to its catheter's last node (the tendon has
    its catheter's length, :func:`check_tendon_termination`)."""
    return Anchor(tendon, tendon.nodes - 1, catheter, catheter.nodes - 1)


def check_tendon_termination(name: str, tendon: Any, host: Any) -> None:
    """SceneError unless the tendon rod ``name`` (its :data:`RodOptions` ``tendon``) can end
    at its catheter's tip (``host``): equal lengths, to a relative 1e-9."""
    if tendon.length > host.length * (1 + 1e-9):
        raise SceneError(f"rods.{name}.length = {tendon.length!r}: the tendon is longer than "
                         f"its catheter ({host.length!r} m); allowed: equal lengths")
    if tendon.length < host.length * (1 - 1e-9):
        raise SceneError(f"rods.{name}.length = {tendon.length!r}: the tendon must end at "
                         f"the catheter's tip; allowed: the catheter's length "
                         f"{host.length!r} m")
