"""Endpoint coupling, paper Eq. (29): the tendon's tip held r_L from the catheter's tip.

    F_C = K_C (|t − r_N| − r_L) (t − r_N) / |t − r_N|      (K_C [N/m])

a spring of rest length r_L between the two tips, applied to both in opposite directions
(the paper's wording), i.e. the gradient of ½ K_C (|t − r_N| − r_L)² in both coupling
variants.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.schema import Options
from rodsim.core.tendon import Tendon
from rodsim.core.terms._relative import (
    absolute,
    check_one,
    penalty_parameters,
    tendon_axial_scale,
)
from rodsim.core.terms._segment import Segments, two_node_block
from rodsim.core.terms.base import KernelArguments, TendonTerm

#: Default K_C / (E_T A_T / L_T) (rodsim/core/terms/_relative.py): the spring adds 1e-4 of
#: the tendon's own axial compliance.
DEFAULT_K_C_RELATIVE = 1e4


@dataclass(frozen=True, kw_only=True)
class EndpointCouplingOptions(Options):
    """The options of the ``endpoint_coupling`` term: one field per
    parameter, checked against them when the term class is defined."""

    K_C: float = 0.0
    K_C_relative: float = DEFAULT_K_C_RELATIVE


class EndpointCoupling(TendonTerm):
    """Spring of rest length r_L between the catheter's and the tendon's tips, Eq. (29)."""

    name = "endpoint_coupling"
    figure_layer = "tendon"
    Options = EndpointCouplingOptions
    options: EndpointCouplingOptions
    equation = "Eq. (29)"
    parameters = (
        *penalty_parameters("K_C", "N/m", "endpoint coupling penalty constant",
                            DEFAULT_K_C_RELATIVE,
                            "the tendon's axial stiffness E_T A_T / L_T"),
    )

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        check_one(options, "K_C", DEFAULT_K_C_RELATIVE, prefix)

    def __init__(self, tendon: Tendon, options: EndpointCouplingOptions) -> None:
        super().__init__(tendon, options)
        #: The absolute penalty constant [N/m].
        self.K_C = absolute(options, "K_C", tendon_axial_scale(tendon))
        self._stiffness = self.K_C
        end = tendon.termination
        self.dofs = np.concatenate([end.to_position_index, end.position_index])[None, :]
        # (r_N, t): edge e = t − r_N

    def rigid_links(self) -> np.ndarray:
        """The stiff link r_N–t, whose length a Newton step keeps (Model.step)."""
        return self.dofs

    def kernel_arguments(self) -> KernelArguments:
        return {"dofs": self.dofs, "stiffness": float(self._stiffness),
                "offset": float(self.tendon.offset)}

    def _edge(self, x: np.ndarray) -> Segments:
        return Segments.of(x[self.dofs[0]].reshape(2, 3))

    def energy(self, x: np.ndarray) -> float:
        seg = self._edge(x)
        return float(0.5 * self._stiffness * (seg.norm[0] - self.tendon.offset) ** 2)

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        seg = self._edge(x)
        pull = self._stiffness * (seg.norm - self.tendon.offset)[:, None] * seg.tangent
        return np.concatenate([pull, -pull], axis=1)

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        seg = self._edge(x)
        t = seg.tangent
        tt = t[:, :, None] * t[:, None, :]
        stretch = ((seg.norm - self.tendon.offset) / seg.norm)[:, None, None]
        return two_node_block(self._stiffness * (tt + stretch * (np.eye(3) - tt)))
