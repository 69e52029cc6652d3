"""Stretch energy, paper Eq. (6), integrated over rest arc length s (docs/design.md, erratum 3).

    V_s = ½ ∫ K_s (|r′| − 1)² ds  ≈  Σ_j ½ K_s,j l (|e_j| / l − 1)²,   K_s = E_s π r²

One element per segment j, coordinates (r_j, r_{j+1}). With sections
(:mod:`rodsim.core.rod.sections`), K_s,j = E_s A of segment j (the harmonic mean where a
section boundary falls inside it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options
from rodsim.core.terms._segment import Segments, two_node_block
from rodsim.core.terms.base import KernelArguments, RodTerm


@dataclass(frozen=True, kw_only=True)
class StretchOptions(Options):
    """The options of the ``stretch`` term: one field per
    parameter, checked against them when the term class is defined."""


class Stretch(RodTerm):
    """Axial stretch of the centerline, Eq. (6)."""

    name = "stretch"
    Options = StretchOptions
    options: StretchOptions
    equation = "Eq. (6)"

    def __init__(self, rod: Rod, options: StretchOptions) -> None:
        super().__init__(rod, options)
        pos = rod.layout.position_index
        self.dofs = np.concatenate([pos[:-1], pos[1:]], axis=1)
        self._stiffness = rod.segment_stretch_stiffness()  # K_s per segment
        self._rest = rod.geometry.segment_length

    def kernel_arguments(self) -> KernelArguments:
        return {"dofs": self.dofs, "stiffness": self._stiffness, "rest": float(self._rest)}

    def _strain(self, x: np.ndarray) -> tuple[Segments, np.ndarray]:
        seg = Segments.of(x[self.rod.layout.position_index])
        return seg, seg.norm / self._rest - 1.0

    def energy(self, x: np.ndarray) -> float:
        _, strain = self._strain(x)
        return float(0.5 * self._rest * np.sum(self._stiffness * strain**2))

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        seg, strain = self._strain(x)
        tension = (self._stiffness * strain)[:, None] * seg.tangent  # ∂E/∂e
        return np.concatenate([tension, -tension], axis=1)

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        seg, strain = self._strain(x)
        t = seg.tangent
        tt = t[:, :, None] * t[:, None, :]
        h_edge = self._stiffness[:, None, None] * (
            tt / self._rest + (strain / seg.norm)[:, None, None] * (np.eye(3) - tt)
        )
        return two_node_block(h_edge)
