"""Hanging mass (or any constant force) at the rod's tip — the load of the paper's §3 scenes.

    V = −F · r_{N−1},   F = m g d̂ + F_extra,

d̂ the direction the mass hangs along (``direction``, −y by default: the paper's; set it as
the rod's ``gravity.direction`` when gravity pulls elsewhere).

A dead load: its force does not depend on the state, so it adds no Jacobian entries.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter
from rodsim.core.terms._dead_load import STANDARD_GRAVITY, unit_direction
from rodsim.core.terms.base import KernelArguments, RodTerm


@dataclass(frozen=True, kw_only=True)
class TipLoadOptions(Options):
    """The options of the ``tip_load`` term: one field per
    parameter, checked against them when the term class is defined."""

    mass: float = 0.0
    force: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    gravity: float = 9.81
    direction: list[float] = field(default_factory=lambda: [0.0, -1.0, 0.0])


class TipLoad(RodTerm):
    """Constant force on the last control point (hanging mass, Figs. 5–9)."""

    name = "tip_load"
    figure_layer = "load"
    Options = TipLoadOptions
    options: TipLoadOptions
    equation = "§3 (hanging mass); enters F_net of Eq. (17)"
    is_load = True
    has_jacobian = False
    kernel = "constant_force"
    parameters = (
        Parameter("mass", "float", 0.0, "kg", "hanging mass at the tip, pulling along "
                  "direction (−y by default)", 0.0, 1e6),
        Parameter("force", "vector", [0.0, 0.0, 0.0], "N", "extra constant force at the tip",
                  -1e7, 1e7, length=3),
        Parameter("gravity", "float", STANDARD_GRAVITY, "m/s^2", "gravitational acceleration",
                  0.0, 1e3),
        Parameter("direction", "vector", [0.0, -1.0, 0.0], "-",
                  "direction the hanging mass pulls along, world frame (normalised; not zero): "
                  "the rod's gravity.direction where gravity pulls elsewhere than −y",
                  -1e3, 1e3, length=3),
    )

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        unit_direction(options.direction, f"{prefix}.direction")

    def __init__(self, rod: Rod, options: TipLoadOptions) -> None:
        super().__init__(rod, options)
        self.dofs = rod.layout.position_index[-1:]
        self.force = np.asarray(options.force, dtype=float) + (
            options.mass * options.gravity
            * unit_direction(options.direction, f"rods.{rod.name}.tip_load.direction"))

    def point_masses(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The hanging mass's inertia at the tip (natural frequencies, docs/dynamics.md);
        ``None`` without a mass (a ``force`` alone is massless)."""
        if self.options.mass <= 0.0:
            return None
        return self.dofs.copy(), np.array([float(self.options.mass)])

    def kernel_arguments(self) -> KernelArguments:
        return {"forces": self.force[None, :].copy()}

    def energy(self, x: np.ndarray) -> float:
        return float(-self.force @ x[self.dofs[0]])

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        return self.force[None, :]
