"""A rigid sphere (tissue, an organ's bulge): the rod stays outside.

φ(p) = |p − c| − R; with e = (p − c)/|p − c|: ∇φ = e, ∇²φ = (I − e eᵀ)/|p − c|.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.obstacles import Obstacle
from rodsim.core.obstacles._drawing import sphere_mesh
from rodsim.core.schema import Parameter


class Sphere(Obstacle):
    """A solid ball of radius R around c."""

    type = "sphere"
    kernel = "contact_sphere"
    example = {"center": [0.07, -0.02, 0.0], "radius": 0.015}
    parameters = (
        Parameter("center", "vector", None, "m", "centre c", -1e3, 1e3, length=3),
        Parameter("radius", "float", None, "m", "radius R", 0.0, 1e3, exclusive_minimum=True),
    )

    def __init__(self, name: str, table: Any) -> None:
        super().__init__(name, table)
        self.center = np.asarray(table["center"], dtype=float)
        self.radius = float(table["radius"])

    def gap(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        r = points - self.center
        d = np.maximum(np.linalg.norm(r, axis=1), 1e-300)
        e = r / d[:, None]
        hess = (np.eye(3) - e[:, :, None] * e[:, None, :]) / d[:, None, None]
        return d - self.radius, e, hess

    def kernel_arguments(self) -> dict[str, Any]:
        return {"center": self.center, "sphere_radius": self.radius}

    def outline(self, view: tuple[int, int], level: float, lower: np.ndarray,
                upper: np.ndarray) -> list[np.ndarray]:
        """The circle the plane at ``level`` cuts (none when it misses the ball)."""
        a, b = view
        depth = 3 - a - b
        cut = self.radius**2 - (level - self.center[depth]) ** 2
        if cut <= 0.0:
            return []
        angle = np.linspace(0.0, 2 * np.pi, 181)
        circle = np.tile(self.center, (len(angle), 1))
        circle[:, a] += np.sqrt(cut) * np.cos(angle)
        circle[:, b] += np.sqrt(cut) * np.sin(angle)
        circle[:, depth] = level
        return [circle]

    def surface(self, lower: np.ndarray, upper: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray] | None:
        """The whole sphere."""
        return sphere_mesh(self.center, self.radius)
