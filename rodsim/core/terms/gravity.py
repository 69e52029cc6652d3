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
from rodsim.core.terms.base import RodTerm
from rodsim.core.terms.tip_load import STANDARD_GRAVITY


class Gravity(RodTerm):
    """Distributed weight of the rod, lumped on the control points, along −y."""

    name = "gravity"
    equation = "self-weight (not in the paper); enters F_net of Eq. (17)"
    is_load = True
    has_jacobian = False
    kernel = "constant_force"
    parameters = (
        Parameter("gravity", "float", STANDARD_GRAVITY, "m/s^2", "gravitational acceleration",
                  0.0, 1e3),
    )

    def __init__(self, rod: Rod, options: Any) -> None:
        super().__init__(rod, options)
        self.dofs = rod.layout.position_index
        weights = rod.node_masses() * options.gravity
        self._forces = np.zeros((rod.nodes, 3))
        self._forces[:, 1] = -weights

    def kernel_arguments(self) -> tuple:
        return (self._forces,)

    def energy(self, x: np.ndarray) -> float:
        return float(-np.sum(self._forces * x[self.dofs]))

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        return self._forces
