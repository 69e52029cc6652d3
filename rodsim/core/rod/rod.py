"""One Cosserat rod of a scene: material, cross-section, rest geometry, support and layout."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from rodsim.core.rod.geometry import RodGeometry
from rodsim.core.rod.layout import RodLayout
from rodsim.core.rod.sections import INHERITED, SectionProfile
from rodsim.core.schema import Options, Parameter
from rodsim.core.supports import CLAMPS, Support, clamp_doc

__all__ = ["Rod", "RodOptions", "ROD_PARAMETERS", "CLAMPS"]

ROD_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("length", "float", None, "m", "rest length L", 1e-6, 100.0),
    Parameter("radius", "float", None, "m", "cross-section radius r (below L: a rod is slender)",
              1e-9, 1.0),
    Parameter("youngs_modulus", "float", None, "Pa", "Young's modulus of bending E_b", 1e-3,
              1e13),
    Parameter("stretch_modulus", "float", None, "Pa",
              "Young's modulus of stretching E_s (if omitted: youngs_modulus, as in an ideal "
              "material)", 1e-3, 1e13),
    Parameter("poisson_ratio", "float", 0.5, "-",
              "Poisson ratio ν; shear modulus G = E_b / (2(1 + ν)) sets the twist stiffness",
              -0.99, 0.5),
    Parameter("density", "float", None, "kg/m^3", "mass density ρ", 1e-3, 1e9),
    Parameter("nodes", "int", None, "-", "number of control points N", 3, 200_000),
    Parameter("clamp", "str", "frame", "-", clamp_doc(), choices=CLAMPS),
    Parameter("origin", "vector", [0.0, 0.0, 0.0], "m", "position of the base r_0", -1e3, 1e3,
              length=3),
    Parameter("terms", "list", ["stretch", "bend_twist", "centerline"], "-",
              "energy terms acting on this rod (`rodsim terms` lists them)"),
)

@dataclass(frozen=True, kw_only=True)
class RodOptions(Options):
    """A validated rod table's own values ([rods.<name>], SI units), typed: one field per
    ``ROD_PARAMETERS`` (checked by tests/test_types.py); its per-term sub-tables are the
    terms' own options (``rodsim.core.terms.base.Term.Options``)."""

    length: float
    radius: float
    youngs_modulus: float
    stretch_modulus: float
    poisson_ratio: float = 0.5
    density: float
    nodes: int
    clamp: str = "frame"
    origin: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    terms: list[str] = field(default_factory=lambda: ["stretch", "bend_twist", "centerline"])


@dataclass(frozen=True)
class Rod:
    """A validated rod table turned into the quantities the terms need.

    Attributes
    ----------
    name
        Key of the rod in the scene (``[rods.<name>]``).
    options
        The rod table's own values (a ``RodOptions``, SI units).
    layout
        Where the rod's coordinates sit in the global state.
    support
        How its base is held and where (rodsim/core/supports.py): the base position r_0
        and the base frame of the rest shape.
    """

    name: str
    options: RodOptions
    layout: RodLayout = field(repr=False)
    support: Support = field(repr=False)
    #: Supports at other nodes than the base (position, or position and frame;
    #: rodsim/core/supports.py).
    node_supports: tuple[Support, ...] = field(default=(), repr=False)
    #: The validated ``[[rods.<name>.sections]]`` spans (empty: a uniform rod).
    sections: tuple[dict[str, Any], ...] = field(default=(), repr=False)

    @property
    def origin(self) -> np.ndarray:
        """Position of the base r_0 [m]: the support's point (the rod's ``origin`` moved by
        its base insertion, or a tendon's lumen entrance)."""
        return self.support.position

    @cached_property
    def geometry(self) -> RodGeometry:
        return RodGeometry(self.options.nodes, self.options.length)

    @cached_property
    def profile(self) -> SectionProfile | None:
        """The rod's spans (``rodsim.core.rod.sections``), ``None`` for a uniform rod."""
        if not self.sections:
            return None
        return SectionProfile.of(self.sections, {name: getattr(self.options, name)
                                                 for name in INHERITED})

    @property
    def varying(self) -> bool:
        """Whether the stiffness or mass per length changes along the rod (the analytic
        references of a uniform rod do not apply)."""
        return self.profile is not None and not self.profile.uniform

    def _whole(self, values: np.ndarray) -> float:
        """Harmonic mean over [0, L] of per-span ``values``."""
        assert self.profile is not None
        return float(self.profile.harmonic_mean(values, np.zeros(1),
                                                np.full(1, self.length))[0])

    @property
    def nodes(self) -> int:
        return int(self.options.nodes)

    @property
    def length(self) -> float:
        return float(self.options.length)

    @property
    def radius(self) -> float:
        return float(self.options.radius)

    @property
    def area(self) -> float:
        """Cross-section area A = π r² [m²]."""
        return math.pi * self.radius**2

    @property
    def second_moment(self) -> float:
        """Area moment of inertia I = π r⁴ / 4 [m⁴] (bending, Eq. 8)."""
        return math.pi * self.radius**4 / 4.0

    @property
    def polar_moment(self) -> float:
        """Polar moment J = π r⁴ / 2 [m⁴] (twist, Eq. 8)."""
        return math.pi * self.radius**4 / 2.0

    @property
    def youngs_modulus(self) -> float:
        return float(self.options.youngs_modulus)

    @property
    def shear_modulus(self) -> float:
        """G = E_b / (2 (1 + ν)) [Pa]."""
        return self.youngs_modulus / (2.0 * (1.0 + self.options.poisson_ratio))

    @property
    def bending_stiffness(self) -> float:
        """E I [N·m²] (Eq. 8); with sections, its harmonic mean over the rod (the uniform rod
        that turns by as much under a constant moment)."""
        if self.profile is not None:
            return self._whole(self.profile.youngs_modulus * self.profile.second_moment)
        return self.youngs_modulus * self.second_moment

    @property
    def stretch_stiffness(self) -> float:
        """K_s = E_s A [N] (Eq. 6); with sections, its harmonic mean over the rod."""
        if self.profile is not None:
            return self._whole(self.profile.stretch_modulus * self.profile.area)
        return float(self.options.stretch_modulus) * self.area

    @property
    def smallest_bending_stiffness(self) -> float:
        """The least E I along the rod [N·m²] (E I of a uniform rod)."""
        if self.profile is not None:
            return float(np.min(self.profile.youngs_modulus * self.profile.second_moment))
        return self.bending_stiffness

    def segment_stretch_stiffness(self) -> np.ndarray:
        """E_s A of every segment [N], shape (N − 1,): the harmonic mean over the segment
        where sections change inside it."""
        if self.profile is None:
            return np.full(self.nodes - 1, self.stretch_stiffness)
        left = np.arange(self.nodes - 1) * self.geometry.segment_length
        return self.profile.harmonic_mean(self.profile.stretch_modulus * self.profile.area,
                                          left, left + self.geometry.segment_length)

    @property
    def density(self) -> float:
        return float(self.options.density)

    @property
    def base_quaternion(self) -> np.ndarray:
        """Orientation of the base frame at s = 0 (the support's frame; the undeformed rod's
        orientation)."""
        return self.support.frame

    def rest_positions(self) -> np.ndarray:
        """Straight rod along +x from ``origin``, shape (N, 3)."""
        x = np.zeros((self.nodes, 3))
        x[:, 0] = self.geometry.node_s
        return x + self.origin

    def rest_quaternions(self) -> np.ndarray:
        """Every segment in the base frame's orientation, shape (N − 1, 4)."""
        return np.tile(self.base_quaternion, (self.nodes - 1, 1))

    def fixed_index(self) -> np.ndarray:
        """Global indices of the coordinates the supports remove (see docs/model.md)."""
        return np.concatenate([self.support.fixed_index(self.layout),
                               *(s.fixed_index(self.layout) for s in self.node_supports)])

    def held_positions(self) -> np.ndarray:
        """The rest state's positions (N, 3) [m] with every node support's node at its
        prescribed place (the value the fixed coordinates keep)."""
        positions = self.rest_positions()
        for support in self.node_supports:
            positions[support.node] = support.position
        return positions

    def support_reaction_scale(self) -> float:
        """Force scale [N] of the node supports' prescribed displacements (0 when none
        moves its node): the reaction a displacement δ of a node held at a span s beyond the
        last held point before it would meet, 3 E I |δ⊥| / s³ across the rod (a
        cantilever's tip stiffness) plus min(E_s A |δ∥| / s, 2.05 π² E I / s²) along it
        (axial stiffness, up to the buckling load of a clamped–pinned column). A scale, not
        a prediction: what F_ref adds for a displacement as it adds a load's size
        (``rodsim.core.model.Model._build_scales``)."""
        if not self.node_supports:
            return 0.0  # (no rest positions to build: every model of new values asks)
        total, held = 0.0, 0.0
        rest = self.rest_positions()
        for support in sorted(self.node_supports, key=lambda support: support.s):
            displacement = support.position - rest[support.node]
            span = support.s - held
            held = support.s
            bending = self.bending_stiffness
            across = float(np.hypot(displacement[1], displacement[2]))
            total += 3.0 * bending * across / span**3 + min(
                self.stretch_stiffness * abs(float(displacement[0])) / span,
                2.05 * math.pi**2 * bending / span**2)
        return total

    def node_masses(self) -> np.ndarray:
        """Lumped mass of each control point, ρ A × (half of each adjacent segment) [kg];
        with sections, the consistent share ∫ ρ A N_i ds."""
        if self.profile is not None:
            return self.profile.node_integral(self.profile.density * self.profile.area,
                                              self.geometry)
        return self.density * self.area * self.geometry.node_mass_fraction

    def pseudo_time_quaternion_masses(self) -> np.ndarray:
        """Generalised mass of each quaternion coordinate [kg·m²].

        The kinetic energy of a segment's rotation is ½ ω·(ρ I l) ω with ω = 2 Q(q)ᵀ q̇ for
        a unit quaternion, i.e. ½ (4 ρ I l) |q̇|² (isotropic approximation with the
        transverse moment I, Eqs. 12–13). Only the pseudo-dynamics use it; the physical
        rotary inertia (ρ I and ρ J, rank 3) is ``rodsim.core.inertia``.
        """
        if self.profile is not None:
            left = np.arange(self.nodes - 1) * self.geometry.segment_length
            return 4.0 * self.profile.integral(self.profile.density * self.profile.second_moment,
                                               left, left + self.geometry.segment_length)
        return np.full(self.nodes - 1, 4.0 * self.density * self.second_moment
                       * self.geometry.segment_length)
