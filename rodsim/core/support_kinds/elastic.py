"""The elastic base support, ``clamp = "elastic"`` (docs/model.md, "Supports and anchors"):
the rod's base held by springs instead of rigidly.

A catheter's base is rarely rigid: a handle, an introducer sheath or a motor stage gives
under load. The kind declares the scene keys (``[rods.<rod>.base]``
``translational_stiffness``, ``rotational_stiffness``, ``torsional_stiffness``) and its
energy, evaluated by the generic support term (rodsim/core/terms/support_energy.py). With
the support point r_c and frame q_c of the base (its ``origin``, moved and turned by
``[rods.<rod>.base]``):

    E = ½ k_t |r_0 − r_c|²  +  ½ l̄ Σ_k K̃_k u_k(q_c, q_0)²,

the first a zero-length spring of stiffness k_t on the base node, the second the bending
element of Eqs. (3), (7) (rodsim/core/terms/bend_twist.py) between the support frame and the
first segment, l̄ = l/2 as the rigid clamp's (q_c, q_0) element (docs/model.md, "Clamp"),
with the half segment and the spring in series:

    K̃_k / l̄ = 1 / (l̄ / K_k + 1 / k_k),   k_1 = k_2 = k_b (``rotational_stiffness``),
                                          k_3 = k_τ (``torsional_stiffness``), N·m/rad,

so that a small turn φ of the rod's end about d_k stores ½ (K̃_k / l̄) φ², and a spring of
stiffness 0 passes no moment about its axes (k_b = 0: a pin that bends freely). As
k_t, k_b, k_τ → ∞ the element is the rigid clamp's and the model the ``frame`` clamp's,
second order in N as it is; with finite springs a cantilever under a tip force F gives
the tip F L³/(3 E I) + F L²/k_b + F/k_t (tests/test_elastic_support.py,
tests/test_elastic_base.py). For large turns the spring's energy is that of the discrete
strain, 2 k (sin(φ/2))² (1 + O(l/L)) — a rotational spring whose moment falls off as
cos(φ/2) past small angles. Its compiled kernel: rodsim/core/kernels/elastic_base.py.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from rodsim.core.schema import Parameter, SceneError
from rodsim.core.supports import Support, SupportKind

__all__ = ["ElasticSupport"]


class ElasticSupport(SupportKind):
    """The base held at its place r_c and frame q_c by linear springs instead of rigidly
    (module docstring). Nothing is fixed and no frame element is given to the bending
    term: the springs' series element replaces it."""

    name = "elastic"
    doc = ("position and frame at s = 0 held by springs: [rods.<rod>.base] "
           "translational_stiffness, rotational_stiffness")
    base_parameters = (
        Parameter("translational_stiffness", "float", None, "N/m",
                  "clamp = 'elastic': spring k_t holding the base node at its place (the "
                  "origin, moved by insertion)", 0.0, 1e15, exclusive_minimum=True),
        Parameter("rotational_stiffness", "float", None, "N*m/rad",
                  "clamp = 'elastic': spring k_b holding the first segment's turn about the "
                  "bending axes d1, d2 of the base frame (and about d3 unless "
                  "torsional_stiffness is set; 0: a pin that passes no moment)", 0.0, 1e15),
        Parameter("torsional_stiffness", "float", 0.0, "N*m/rad",
                  "clamp = 'elastic': spring k_tau about the rod's axis d3 at the base (0: "
                  "rotational_stiffness)", 0.0, 1e15),
    )
    has_energy = True
    energy_kernel = "elastic_base"
    former_terms = ("elastic_base",)
    former_keys = (" (the elastic_base term's stiffness is translational_stiffness; a "
                   "torsional_stiffness of 0 or none takes rotational_stiffness)")

    @classmethod
    def check_base(cls, rod: str, holders: list[str], pulled: bool,
                   holder_terms: Sequence[str] = ()) -> None:
        if holders:
            raise SceneError(f"rods.{rod}.clamp = 'elastic': the base is also held by "
                             f"rods.{rod}.{holders[0]}; allowed: one of them")

    @classmethod
    def energy_values(cls, base: Mapping[str, Any]) -> Sequence[float]:
        """(k_t, k_b, k_τ) of a resolved ``[rods.<rod>.base]`` (k_τ = k_b when 0)."""
        rotational = float(base["rotational_stiffness"])
        return [float(base["translational_stiffness"]), rotational,
                float(base["torsional_stiffness"]) or rotational]

    @classmethod
    def energy_constants(cls, values: Sequence[float], support: Support,
                         rod: Any) -> dict[str, Any]:
        """k_t (``stiffness``), r_c (``point``), q_c (``frame``, (1, 4)), l̄ = l/2
        (``dual_lengths``, (1,)) and K̃_k (``bend_stiffness``, (1, 3): zero where k_k is)."""
        from rodsim.core.terms.bend_twist import element_stiffness  # the kinds load first

        stiffness, rotational, torsional = (float(v) for v in values)
        half = 0.5 * rod.geometry.segment_length
        springs = np.array([rotational, rotational, torsional], dtype=float)
        rod_stiffness = element_stiffness(rod, "corrected", 0.0, np.zeros(1),
                                          np.array([half]))[0]
        with np.errstate(divide="ignore"):
            series = np.where(springs > 0.0, half / (half / rod_stiffness + 1.0 / springs),
                              0.0)
        return {"stiffness": stiffness, "point": np.asarray(support.position, dtype=float),
                "frame": np.asarray(support.frame, dtype=float)[None, :],
                "dual_lengths": np.array([half]), "bend_stiffness": series[None, :]}

    @staticmethod
    def _pair(constants: Mapping[str, Any], x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(q_c, q_0) as the bending element's two sides, (1, 4) each."""
        return constants["frame"].copy(), np.array(x[None, 3:7])

    @classmethod
    def energy(cls, constants: Mapping[str, Any], x: np.ndarray) -> float:
        from rodsim.core.terms.bend_twist import bend_kinematics

        gap = x[:3] - constants["point"]
        dual, springs = constants["dual_lengths"], constants["bend_stiffness"]
        u = bend_kinematics(*cls._pair(constants, x), dual).u
        return float(0.5 * constants["stiffness"] * gap @ gap
                     + 0.5 * np.sum(dual[:, None] * springs * u**2))

    @classmethod
    def forces(cls, constants: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
        from rodsim.core.terms.bend_twist import bend_forces

        pull = -constants["stiffness"] * (x[:3] - constants["point"])
        turn = bend_forces(*cls._pair(constants, x), constants["dual_lengths"],
                           constants["bend_stiffness"])[0, 4:]
        return np.concatenate([pull, turn])

    @classmethod
    def jacobian(cls, constants: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
        from rodsim.core.terms.bend_twist import bend_jacobians

        jac = np.zeros((7, 7))
        jac[:3, :3] = -constants["stiffness"] * np.eye(3)
        jac[3:, 3:] = bend_jacobians(*cls._pair(constants, x), constants["dual_lengths"],
                                     constants["bend_stiffness"])[0, 4:, 4:]
        return jac
