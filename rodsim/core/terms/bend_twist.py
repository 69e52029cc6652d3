"""Bending and twisting energy, paper Eqs. (7)–(8), with q′ for q̇ (docs/design.md, erratum 1).

    V_b = ½ ∫ Σ_k K_kk (u_k − û_k)² ds,   u_k = (2 / |q|²) (B_k q) · q′        (Eqs. 3, 7)

Discretely, at each interior node i between the quaternions a = q_{i−1} and b = q_i (a
distance l̄ = l apart),

    u_k,i = (2 / l̄) (B_k a) · b / (|a| |b|),   energy ½ l̄ Σ_k K_kk u_k,i².

The normalisation is Eq. (3)'s 2/|q|², kept in the discrete form (docs/design.md,
erratum 1). It makes the strains independent of the quaternions' norms, which
only the centerline penalty Eq. (9) holds at 1. Without it, bending pulls |q| below 1 by
O(EI κ² / K_P) and so softens the rod: on Table 1 (100 g, K_P = 1e4) that moved the tip by
4.7e-5 L and made the penalty model differ from IDA's exactly-unit quaternions by as much
(docs/model.md). The rest curvature û is zero (straight rods).

When the rod's base support holds a frame (``clamp`` = ``frame`` or ``orientation``,
rodsim/core/supports.py), its frame q_c sits at s = 0, half a segment before q_0, and adds
one element (q_c, q_0) with l̄ = l / 2; this keeps the discretisation second order in N
(docs/model.md, "Clamp"). The ``first_segment`` clamp fixes q_0 instead and adds no element.
A support at node k that holds the frame too (``orientation = true``) puts its frame q_c
at s_k, between q_{k−1} and q_k: the element (q_{k−1}, q_k) becomes the two elements
(q_{k−1}, q_c) and (q_c, q_k), each with l̄ = l / 2 (at the tip node, the first only) — a
clamp at s_k on both sides. The frames come from the supports (an actuated base turns
them); the term knows nothing else of how the rod is held.

Stiffness (Eq. 8, the paper's corrected tensor, default):
    K_11 = K_22 = E π r⁴ / 4,   K_33 = G π r⁴ / 2
``stiffness = "corde"`` uses the tensor printed in CORDE [33], which the paper's Fig. 9 shows
to overestimate the stiffness:  K_11 = K_22 = E π r² / 4,  K_33 = G π r² / 2  (an r² where
r⁴ belongs; dimensionally wrong, kept only to reproduce Fig. 9).

With sections that vary along the rod (``rodsim.core.rod.sections``) each element has its
own K: the harmonic mean of the spans' stiffnesses over its dual interval, so that a
piecewise-uniform rod under a constant moment turns by exactly ∫ M / (E I) ds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rodsim.core.rod.quaternion import B, form_combination
from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter
from rodsim.core.terms.base import KernelArguments, RodTerm

#: B as flattened matrices: (b @ _B_ROWS)[n, 4k + a] = Σ_c B[k, c, a] b[n, c] (B_kᵀ b) and
#: (a @ _B_COLUMNS)[n, 4k + c] = Σ_d B[k, c, d] a[n, d] (B_k a).
_B_ROWS = np.ascontiguousarray(B.transpose(1, 0, 2).reshape(4, 12))
_B_COLUMNS = np.ascontiguousarray(B.reshape(12, 4).T)


def stiffness_tensor(rod: Rod, model: str, twist_override: float = 0.0) -> np.ndarray:
    """Diagonal (K_11, K_22, K_33) of Eq. (8) [N·m²], or of CORDE's tensor for Fig. 9;
    ``twist_override`` > 0 replaces K_33."""
    if model == "corrected":  # E I and G J, Eq. (8)
        bend, twist = rod.bending_stiffness, rod.shear_modulus * rod.polar_moment
    else:  # CORDE's printed tensor: r² where r⁴ belongs
        area = math.pi * rod.radius**2
        bend, twist = rod.youngs_modulus * area / 4.0, rod.shear_modulus * area / 2.0
    return np.array([bend, bend, twist_override if twist_override > 0.0 else twist])


def element_stiffness(rod: Rod, model: str, twist_override: float, start: np.ndarray,
                      end: np.ndarray) -> np.ndarray:
    """(K_11, K_22, K_33) of each bending element over its dual interval [start, end] [N·m²],
    shape (n_elem, 3). A uniform rod: ``stiffness_tensor`` for every element. With
    sections: each span's E I and G J (CORDE: E A / 4, G A / 2), harmonically averaged over
    the element's dual interval (``rodsim.core.rod.sections``), which keeps the rotation
    across the element exact under a constant moment."""
    profile = rod.profile
    if profile is None:
        return np.tile(stiffness_tensor(rod, model, twist_override), (len(start), 1))
    if model == "corrected":
        bend = profile.youngs_modulus * profile.second_moment
        twist = profile.shear_modulus * profile.polar_moment
    else:
        bend = profile.youngs_modulus * profile.area / 4.0
        twist = profile.shear_modulus * profile.area / 2.0
    out = np.empty((len(start), 3))
    out[:, 0] = out[:, 1] = profile.harmonic_mean(bend, start, end)
    out[:, 2] = (twist_override if twist_override > 0.0
                 else profile.harmonic_mean(twist, start, end))
    return out


class BendKinematics(NamedTuple):
    """Strains of the bending elements and the pieces of their derivatives.

    ``a``, ``b``: the element's two quaternions (n, 4); ``na2``, ``nb2``: |a|², |b|²;
    ``scale``: c s = (2/l̄) / (|a||b|); ``ga``, ``gb``: ∂f_k/∂a = B_kᵀ b and ∂f_k/∂b = B_k a
    (n, 3, 4); ``f``: f_k = (B_k a)·b (n, 3); ``u``: strains u_k = c s f_k (n, 3) [1/m];
    ``ha``, ``hb``: ∇u_k / (c s) with respect to a and b (n, 3, 4).
    """

    a: np.ndarray
    b: np.ndarray
    na2: np.ndarray
    nb2: np.ndarray
    scale: np.ndarray
    ga: np.ndarray
    gb: np.ndarray
    f: np.ndarray
    u: np.ndarray
    ha: np.ndarray
    hb: np.ndarray


def bend_kinematics(a: np.ndarray, b: np.ndarray, dual_lengths: np.ndarray) -> BendKinematics:
    """Strains of the bending elements (a, b) of dual lengths l̄ and the pieces of their
    derivatives (see ``BendKinematics``)."""
    na2, nb2 = np.sum(a * a, axis=1), np.sum(b * b, axis=1)
    scale = 2.0 / (dual_lengths * np.sqrt(na2 * nb2))  # c s = (2/l̄) / (|a||b|)
    ga = (b @ _B_ROWS).reshape(-1, 3, 4)  # ∂f_k/∂a = B_kᵀ b
    gb = (a @ _B_COLUMNS).reshape(-1, 3, 4)  # ∂f_k/∂b = B_k a
    f = np.einsum("nka,na->nk", ga, a)  # f_k = (B_k a) · b
    u = scale[:, None] * f
    # ∇u_k = c s (g − f q / |q|²) for each of a and b
    ha = ga - (f / na2[:, None])[:, :, None] * a[:, None, :]
    hb = gb - (f / nb2[:, None])[:, :, None] * b[:, None, :]
    return BendKinematics(a, b, na2, nb2, scale, ga, gb, f, u, ha, hb)


def bend_forces(a: np.ndarray, b: np.ndarray, dual_lengths: np.ndarray,
                stiffness: np.ndarray) -> np.ndarray:
    """F = −∂E/∂(a, b) of the bending elements (a, b), shape (n, 8) (Eq. 7)."""
    kin = bend_kinematics(a, b, dual_lengths)
    scale, u, ha, hb = kin.scale, kin.u, kin.ha, kin.hb
    # ∂E/∂q = l̄ Σ_k K_k u_k ∇u_k,  ∇u_k = c s h_k
    weight = (dual_lengths * scale)[:, None] * stiffness * u
    grad_a = np.einsum("nk,nka->na", weight, ha)
    grad_b = np.einsum("nk,nka->na", weight, hb)
    return -np.concatenate([grad_a, grad_b], axis=1)


def _gauss_newton(kinematics: BendKinematics, dual_lengths: np.ndarray,
                  stiffness: np.ndarray) -> np.ndarray:
    """l̄ Σ_k K_k ∇u_k ∇u_kᵀ of the bending elements, shape (n, 8, 8): the material part of
    the stiffness (positive semi-definite)."""
    gn = (dual_lengths * kinematics.scale**2)[:, None] * stiffness
    grad = np.concatenate([kinematics.ha, kinematics.hb], axis=2)  # (n, 3, 8), ∇u_k / (c s)
    return np.matmul((grad * gn[:, :, None]).transpose(0, 2, 1), grad)


def bend_jacobians(a: np.ndarray, b: np.ndarray, dual_lengths: np.ndarray,
                   stiffness: np.ndarray) -> np.ndarray:
    """∂F/∂(a, b) of the bending elements (a, b), shape (n, 8, 8) (Eq. 7)."""
    kinematics = bend_kinematics(a, b, dual_lengths)
    a, b, na2, nb2, scale, ga, gb, f, u, ha, hb = kinematics
    lbar = dual_lengths
    hess = _gauss_newton(kinematics, dual_lengths, stiffness)
    # Curvature part: l̄ Σ_k K_k u_k ∇²u_k, with (per k, in units of c s)
    #   ∇²_aa u = −[g_a aᵀ + a g_aᵀ + f I − 3 f a aᵀ/|a|²] / |a|²
    #   ∇²_ab u = B_kᵀ − g_a bᵀ/|b|² − a g_bᵀ/|a|² + f a bᵀ/(|a|²|b|²)
    w = (lbar * scale)[:, None] * stiffness * u  # l̄ K_k u_k c s
    eye = np.eye(4)

    def same(q: np.ndarray, g: np.ndarray, n2: np.ndarray) -> np.ndarray:
        sym = np.matmul(w[:, None, :], g)[:, 0, :, None] * q[:, None, :]
        fw = np.sum(w * f, axis=1)
        qq = q[:, :, None] * q[:, None, :]
        return -(sym + sym.transpose(0, 2, 1) + fw[:, None, None] * eye
                 - 3.0 * (fw / n2)[:, None, None] * qq) / n2[:, None, None]

    h_aa = same(a, ga, na2)
    h_bb = same(b, gb, nb2)
    fw = np.sum(w * f, axis=1)
    wga = np.matmul(w[:, None, :], ga)[:, 0, :]  # Σ_k w_k ∂f_k/∂a
    wgb = np.matmul(w[:, None, :], gb)[:, 0, :]
    h_ab = (form_combination(w, B).transpose(0, 2, 1)
            - wga[:, :, None] * b[:, None, :] / nb2[:, None, None]
            - a[:, :, None] * wgb[:, None, :] / na2[:, None, None]
            + (fw / (na2 * nb2))[:, None, None] * a[:, :, None] * b[:, None, :])
    hess[:, :4, :4] += h_aa
    hess[:, 4:, 4:] += h_bb
    hess[:, :4, 4:] += h_ab
    hess[:, 4:, :4] += h_ab.transpose(0, 2, 1)
    return -hess


@dataclass(frozen=True, kw_only=True)
class BendTwistOptions(Options):
    """The options of the ``bend_twist`` term: one field per
    parameter, checked against them when the term class is defined."""

    stiffness: str = "corrected"
    twist_stiffness: float = 0.0


class BendTwist(RodTerm):
    """Bending about d1, d2 and twisting about d3, Eqs. (7)–(8)."""

    name = "bend_twist"
    figure_layer = "shape"
    Options = BendTwistOptions
    options: BendTwistOptions
    equation = "Eqs. (3), (7), (8)"
    strain_kinds = ("bending", "twist")
    parameters = (
        Parameter("stiffness", "str", "corrected", "-",
                  "stiffness tensor: 'corrected' (Eq. 8) or 'corde' (Fig. 9 only)",
                  choices=("corrected", "corde")),
        Parameter("twist_stiffness", "float", 0.0, "N*m^2",
                  "K_33 override; 0 keeps G J of Eq. (8). For a round tendon, whose twist "
                  "couples to nothing, a larger value removes a near-null mode", 0.0, 1e6),
    )

    def __init__(self, rod: Rod, options: BendTwistOptions) -> None:
        super().__init__(rod, options)
        quat = rod.layout.quaternion_index
        seg = rod.geometry.segment_length
        middles = rod.geometry.segment_s
        held = {support.node: support.frame for support in rod.node_supports
                if support.frame_element}
        # Elements (a, b, fixed side, frame, dual interval): a constant frame's side repeats
        # the free side's indices, its entries zeroed (rodsim/core/kernels/bend_twist.py).
        elements: list[tuple[np.ndarray, np.ndarray, int, np.ndarray, float, float]] = []
        none = np.zeros(4)
        if rod.support.frame_element:  # (q_c, q_0) at the base, l̄ = l/2
            elements.append((quat[0], quat[0], 1, rod.support.frame, 0.0, 0.5 * seg))
        for node in range(1, len(quat) + 1):
            s_node = node * seg
            if node in held:  # (q_{k−1}, q_c) and (q_c, q_k), each l̄ = l/2
                elements.append((quat[node - 1], quat[node - 1], 2, held[node],
                                 middles[node - 1], s_node))
                if node < len(quat):
                    elements.append((quat[node], quat[node], 1, held[node], s_node,
                                     middles[node]))
            elif node < len(quat):
                elements.append((quat[node - 1], quat[node], 0, none, middles[node - 1],
                                 middles[node]))
        self.dofs = np.array([np.concatenate(e[:2]) for e in elements], dtype=np.int64
                             ).reshape(-1, 8)
        #: Per element: 0, or the side (1: a, 2: b) that is a support's constant frame.
        self._fixed = np.array([e[2] for e in elements], dtype=np.int8)
        self._frames = np.array([e[3] for e in elements], dtype=float).reshape(-1, 4)
        starts = np.array([e[4] for e in elements], dtype=float)
        ends = np.array([e[5] for e in elements], dtype=float)
        self._dual_lengths = np.where(self._fixed == 0, seg, 0.5 * seg)
        #: (K_11, K_22, K_33) of each element, shape (n_elem, 3) (Eq. 8; sections: docs/model.md)
        self._stiffness = element_stiffness(rod, options.stiffness, options.twist_stiffness,
                                            starts, ends)

    def kernel_arguments(self) -> KernelArguments:
        return {"dofs": self.dofs, "dual_lengths": self._dual_lengths,
                "stiffness": self._stiffness, "fixed": self._fixed, "frames": self._frames}

    def _pairs(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a, b = x[self.dofs[:, :4]], x[self.dofs[:, 4:]]
        a[self._fixed == 1] = self._frames[self._fixed == 1]
        b[self._fixed == 2] = self._frames[self._fixed == 2]
        return a, b

    def _kinematics(self, x: np.ndarray) -> BendKinematics:
        """Strains and the pieces of their derivatives (see ``BendKinematics``)."""
        return bend_kinematics(*self._pairs(x), self._dual_lengths)

    def strains(self, x: np.ndarray) -> np.ndarray:
        """Material strains u_k at every element, shape (n_elem, 3) [1/m] (Eq. 3)."""
        return self._kinematics(x).u

    def energy(self, x: np.ndarray) -> float:
        u = self.strains(x)
        return float(0.5 * np.sum(self._dual_lengths[:, None] * self._stiffness * u**2))

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        forces = bend_forces(*self._pairs(x), self._dual_lengths, self._stiffness)
        forces[self._fixed == 1, :4] = 0.0  # a support's frame does not move
        forces[self._fixed == 2, 4:] = 0.0
        return forces

    def material_stiffness(self, x: np.ndarray, weights: np.ndarray | None = None
                           ) -> np.ndarray:
        """l̄ Σ_k K_k ∇u_k ∇u_kᵀ per element (the strain rates u̇_k = ∇u_k · q̇ with
        stiffnesses l̄ K_k), a support's constant frame's rows and columns zero; ``weights``
        (bending, twist) multiply K_11, K_22 and K_33 (``Term.material_stiffness``)."""
        stiffness = (self._stiffness if weights is None
                     else self._stiffness * np.array([weights[0], weights[0], weights[1]]))
        blocks = _gauss_newton(self._kinematics(x), self._dual_lengths, stiffness)
        for side, block in ((1, slice(0, 4)), (2, slice(4, 8))):
            blocks[self._fixed == side, block, :] = 0.0
            blocks[self._fixed == side, :, block] = 0.0
        return blocks

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        jacobians = bend_jacobians(*self._pairs(x), self._dual_lengths, self._stiffness)
        for side, block in ((1, slice(0, 4)), (2, slice(4, 8))):
            jacobians[self._fixed == side, block, :] = 0.0
            jacobians[self._fixed == side, :, block] = 0.0
        return jacobians
