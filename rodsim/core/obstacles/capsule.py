"""A rigid capsule (a segment with a radius: a tool shaft, a bone, a neighbouring catheter):
the rod stays outside.

With a, b the segment's ends, w = b − a, the nearest point's parameter
t = clamp((p − a) · w / |w|², 0, 1), q = a + t w, r = p − q, d = |r|, e = r/d:

    φ = d − R,     ∇φ = e,
    ∇²φ = (I − e eᵀ − ŵ ŵᵀ)/d   beside the segment (0 < t < 1; ŵ = w/|w|: a cylinder),
    ∇²φ = (I − e eᵀ)/d          beyond an end (a sphere around it).

φ and ∇φ are continuous; ∇²φ jumps where a cylinder meets an end's sphere (the capsule's
surface is C¹ there, as a capsule is), which the Newton iterations cross as they cross the
onset of contact elsewhere.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.obstacles import Obstacle
from rodsim.core.obstacles._drawing import sphere_mesh, tube_mesh
from rodsim.core.schema import Parameter, SceneError


class Capsule(Obstacle):
    """The points within R of the segment a–b are solid."""

    type = "capsule"
    kernel = "contact_capsule"
    example = {"start": [0.06, -0.012, -0.02], "end": [0.06, -0.012, 0.02], "radius": 0.008}
    parameters = (
        Parameter("start", "vector", None, "m", "one end a of the segment", -1e3, 1e3,
                  length=3),
        Parameter("end", "vector", None, "m", "the other end b of the segment", -1e3, 1e3,
                  length=3),
        Parameter("radius", "float", None, "m", "radius R around the segment", 0.0, 1e3,
                  exclusive_minimum=True),
    )

    @classmethod
    def resolve(cls, table: dict[str, Any], prefix: str) -> dict[str, Any]:
        if np.array_equal(np.asarray(table["start"], float), np.asarray(table["end"], float)):
            raise SceneError(f"{prefix}.end = {table['end']!r}: the segment's ends coincide; "
                             "allowed: distinct start and end (a ball is type = 'sphere')")
        return table

    def __init__(self, name: str, table: Any) -> None:
        super().__init__(name, table)
        self.start = np.asarray(table["start"], dtype=float)
        self.end = np.asarray(table["end"], dtype=float)
        self.radius = float(table["radius"])

    def gap(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        w = self.end - self.start
        t = ((points - self.start) @ w) / (w @ w)
        beside = (t > 0.0) & (t < 1.0)
        q = self.start + np.clip(t, 0.0, 1.0)[:, None] * w
        r = points - q
        d = np.maximum(np.linalg.norm(r, axis=1), 1e-300)
        e = r / d[:, None]
        axis = w / np.linalg.norm(w)
        hess = (np.eye(3) - e[:, :, None] * e[:, None, :]
                - beside[:, None, None] * np.outer(axis, axis)) / d[:, None, None]
        return d - self.radius, e, hess

    def kernel_arguments(self) -> dict[str, Any]:
        return {"start": self.start, "end": self.end, "capsule_radius": self.radius}

    def surface(self, lower: np.ndarray, upper: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray] | None:
        """The cylinder around the segment and a sphere at each end."""
        w = self.end - self.start
        parts = [tube_mesh(np.array([self.start, self.end]), np.array([w, w]),
                           np.full(2, self.radius)),
                 sphere_mesh(self.start, self.radius), sphere_mesh(self.end, self.radius)]
        vertices, triangles, offset = [], [], 0
        for v, f in parts:
            vertices.append(v)
            triangles.append(f + offset)
            offset += len(v)
        return np.concatenate(vertices), np.concatenate(triangles)
