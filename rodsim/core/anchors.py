"""Anchors: a point of one rod tied to a point of another (docs/model.md, "Supports and
anchors").

Two kinds use an anchor:

- a tendon's *termination* (``tendon_termination``): the tendon's last node tied to its
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

from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.base_places import BasePlace
from rodsim.core.rod.rod import Rod
from rodsim.core.schema import SceneError, shown
from rodsim.core.supports import Support, node_at, node_exactly_at

__all__ = ["Anchor", "JoinedPlace", "check_joints", "check_tendon_termination", "joined_support",
           "joint_depth", "node_at", "scene_joints", "tendon_termination"]


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
        """Global indices of ``to_segment``'s quaternion (4,)."""
        return self.to.layout.quaternion_index[self.to_segment]


def tendon_termination(tendon: Rod, catheter: Rod) -> Anchor:
    """Where a tendon ends: its last node, tied to its catheter's last node (the tendon has
    its catheter's length, ``check_tendon_termination``)."""
    return Anchor(tendon, tendon.nodes - 1, catheter, catheter.nodes - 1)


def check_tendon_termination(name: str, tendon: Any, host: Any,
                             host_name: str | None = None) -> None:
    """SceneError unless the tendon rod ``name`` (its ``RodOptions`` ``tendon``) can end
    at its catheter's tip (``host``, the rod ``host_name``): equal lengths, to a relative
    1e-9."""
    facts: dict[str, Any] = {
        "key": f"rods.{name}.length", "value": tendon.length, "reason": "cross-table rule",
        "allowed": "the catheter's length",
        "related": (f"rods.{host_name}.length",) if host_name else ()}
    if tendon.length > host.length * (1 + 1e-9):
        raise SceneError(f"rods.{name}.length = {tendon.length!r}: the tendon is longer than "
                         f"its catheter ({host.length!r} m); allowed: equal lengths", **facts)
    if tendon.length < host.length * (1 - 1e-9):
        raise SceneError(f"rods.{name}.length = {tendon.length!r}: the tendon must end at "
                         f"the catheter's tip; allowed: the catheter's length "
                         f"{host.length!r} m", **facts)


def scene_joints(scene: Any) -> dict[str, Any]:
    """The options of the term that joins a rod to another (``Term.joins_rods``: they name
    the other ``rod`` and the arclength ``s`` on it) of every rod of a resolved scene that
    lists one, by rod."""
    out = {}
    for name, table in scene.data["rods"].items():
        for key in table["terms"]:
            if scene.term_type("rods", name, key).joins_rods:
                out[name] = scene.term_options("rods", name, key)
    return out


def joint_depth(rod: str, joints: Mapping[str, Any]) -> int:
    """How many joints separate ``rod`` from a supported rod (0 for a supported rod); the
    model builds rods in this order so that a joined rod's base is placed at its joint."""
    depth = 0
    while rod in joints and depth <= len(joints):
        rod = joints[rod].rod
        depth += 1
    return depth


def joined_support(parent: Rod, s: float) -> Support:
    """The base support of a rod joined at arclength ``s`` of ``parent``: it holds nothing
    (the joint term does), at the parent's rest point there, in the parent's base frame."""
    node = node_at(parent.nodes, parent.length, s)
    return Support("free", parent.rest_positions()[node], parent.base_quaternion)


class JoinedPlace(BasePlace):
    """A rod joined to another (a term that ``joins_rods``): its base at the joint on the
    other rod (``joined_support``), built after it (rodsim/core/base_places.py)."""

    name = "joined"
    precedence = 1

    @classmethod
    def claims(cls, scene: Any, rod: str) -> bool:
        return rod in scene_joints(scene)

    @classmethod
    def parent(cls, scene: Any, rod: str) -> str | None:
        return str(scene_joints(scene)[rod].rod)

    @classmethod
    def order(cls, scene: Any, rod: str) -> tuple[int, int]:
        return (0, joint_depth(rod, scene_joints(scene)))

    @classmethod
    def support(cls, scene: Any, rod: str, rods: Mapping[str, Rod]) -> Support:
        joint = scene_joints(scene)[rod]
        return joined_support(rods[joint.rod], joint.s)


def check_joints(rods: Mapping[str, Mapping[str, Any]], tendons: Collection[str],
                 joiners: Mapping[str, str]) -> None:
    """Cross-check the term that joins each rod to another (``joiners``: its scene key by
    rod, the rods' terms that declare ``Term.joins_rods``) against the scene (resolved
    tables): the rod it names exists, is not itself nor a tendon; ``s`` is on that rod and
    at a node; the joined rod is no tendon and its own base holds nothing
    (``clamp = "free"``); no chain of joints closes on itself. Raises SceneError."""
    joined = {name: rods[name][key] for name, key in joiners.items()}
    for name, joint in joined.items():
        prefix = f"rods.{name}.{joiners[name]}"
        other = joint["rod"]
        if other not in rods:
            raise SceneError(f"{prefix}.rod = {shown(other)}: no such rod; rods: "
                             + ", ".join(rods))
        if other == name:
            raise SceneError(f"{prefix}.rod = {other!r}: a rod cannot be joined to itself")
        if name in tendons or other in tendons:
            which = name if name in tendons else other
            raise SceneError(f"{prefix}: rod {which!r} is a tendon, which is anchored to its "
                             "catheter by its coupling terms; allowed: a joint between "
                             "backbone rods")
        clamp = rods[name]["clamp"]
        if clamp != "free":
            raise SceneError(f"rods.{name}.clamp = {clamp!r}: the base is also held by "
                             f"{prefix} (a support and an anchor at the same point); "
                             "allowed: 'free'")
        if "base" in rods[name] and any(rods[name]["base"].get(k, 0.0) != 0.0
                                        for k in ("insertion", "rotation")):
            raise SceneError(f"rods.{name}.base: a joined rod's base follows its joint; "
                             "allowed: insertion = rotation = 0")
        length, nodes = float(rods[other]["length"]), int(rods[other]["nodes"])
        s = float(joint["s"])
        node_exactly_at(nodes, length, s, f"{prefix}.s", f"rod {other!r}")
        seen, rod = {name}, other
        while rod in joined:
            if rod in seen:
                raise SceneError(f"{prefix}.rod = {other!r}: the joints close a loop "
                                 f"({', '.join(sorted(seen))}) and nothing holds them; "
                                 "allowed: a chain of joints ending at a supported rod")
            seen.add(rod)
            rod = joined[rod]["rod"]
