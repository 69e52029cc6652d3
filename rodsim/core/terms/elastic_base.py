"""The energy of the elastic base support, ``clamp = "elastic"`` (``ElasticSupport``,
rodsim/core/supports.py; docs/model.md, "Supports and anchors"): the rod's base held by
springs instead of rigidly.

A catheter's base is rarely rigid: a handle, an introducer sheath or a motor stage gives
under load. The support kind declares the scene keys (``[rods.<rod>.base]``
``translational_stiffness``, ``rotational_stiffness``, ``torsional_stiffness``) and adds this
term, of scope ``"support"``: no scene lists it (a rod that does is pointed to the kind,
``SupportKind.refuse_listed``). With the support point r_c and frame q_c of the base (its
``origin``, moved and turned by ``[rods.<rod>.base]``):

    E = ½ k_t |r_0 − r_c|²  +  ½ l̄ Σ_k K̃_k u_k(q_c, q_0)²,

the first a zero-length spring of stiffness k_t (``stiffness``, N/m) on the base node, the
second the bending element of Eqs. (3), (7) (rodsim/core/terms/bend_twist.py) between the
support frame and the first segment, l̄ = l/2 as the rigid clamp's (q_c, q_0) element
(docs/model.md, "Clamp"), with the half segment and the spring in series:

    K̃_k / l̄ = 1 / (l̄ / K_k + 1 / k_k),   k_1 = k_2 = k_b (``rotational_stiffness``),
                                          k_3 = k_τ (``torsional_stiffness``), N·m/rad,

so that a small turn φ of the rod's end about d_k stores ½ (K̃_k / l̄) φ², and a spring of
stiffness 0 passes no moment about its axes (k_b = 0: a pin that bends freely). As
k_t, k_b, k_τ → ∞ the element is the rigid clamp's and the model the ``frame`` clamp's,
second order in N as it is; with finite springs a cantilever under a tip force F gives
the tip F L³/(3 E I) + F L²/k_b + F/k_t (tests/test_elastic_support.py,
tests/test_elastic_base.py). For large turns the
spring's energy is that of the discrete strain, 2 k (sin(φ/2))² (1 + O(l/L)) — a
rotational spring whose moment falls off as cos(φ/2) past small angles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter
from rodsim.core.terms.base import KernelArguments, RodTerm
from rodsim.core.terms.bend_twist import (
    bend_forces,
    bend_jacobians,
    bend_kinematics,
    element_stiffness,
)


@dataclass(frozen=True, kw_only=True)
class ElasticBaseOptions(Options):
    """The options of the ``elastic_base`` term (built by ``ElasticSupport.terms`` from the
    base's keys): one field per parameter, checked against them when the term class is
    defined."""

    stiffness: float
    rotational_stiffness: float
    torsional_stiffness: float


class ElasticBase(RodTerm):
    """The rod's base node held at its support point by a spring and its first segment at
    the support frame by rotational springs (module docstring): the energy of the
    ``elastic`` support kind."""

    name = "elastic_base"
    scope = "support"
    figure_layer = "shape"
    Options = ElasticBaseOptions
    options: ElasticBaseOptions
    equation = "support (not in the paper); Eqs. (3), (7), (8) for the frame"
    parameters = (
        Parameter("stiffness", "float", None, "N/m",
                  "translational spring k_t holding the base node at its support point "
                  "(the rod's origin, moved by [rods.<rod>.base])", 1e-9, 1e15),
        Parameter("rotational_stiffness", "float", None, "N*m/rad",
                  "rotational spring k_b about the two bending axes d1, d2 at the base (0: "
                  "a pin that passes no bending moment)", 0.0, 1e15),
        Parameter("torsional_stiffness", "float", None, "N*m/rad",
                  "rotational spring k_tau about the rod's axis d3 at the base (0: the base "
                  "turns freely about it)", 0.0, 1e15),
    )

    def __init__(self, rod: Rod, options: ElasticBaseOptions) -> None:
        super().__init__(rod, options)
        support = rod.support
        layout = rod.layout
        half = 0.5 * rod.geometry.segment_length
        self._stiffness = float(options.stiffness)
        self._point = np.asarray(support.position, dtype=float)
        self._frame = np.asarray(support.frame, dtype=float)[None, :]
        self._dual_lengths = np.array([half])
        springs = np.array([options.rotational_stiffness, options.rotational_stiffness,
                            options.torsional_stiffness], dtype=float)
        rod_stiffness = element_stiffness(rod, "corrected", 0.0, np.zeros(1),
                                          np.array([half]))[0]
        #: K̃_k, (1, 3): l̄ / (l̄/K_k + 1/k_k), zero where k_k is (no moment about d_k).
        with np.errstate(divide="ignore"):
            series = np.where(springs > 0.0, half / (half / rod_stiffness + 1.0 / springs),
                              0.0)
        self._bend_stiffness = series[None, :]
        self.dofs = np.concatenate([layout.position_index[0],
                                    layout.quaternion_index[0]])[None, :]  # (r_0, q_0)

    def kernel_arguments(self) -> KernelArguments:
        return {"dofs": self.dofs, "stiffness": self._stiffness, "point": self._point,
                "frame": self._frame, "dual_lengths": self._dual_lengths,
                "bend_stiffness": self._bend_stiffness}

    def _pair(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self._frame.copy(), x[self.dofs[:, 3:7]]

    def energy(self, x: np.ndarray) -> float:
        gap = x[self.dofs[0, :3]] - self._point
        u = bend_kinematics(*self._pair(x), self._dual_lengths).u
        return float(0.5 * self._stiffness * gap @ gap
                     + 0.5 * np.sum(self._dual_lengths[:, None] * self._bend_stiffness * u**2))

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        pull = -self._stiffness * (x[self.dofs[0, :3]] - self._point)
        turn = bend_forces(*self._pair(x), self._dual_lengths, self._bend_stiffness)[0, 4:]
        return np.concatenate([pull, turn])[None, :]

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        jac = np.zeros((1, 7, 7))
        jac[0, :3, :3] = -self._stiffness * np.eye(3)
        jac[:, 3:, 3:] = bend_jacobians(*self._pair(x), self._dual_lengths,
                                        self._bend_stiffness)[:, 4:, 4:]
        return jac
