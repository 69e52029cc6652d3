"""A dead load on every control point of a rod: forces fixed when the term is built.

    V = −Σ_i F_i · r_i

Self-weight and a load per unit length are such loads; they differ only in how the nodal
forces F_i are computed (``NodalDeadLoad.nodal_forces``). No Jacobian entries; the
compiled kernel is ``rodsim.core.kernels.constant_force``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.schema import SceneError, shown
from rodsim.core.terms.base import KernelArguments, RodTerm

#: Standard gravity [m/s²]; the paper's hanging masses are weighed with it.
STANDARD_GRAVITY = 9.81


def unit_direction(direction: Any, key: str) -> np.ndarray:
    """``direction`` normalised (SceneError, one line, for a zero vector): where gravity
    pulls a rod's weight or a hanging mass."""
    vector = np.asarray(direction, dtype=float)
    norm = float(np.linalg.norm(vector))
    if not norm > 0.0:
        raise SceneError(f"{key} = {shown(list(direction))}: a zero vector has no direction; "
                         "allowed: any nonzero vector (normalised)", key=key,
                         value=list(direction), allowed="a nonzero vector",
                         reason="zero vector")
    return vector / norm


class NodalDeadLoad(RodTerm):
    """Constant forces F_i on the control points (subclasses give them)."""

    is_load = True
    has_jacobian = False
    kernel = "constant_force"

    def __init__(self, rod: Rod, options: Any) -> None:
        super().__init__(rod, options)
        self.dofs = rod.layout.position_index
        self._forces = self.nodal_forces(rod, options)

    def nodal_forces(self, rod: Rod, options: Any) -> np.ndarray:
        """The force on each control point [N], shape (N, 3)."""
        raise NotImplementedError

    def kernel_arguments(self) -> KernelArguments:
        return {"forces": self._forces}

    def energy(self, x: np.ndarray) -> float:
        return float(-np.sum(self._forces * x[self.dofs]))

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        return self._forces
