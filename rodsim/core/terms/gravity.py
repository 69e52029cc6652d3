"""Self-weight of the rod (docs/design.md, erratum 10): off in the paper's scenes, available here.

    V = −Σ_i m_i g ĝ · r_i,   m_i = ρ A × (rest length lumped on control point i)

with ĝ = ``direction`` / |``direction``|, the unit vector gravity pulls along: (0, −1, 0) by
default (V = Σ_i m_i g y_i, the paper's frame with y up), any other to tilt the robot in
gravity (a catheter hanging down, or lying on its side). The direction is normalised; a zero
vector is refused. It serves statics and physical time alike (a dead load: the same force at
every state).

The catheter of Table 1 weighs ≈ 0.15 kg, more than any mass the paper hangs on it; the
``gravity`` study shows what leaving it out changes. A dead load: no Jacobian entries.
A ``tip_load``'s hanging ``mass`` is weighed by its own term along −y; give its ``force``
for a weight along another direction.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter
from rodsim.core.terms._dead_load import STANDARD_GRAVITY, NodalDeadLoad, unit_direction


@dataclass(frozen=True, kw_only=True)
class GravityOptions(Options):
    """The options of the ``gravity`` term: one field per
    parameter, checked against them when the term class is defined."""

    gravity: float = 9.81
    direction: list[float] = field(default_factory=lambda: [0.0, -1.0, 0.0])


class Gravity(NodalDeadLoad):
    """Distributed weight of the rod, lumped on the control points, along ``direction``
    (−y by default)."""

    name = "gravity"
    figure_layer = "load"
    Options = GravityOptions
    options: GravityOptions
    equation = "self-weight (not in the paper); enters F_net of Eq. (17)"
    parameters = (
        Parameter("gravity", "float", STANDARD_GRAVITY, "m/s^2", "gravitational acceleration",
                  0.0, 1e3),
        Parameter("direction", "vector", [0.0, -1.0, 0.0], "-",
                  "direction gravity pulls along, world frame (normalised; not zero)",
                  -1e3, 1e3, length=3),
    )

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        unit_direction(options.direction, f"{prefix}.direction")

    def nodal_forces(self, rod: Rod, options: Any) -> np.ndarray:
        direction = unit_direction(options.direction, f"rods.{rod.name}.gravity.direction")
        return rod.node_masses()[:, None] * options.gravity * direction[None, :]
