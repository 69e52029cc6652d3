"""Self-weight of the rod (docs/design.md, erratum 10): off in the paper's scenes, available here.

    V = Σ_i m_i g y_i,   m_i = ρ A × (rest length lumped on control point i)

The catheter of Table 1 weighs ≈ 0.15 kg, more than any mass the paper hangs on it; the
``gravity`` study shows what leaving it out changes. A dead load: no Jacobian entries.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter
from rodsim.core.terms._dead_load import NodalDeadLoad
from rodsim.core.terms.tip_load import STANDARD_GRAVITY


@dataclass(frozen=True, kw_only=True)
class GravityOptions(Options):
    """The options of the ``gravity`` term: one field per
    parameter, checked against them when the term class is defined."""

    gravity: float = 9.81


class Gravity(NodalDeadLoad):
    """Distributed weight of the rod, lumped on the control points, along −y."""

    name = "gravity"
    Options = GravityOptions
    options: GravityOptions
    equation = "self-weight (not in the paper); enters F_net of Eq. (17)"
    parameters = (
        Parameter("gravity", "float", STANDARD_GRAVITY, "m/s^2", "gravitational acceleration",
                  0.0, 1e3),
    )

    def nodal_forces(self, rod: Rod, options: Any) -> np.ndarray:
        forces = np.zeros((rod.nodes, 3))
        forces[:, 1] = -rod.node_masses() * options.gravity
        return forces
