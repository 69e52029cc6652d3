"""Stretch energy, paper Eq. (6), integrated over rest arc length s (docs/design.md, erratum 3).

    V_s = ½ ∫ K_s (|r′| − 1)² ds  ≈  Σ_j ½ K_s,j l (|e_j| / l − 1)²,   K_s = E_s π r²

One element per segment j, coordinates (r_j, r_{j+1}). Evaluated on the offset state
(``rodsim.core.terms.base.Term.offsets``): the stretch |e_j| − l is formed as
|e_j| − |E_j| from the displacements (``rodsim.core.terms._segment.Segments.about``),
E_j the rest edge, whose length is l to round-off: the rest state is stress-free exactly and
the force carries a round-off relative to the displacement (docs/model.md, "The offset state
and the residual floor"). With sections
(``rodsim.core.rod.sections``), K_s,j = E_s A of segment j (the harmonic mean where a
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
    figure_layer = "shape"
    Options = StretchOptions
    options: StretchOptions
    equation = "Eq. (6)"
    offsets = True
    strain_kinds = ("stretch",)

    def __init__(self, rod: Rod, options: StretchOptions) -> None:
        super().__init__(rod, options)
        pos = rod.layout.position_index
        self.dofs = np.concatenate([pos[:-1], pos[1:]], axis=1)
        self._stiffness = rod.segment_stretch_stiffness()  # K_s per segment
        self._rest = rod.geometry.segment_length
        #: The rest edges E_j (N − 1, 3) the offsets are taken from.
        self.rest_edges = np.ascontiguousarray(np.diff(rod.rest_positions(), axis=0))
        self.rest_lengths = np.linalg.norm(self.rest_edges, axis=1)

    def kernel_arguments(self) -> KernelArguments:
        return {"dofs": self.dofs, "stiffness": self._stiffness, "rest": float(self._rest),
                "rest_edges": self.rest_edges, "rest_lengths": self.rest_lengths}

    def _strain(self, x: np.ndarray) -> tuple[Segments, np.ndarray]:
        seg = Segments.about(x[self.rod.layout.position_index], self.rest_edges,
                             self.rest_lengths)
        return seg, seg.change / self._rest

    def energy(self, x: np.ndarray) -> float:
        _, strain = self._strain(x)
        return float(0.5 * self._rest * np.sum(self._stiffness * strain**2))

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        seg, strain = self._strain(x)
        tension = (self._stiffness * strain)[:, None] * seg.tangent  # ∂E/∂e
        return np.concatenate([tension, -tension], axis=1)

    def material_stiffness(self, x: np.ndarray, weights: np.ndarray | None = None
                           ) -> np.ndarray:
        """k t tᵀ on the edge (the stretch rate ṡ = t · ė with stiffness k = K_s / l), as a
        two-node block: the Jacobian's first term, without its geometric part (``weights``:
        one factor on k, ``Term.material_stiffness``)."""
        seg, _ = self._strain(x)
        t = seg.tangent
        tt = t[:, :, None] * t[:, None, :]
        stiffness = self._stiffness if weights is None else self._stiffness * weights[0]
        return -two_node_block(stiffness[:, None, None] * tt / self._rest)

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        seg, strain = self._strain(x)
        t = seg.tangent
        tt = t[:, :, None] * t[:, None, :]
        h_edge = self._stiffness[:, None, None] * (
            tt / self._rest + (strain / seg.norm)[:, None, None] * (np.eye(3) - tt)
        )
        return two_node_block(h_edge)
