"""How deep a rod lies inside the rigid obstacles it touches, against the contact law's
validity (docs/contact.md, "The law").

The penalty ψ of rodsim/core/terms/contact.py stands for a rigid wall through its
compliance: a node's sphere sinks p = f/k + δ/2 into the wall under a contact force f. That
is a model of a rigid contact only while p is small against the rod's radius r; the law is
stated for p ≤ ``DEPTH_LIMIT`` r. Deeper, the equilibrium is the penalty's, not the
wall's: `tip-on-tissue` with its plane moved 5 mm into the rod's path came back "stable"
with the tip 4.3 radii inside rigid tissue under a contact force of 50 kN. The equilibrium
stop (rodsim/solvers/stops.py) fails such a state with this module's reason; a rest state
already that deep (the straight rest shape through a wall) gets a warning
(``rest_crossings``); a held node that deep (a clamped base, a node support) is refused
when the scene is validated (rodsim/core/obstacles/__init__.py). Measured on the shipped
contact scenes: the deepest node 0.0067 r (tip-on-tissue) and 3.1e-4 r (vessel-insertion).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rodsim.core.obstacles import DEPTH_LIMIT

if TYPE_CHECKING:
    from rodsim.core.model import Model

__all__ = ["DEPTH_LIMIT", "Penetration", "deepest", "rest_crossings"]



@dataclass(frozen=True)
class Penetration:
    """The deepest node of one rod in one obstacle: its penetration in rod radii."""

    rod: str
    obstacle: str
    node: int
    s: float
    radii: float

    def text(self) -> str:
        return (f"rod {self.rod!r} lies {self.radii:.3g} radii inside obstacle "
                f"{self.obstacle!r} at node {self.node} (s = {self.s:.6g} m)")


def _penetrations(model: Model, full: np.ndarray) -> list[Penetration]:
    """The deepest node of each (rod, obstacle) contact term at the full state ``full``."""
    from rodsim.core.terms.contact import Contact

    found = []
    for term in model.terms:
        if isinstance(term, Contact):
            depth = term.penetration(full) / term.radius
            node = int(np.argmax(depth))
            s = float(term.rod.geometry.node_s[node])
            found.append(Penetration(term.rod.name, term.obstacle.name, node, s,
                                     float(depth[node])))
    return found


def deepest(model: Model, x: np.ndarray) -> Penetration | None:
    """The deepest node past ``DEPTH_LIMIT`` at the free state ``x``, or None."""
    found = [p for p in _penetrations(model, model.full(x)) if p.radii > DEPTH_LIMIT]
    return max(found, key=lambda p: p.radii) if found else None


def depth_failure(model: Model, x: np.ndarray) -> str | None:
    """The failure reason of an equilibrium deeper than the law's validity, or None."""
    found = deepest(model, x)
    if found is None:
        return None
    return (f"{found.text()}: deeper than the contact law's validity ({DEPTH_LIMIT:g} r, "
            "docs/contact.md), the state is the penalty's, not the rigid wall's; the loads "
            "press the rod through the obstacle: check where the obstacle is, or raise its "
            "stiffness_scale")


def rest_crossings(model: Model) -> list[str]:
    """One warning per (rod, obstacle) whose rest (held) shape lies deeper than
    ``DEPTH_LIMIT`` inside the obstacle: the solve starts through the wall."""
    from rodsim.core.terms.contact import Contact

    out = []
    for term in model.terms:
        if isinstance(term, Contact):
            gap = term.obstacle.gap(term.rod.held_positions())[0]
            depth = (term.radius - gap) / term.radius
            inside = np.flatnonzero(depth > DEPTH_LIMIT)
            if len(inside):
                node = int(inside[np.argmax(depth[inside])])
                out.append(f"the rest shape of rod {term.rod.name!r} crosses obstacle "
                           f"{term.obstacle.name!r}: {len(inside)} nodes inside, the deepest "
                           f"{depth[node]:.3g} radii (node {node}); the solve starts through "
                           "the wall and may settle on its far side (start from a state "
                           "inside: track the insertion)")
    return out
