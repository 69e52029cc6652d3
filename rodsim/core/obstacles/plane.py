"""A rigid plane (tissue): the free side is where the normal points.

φ(p) = n · (p − p₀) with n the unit normal; ∇φ = n, ∇²φ = 0.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.obstacles import PLANE, Obstacle
from rodsim.core.schema import Parameter, SceneError


class Plane(Obstacle):
    """The half-space n · (p − p₀) < 0 is solid."""

    type = "plane"
    kind = PLANE
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

    def kernel_data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return (np.concatenate([self.point, self.normal]), np.zeros(0), np.zeros((0, 4, 3)),
                np.zeros((0, 4)))
