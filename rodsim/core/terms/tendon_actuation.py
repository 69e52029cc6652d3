"""Actuation force F_A on the tendon (paper §4.3: F_A = 2 N). Where it acts is our choice.

The paper does not say where F_A acts nor how the tendon's proximal end is held, and its
tendon (E_s = 0.001 MPa, r = 0.1 mm: E_s A = 3.1e-5 N) cannot carry 2 N along its length
(docs/design.md, erratum 7). Two choices, recorded in every archive through the scene:

- ``distal`` (default, for the paper's scenes): F_A pulls the tendon's tip back along the
  lumen, F = −F_A d3(q_last) of the catheter's last segment (a follower load). The tendon
  need not carry the tension; its base is clamped at the lumen entrance.
- ``proximal`` (physical): F_A pulls the tendon's base out of the catheter along −d3 of the
  catheter's base frame (−x); the tension travels along the tendon, which must then be stiff
  in stretch and have the ``orientation`` clamp (base free to slide).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rodsim.core.rod.quaternion import director, director_gradient
from rodsim.core.schema import Options, Parameter
from rodsim.core.tendon import Tendon
from rodsim.core.terms.base import KernelArguments, TendonTerm


@dataclass(frozen=True, kw_only=True)
class TendonActuationOptions(Options):
    """The options of the ``tendon_actuation`` term: one field per
    parameter, checked against them when the term class is defined."""

    force: float = 2.0
    point: str = "distal"


class TendonActuation(TendonTerm):
    """The actuation force F_A on the tendon, at its distal or proximal end."""

    name = "tendon_actuation"
    figure_layer = "load"
    Options = TendonActuationOptions
    options: TendonActuationOptions
    equation = "§4.3 (F_A); enters F_net of Eq. (31)"
    is_load = True
    conservative = False
    parameters = (
        Parameter("force", "float", 2.0, "N", "actuation force F_A (Table 3's experiment: 2 N)",
                  0.0, 1e6),
        Parameter("point", "str", "distal", "-",
                  "'distal' (tip pulled back along the lumen) or 'proximal' (base pulled out)",
                  choices=("distal", "proximal")),
    )

    def __init__(self, tendon: Tendon, options: TendonActuationOptions) -> None:
        super().__init__(tendon, options)
        self._force = options.force
        self._distal = options.point == "distal"
        catheter = tendon.catheter
        if self._distal:
            end = tendon.termination
            self._quaternion = end.to_quaternion_index
            self.dofs = np.concatenate([end.position_index, self._quaternion])[None, :]
        else:
            self.has_jacobian = False
            self.conservative = True
            self.kernel = "constant_force"
            self.dofs = tendon.tendon_rod.layout.position_index[:1]
            self._pull = -self._force * director(catheter.base_quaternion, 2)

    def linear_in(self, option: str) -> bool:
        """F = −F_A d3 (or the constant pull): linear in ``force``."""
        return option == "force"

    def kernel_arguments(self) -> KernelArguments:
        if not self._distal:
            return {"forces": self._pull[None, :].copy()}
        return {"dofs": self.dofs, "pull": float(self._force)}

    def energy(self, x: np.ndarray) -> float | None:
        if self._distal:
            return None
        return float(-self._pull @ x[self.dofs[0]])

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        if not self._distal:
            return self._pull[None, :]
        force = np.zeros(7)
        force[0:3] = -self._force * director(x[self._quaternion], 2)
        return force[None, :]

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        jac = np.zeros((1, 7, 7))
        jac[0, 0:3, 3:7] = -self._force * director_gradient(x[self._quaternion], 2)
        return jac
