"""Centerline penalty, paper Eq. (9): ties each segment's d3 to its tangent (Eq. 1).

    E_p = ½ ∫ K_P |r′/|r′| − d3|² ds  ≈  Σ_j ½ K_P l |t_j − d3(q_j)|²

K_P is an energy per unit rest length [N] in rodsim (the integral runs over s in metres).
It is given either absolutely (``K_P`` [N]) or relative to the rod's own axial stiffness,
``K_P_relative`` = K_P / (E_s A) (E_s A the rod's stretch stiffness, the harmonic mean along
a rod with sections), the default (docs/model.md, "Penalties relative to the rod"): under a
transverse force F a segment shears by about F/K_P, which in units of L is
F/(K_P_relative E_s A) = α r² / (2 K_P_relative L²) for a uniform rod with E_s = E
(α = F L²/(2 E I) the load parameter, I = π r⁴/4). Unlike a scale built on the rod's length,
this one does not change when a rod is split into two joined ones.

Evaluated on the offset state (``rodsim.core.terms.base.Term.offsets``): the mismatch is
formed about the rest state, w = (t − T) − (d3(q) − d3(q⁰)) + m⁰, with t − T from the
displacements (``rodsim.core.terms._segment.Segments.about``) and
d3(q) − d3(q⁰) = δ·A[2, m](q⁰ + q) = ½ (G(q⁰) + G(q)) δ from the quaternion's change
δ = q − q⁰ (Eq. 2 is quadratic, G = ∂d3/∂q), each without cancellation;
m⁰ = T − d3(q⁰) is the rest shape's own mismatch, taken as 0 where it is round-off
(≤ ``REST_ROUNDOFF``). The force then carries a round-off relative to the deformation
instead of eps K_P (docs/model.md, "The offset state and the residual floor").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.rod.quaternion import (
    DIRECTOR_FORMS,
    director,
    director_gradient,
    form_combination,
)
from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter, SceneError
from rodsim.core.terms._segment import Segments
from rodsim.core.terms.base import KernelArguments, RodTerm

#: Default K_P / (E_s A): the penalty error α r² / (2 K_P_relative L²) is ≤ 1e-4 L up to a
#: load α = 8 (a tip force bending a cantilever far past 90°) on a rod as thick as L/r = 20;
#: measured on the random user family (tests/test_user_robot.py).
DEFAULT_K_P_RELATIVE = 100.0

#: A rest mismatch |T − d3(q⁰)| component at most this is round-off of the rest shape (the
#: rest quaternions are built to give d3 = T): it is taken as 0, so that the rest state is
#: an exact zero of the penalty.
REST_ROUNDOFF = 64.0 * float(np.finfo(float).eps)


def penalty_constant(options: Any, rod: Rod) -> float:
    """The absolute K_P [N] of centerline ``options`` on ``rod``: ``K_P`` if given, else
    ``K_P_relative`` · E_s A (the rod's stretch stiffness)."""
    if options.K_P > 0.0:
        return float(options.K_P)
    return float(options.K_P_relative) * rod.stretch_stiffness


@dataclass(frozen=True, kw_only=True)
class CenterlineOptions(Options):
    """The options of the ``centerline`` term: one field per
    parameter, checked against them when the term class is defined."""

    K_P: float = 0.0
    K_P_relative: float = DEFAULT_K_P_RELATIVE


class Centerline(RodTerm):
    """Penalty coupling the directors to the centerline, Eq. (9)."""

    name = "centerline"
    figure_layer = "shape"
    Options = CenterlineOptions
    options: CenterlineOptions
    equation = "Eq. (9)"
    strain_kinds = ("shear",)
    penalty = True
    constraint_constant = "K_P"
    penalty_advice = "the centerline penalty (rods.<name>.centerline.K_P_relative, or K_P)"
    offsets = True
    parameters = (
        Parameter("K_P", "float", 0.0, "N",
                  "centerline penalty constant (energy per length); 0 (default): from "
                  "K_P_relative", 0.0, 1e15),
        Parameter("K_P_relative", "float", DEFAULT_K_P_RELATIVE, "-",
                  "centerline penalty relative to the rod's axial stiffness, K_P / (E_s A); "
                  "used when K_P is not given", 0.0, 1e15,
                  exclusive_minimum=True),
    )

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        if options.K_P > 0.0 and options.K_P_relative != DEFAULT_K_P_RELATIVE:
            raise SceneError(f"{prefix}: K_P = {options.K_P!r} and K_P_relative = "
                             f"{options.K_P_relative!r} both set the centerline penalty; "
                             "allowed: one of them")

    def __init__(self, rod: Rod, options: CenterlineOptions) -> None:
        super().__init__(rod, options)
        pos = rod.layout.position_index
        self.dofs = np.concatenate([pos[:-1], pos[1:], rod.layout.quaternion_index], axis=1)
        #: The absolute penalty constant K_P [N] (:func:`penalty_constant`).
        self.K_P = penalty_constant(options, rod)
        self._weight = self.K_P * rod.geometry.segment_length  # K_P l
        #: Penalty stiffness relative to bending at the scale of one segment, K_P l² / (E I)
        #: (the least E I along a rod with sections).
        self.penalty_ratio = (self.K_P * rod.geometry.segment_length**2
                              / rod.smallest_bending_stiffness)
        #: The rest edges E_j and rest quaternions q⁰_j the offsets are taken from, and the
        #: rest mismatch m⁰_j (0 where it is round-off).
        self.rest_edges = np.ascontiguousarray(np.diff(rod.rest_positions(), axis=0))
        self.rest_lengths = np.linalg.norm(self.rest_edges, axis=1)
        self.rest_quaternions = np.ascontiguousarray(rod.rest_quaternions())
        self.rest_gradients = np.ascontiguousarray(director_gradient(self.rest_quaternions, 2))
        rest = self.rest_edges / self.rest_lengths[:, None]
        mismatch = rest - director(self.rest_quaternions, 2)
        mismatch[np.abs(mismatch) <= REST_ROUNDOFF] = 0.0
        self.rest_mismatch = np.ascontiguousarray(mismatch)

    def kernel_arguments(self) -> KernelArguments:
        return {"dofs": self.dofs, "weight": float(self._weight),
                "rest_edges": self.rest_edges, "rest_lengths": self.rest_lengths,
                "rest_quaternions": self.rest_quaternions,
                "rest_gradients": self.rest_gradients, "rest_mismatch": self.rest_mismatch}

    def _mismatch(self, x: np.ndarray) -> tuple[Segments, np.ndarray, np.ndarray]:
        seg = Segments.about(x[self.rod.layout.position_index], self.rest_edges,
                             self.rest_lengths)
        delta = x[self.rod.layout.quaternion_index]
        q = self.rest_quaternions + delta
        # d3(q) − d3(q⁰) = δ·A(q⁰ + q) = ½ (G(q⁰) + G(q)) δ, G = ∂d3/∂q (Eq. 2 is quadratic)
        change = 0.5 * np.einsum("nmi,ni->nm",
                                 self.rest_gradients + director_gradient(q, 2), delta)
        return seg, q, seg.turn - change + self.rest_mismatch

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

    def material_stiffness(self, x: np.ndarray, weights: np.ndarray | None = None
                           ) -> np.ndarray:
        """K_P l Jᵀ J per element, J = ∂w/∂(r_j, r_{j+1}, q_j) = (−P/|e|, P/|e|, −G) the
        mismatch's (the shear's) derivative: the Jacobian without its curvature parts
        (``weights``: one factor on K_P, ``Term.material_stiffness``)."""
        seg, q, _ = self._mismatch(x)
        weight = self._weight if weights is None else self._weight * float(weights[0])
        grad = director_gradient(q, 2)
        jac = np.concatenate([-seg.projector / seg.norm[:, None, None],
                              seg.projector / seg.norm[:, None, None], -grad], axis=2)
        return weight * np.matmul(jac.transpose(0, 2, 1), jac)

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
