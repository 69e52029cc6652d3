"""Self-weight of the rod (docs/design.md, erratum 10): off in the paper's scenes, available here.

    V = Σ_i m_i g y_i,   m_i = ρ A × (rest length lumped on control point i)

The catheter of Table 1 weighs ≈ 0.15 kg, more than any mass the paper hangs on it; the
``gravity`` study shows what leaving it out changes. A dead load: no Jacobian entries.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Parameter
from rodsim.core.terms._dead_load import NodalDeadLoad
from rodsim.core.terms.tip_load import STANDARD_GRAVITY


class Gravity(NodalDeadLoad):
    """Distributed weight of the rod, lumped on the control points, along −y."""

    name = "gravity"
    equation = "self-weight (not in the paper); enters F_net of Eq. (17)"
    parameters = (
        Parameter("gravity", "float", STANDARD_GRAVITY, "m/s^2", "gravitational acceleration",
                  0.0, 1e3),
    )

    def nodal_forces(self, rod: Rod, options: Any) -> np.ndarray:
        forces = np.zeros((rod.nodes, 3))
        forces[:, 1] = -rod.node_masses() * options.gravity
        return forces
