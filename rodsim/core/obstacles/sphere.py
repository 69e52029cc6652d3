"""A rigid sphere (tissue, an organ's bulge): the rod stays outside.

φ(p) = |p − c| − R; with e = (p − c)/|p − c|: ∇φ = e, ∇²φ = (I − e eᵀ)/|p − c|.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.obstacles import SPHERE, Obstacle
from rodsim.core.schema import Parameter


class Sphere(Obstacle):
    """A solid ball of radius R around c."""

    type = "sphere"
    kind = SPHERE
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

    def kernel_data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return (np.concatenate([self.center, [self.radius]]), np.zeros(0),
                np.zeros((0, 4, 3)), np.zeros((0, 4)))
