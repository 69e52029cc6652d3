"""Programs on supports: a rod's base insertion and rotation and a node support's
displacement as functions of physical time (issue 33 item 2; docs/dynamics.md, "Moving
supports"): which keys they are, what is refused before any work, and the supports'
velocity at a time from the programs' exact derivatives (``Table.rate``,
``Sinusoid.rate``) for the midpoint rule (rodsim/solvers/physical/moving_supports.py).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey
from rodsim.core.anchors import scene_joints
from rodsim.core.model import Model
from rodsim.core.program import ProgramEntry
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.core.supports import node_at
from rodsim.solvers.physical.moving_supports import RigidMotion, SupportVelocity

__all__ = ["is_support_key", "check_support_programs", "SupportPrograms"]

#: The base values a program may move.
BASE_KEYS = ("insertion", "rotation")


def is_support_key(parts: Sequence[str]) -> bool | None:
    """For a key's dotted path ``parts``: None when it is no support's value, True for a
    base's insertion or rotation or a node support's displacement (programs may move
    them), False for another support value."""
    if parts[0] != "rods" or len(parts) < 3 or parts[2] not in ("base", "supports"):
        return None
    return ((len(parts) == 4 and parts[2] == "base" and parts[3] in BASE_KEYS)
            or (len(parts) == 5 and parts[2] == "supports" and parts[4] == "displacement"))


def check_support_programs(scene: Scene, keys: Sequence[NumericKey], integrator: str,
                           path_dependent: bool) -> None:
    """SceneError (one line) for a support program the run cannot take: an integrator
    other than the midpoint rule, a rod whose base holds nothing (clamp ``free``), or a
    scene where a rod follows another's base (a tendon rod, a joint) or has friction
    (``path_dependent``: a string tendon's or a contact's)."""
    moved = [key for key in keys if is_support_key(key.path.split("."))]
    if not moved:
        return
    name = moved[0].name
    if path_dependent:
        raise SceneError(f"program {name}: a moving support with friction (a string "
                         "tendon's or a contact's) is not in this version")
    if integrator != "midpoint":
        raise SceneError(f"program {name}: a moving support is only for integrator "
                         f"'midpoint' (not {integrator!r}); allowed: integrator='midpoint'")
    followers = [rod for rod in scene.rods if rod in scene.data["tendons"]]
    followers += list(scene_joints(scene))
    if followers:
        raise SceneError(f"program {name}: rod {followers[0]!r} follows another rod's "
                         "support (a tendon rod or a joint); a moving support is only for "
                         "scenes without them in this version")
    for key in moved:
        rod = key.path.split(".")[1]
        if scene.rods[rod].clamp == "free":
            raise SceneError(f"program {key.name}: rod {rod!r} has clamp 'free' (its base "
                             "holds nothing); allowed: a base that holds the rod")


class SupportPrograms:
    """The supports' velocity at a time (``at``) from the checked programs ``keys`` and
    ``entries`` of ``model``'s scene; ``active`` False when no program moves a support."""

    def __init__(self, model: Model, keys: Sequence[NumericKey],
                 entries: Sequence[ProgramEntry]) -> None:
        self.model = model
        #: (rod, insertion entry or None, rotation entry or None) of every moved base.
        bases: dict[str, dict[str, ProgramEntry]] = {}
        #: (full-state index of the held coordinate, entry) of every moved node support.
        self.nodes: list[tuple[int, ProgramEntry]] = []
        scene = model.scene
        for key, entry in zip(keys, entries, strict=True):
            parts = key.path.split(".")
            if not is_support_key(parts):
                continue
            rod = model.rods[parts[1]]
            if parts[2] == "base":
                bases.setdefault(parts[1], {})[parts[3]] = entry
                continue
            s = float(scene.support_tables(parts[1])[parts[3]]["s"])
            node = node_at(rod.options.nodes, rod.options.length, s)
            assert key.index is not None  # a vector's component (numeric_key)
            self.nodes.append((int(rod.layout.position_index[node, key.index]), entry))
        self.bases = bases
        self.active = bool(bases or self.nodes)

    def at(self, t: float) -> SupportVelocity:
        """The supports' velocity at ``t`` [s]: each moved base's V = ḋ e_x and
        Ω = θ̇ e_x, each node support's displacement rate."""
        axis = np.array([1.0, 0.0, 0.0])
        rigid = []
        for rod, entries in self.bases.items():
            speed = entries["insertion"].rate(t) if "insertion" in entries else 0.0
            spin = entries["rotation"].rate(t) if "rotation" in entries else 0.0
            rigid.append(RigidMotion(rod, speed * axis, spin * axis))
        moved = np.zeros(self.model.full_size)
        for index, entry in self.nodes:
            moved[index] += entry.rate(t)
        return SupportVelocity(tuple(rigid), moved)
