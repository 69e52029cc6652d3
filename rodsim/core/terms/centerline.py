"""Centerline penalty, paper Eq. (9): ties each segment's d3 to its tangent (Eq. 1).

    E_p = ½ ∫ K_P |r′/|r′| − d3|² ds  ≈  Σ_j ½ K_P l |t_j − d3(q_j)|²

K_P is an energy per unit rest length [N] in rodsim (the integral runs over s in metres).
Because Eq. (2) gives |d3| = |q|², the same penalty also holds the quaternion at unit norm.
One element per segment j, coordinates (r_j, r_{j+1}, q_j).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.rod.quaternion import (
    DIRECTOR_FORMS,
    director,
    director_gradient,
    form_combination,
)
from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Parameter
from rodsim.core.terms._segment import Segments
from rodsim.core.terms.base import RodTerm


class Centerline(RodTerm):
    """Penalty coupling the directors to the centerline, Eq. (9)."""

    name = "centerline"
    equation = "Eq. (9)"
    penalty = True
    parameters = (
        Parameter("K_P", "float", 1e4, "N", "centerline penalty constant (energy per length)",
                  0.0, 1e15, exclusive_minimum=True),
    )

    def __init__(self, rod: Rod, options: Any) -> None:
        super().__init__(rod, options)
        pos = rod.layout.position_index
        self.dofs = np.concatenate([pos[:-1], pos[1:], rod.layout.quaternion_index], axis=1)
        self._weight = options.K_P * rod.geometry.segment_length  # K_P l
        #: Penalty stiffness relative to bending at the scale of one segment, K_P l² / (E I)
        #: (the least E I along a rod with sections).
        self.penalty_ratio = (options.K_P * rod.geometry.segment_length**2
                              / rod.smallest_bending_stiffness)

    def kernel_arguments(self) -> tuple:
        return (self.dofs, float(self._weight))

    def _mismatch(self, x: np.ndarray) -> tuple[Segments, np.ndarray, np.ndarray]:
        seg = Segments.of(x[self.rod.layout.position_index])
        q = x[self.rod.layout.quaternion_index]
        return seg, q, seg.tangent - director(q, 2)

    def energy(self, x: np.ndarray) -> float:
        _, _, w = self._mismatch(x)
        return float(0.5 * self._weight * np.sum(w * w))

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        seg, q, w = self._mismatch(x)
        # ∂E/∂e = K_P l P w / |e|;  ∂E/∂q = −K_P l Gᵀ w with G = ∂d3/∂q
        de = self._weight * (w - np.sum(w * seg.tangent, axis=1)[:, None] * seg.tangent)
        de /= seg.norm[:, None]
        dq = -self._weight * np.einsum("nma,nm->na", director_gradient(q, 2), w)
        return -np.concatenate([-de, de, dq], axis=1)

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        seg, q, w = self._mismatch(x)
        t, n = seg.tangent, seg.norm
        proj = seg.projector
        wt = np.sum(w * t, axis=1)
        outer = t[:, :, None] * w[:, None, :]
        curvature = -(outer + outer.transpose(0, 2, 1)
                      + wt[:, None, None] * (np.eye(3) - 3.0 * t[:, :, None] * t[:, None, :]))
        h_ee = self._weight * (proj + curvature) / (n**2)[:, None, None]
        grad = director_gradient(q, 2)
        h_eq = -self._weight * np.einsum("nab,nbc->nac", proj, grad) / n[:, None, None]
        h_qq = self._weight * (
            np.matmul(grad.transpose(0, 2, 1), grad)
            - 2.0 * form_combination(w, DIRECTOR_FORMS[2])
        )
        hess = np.empty((len(n), 10, 10))
        hess[:, :3, :3] = h_ee
        hess[:, 3:6, 3:6] = h_ee
        hess[:, :3, 3:6] = -h_ee
        hess[:, 3:6, :3] = -h_ee
        hess[:, :3, 6:] = -h_eq
        hess[:, 3:6, 6:] = h_eq
        hess[:, 6:, :3] = -h_eq.transpose(0, 2, 1)
        hess[:, 6:, 3:6] = h_eq.transpose(0, 2, 1)
        hess[:, 6:, 6:] = h_qq
        return -hess
