"""A rigid plane (tissue): the free side is where the normal points.

φ(p) = n · (p − p₀) with n the unit normal; ∇φ = n, ∇²φ = 0.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.obstacles import Obstacle
from rodsim.core.obstacles._drawing import plane_patch
from rodsim.core.schema import Parameter, SceneError


class Plane(Obstacle):
    """The half-space n · (p − p₀) < 0 is solid."""

    type = "plane"
    kernel = "contact_plane"
    example = {"point": [0.0, -0.004, 0.0], "normal": [0.0, 1.0, 0.0]}
    parameters = (
        Parameter("point", "vector", None, "m", "a point of the plane", -1e3, 1e3, length=3),
        Parameter("normal", "vector", None, "-",
                  "normal pointing to the free side (normalised)", -1e3, 1e3, length=3),
    )

    @classmethod
    def resolve(cls, table: dict[str, Any], prefix: str) -> dict[str, Any]:
        if float(np.linalg.norm(table["normal"])) == 0.0:
            raise SceneError(f"{prefix}.normal = {table['normal']!r}: a zero vector; allowed: "
                             "a non-zero vector")
        return table

    def __init__(self, name: str, table: Any) -> None:
        super().__init__(name, table)
        normal = np.asarray(table["normal"], dtype=float)
        self.normal = normal / np.linalg.norm(normal)
        self.point = np.asarray(table["point"], dtype=float)

    def gap(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = len(points)
        phi = (points - self.point) @ self.normal
        return phi, np.tile(self.normal, (n, 1)), np.zeros((n, 3, 3))

    def kernel_arguments(self) -> dict[str, Any]:
        return {"point": self.point, "normal": self.normal}

    def free_half_space(self) -> tuple[np.ndarray, np.ndarray]:
        """The free side n · (p − p₀) > 0."""
        return self.normal, self.point

    def outline(self, view: tuple[int, int], level: float, lower: np.ndarray,
                upper: np.ndarray) -> list[np.ndarray]:
        """The plane's trace across the box (none when the view lies in the plane)."""
        a, b = view
        n = self.normal
        if np.hypot(n[a], n[b]) < 1e-12:
            return []
        direction = np.zeros(3)
        direction[a], direction[b] = -n[b], n[a]
        direction /= np.linalg.norm(direction)
        base = np.asarray(lower + upper, dtype=float) / 2
        base[3 - a - b] = level
        # the point of the trace nearest the box's centre: along the in-view normal
        inplane = np.zeros(3)
        inplane[a], inplane[b] = n[a], n[b]
        base = base - ((base - self.point) @ n) / (inplane @ n) * inplane
        reach = float(np.linalg.norm(upper - lower))
        return [np.array([base - reach * direction, base + reach * direction])]

    def surface(self, lower: np.ndarray, upper: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray] | None:
        """A square of the plane as wide as the box's diagonal."""
        return plane_patch(self.point, self.normal, lower, upper)
