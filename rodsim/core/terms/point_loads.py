"""Point wrenches (force and moment) at any arclength s of a rod (not in the paper).

Each load ``{s, force, moment, frame}`` acts at rest arclength s ∈ [0, L] of the rod. With
the segment j that contains s (l its rest length, s = (j + t) l, t ∈ [0, 1]; a load at an
interior node acts on the segment that starts there, one at s = L on the last segment):

- the force acts at the centerline point r(s) = (1 − t) r_j + t r_{j+1}, so its virtual work
  F · δr(s) puts (1 − t) F on r_j and t F on r_{j+1} (the linear interpolation's consistent
  share; a force at a node goes to that node only);
- the moment acts on the segment's quaternion q = q_j through the angular variation
  δθ = Σ_k δΩ_k d̂_k, δΩ_k = 2 (B_k q) · δq / |q|² (B_k of Eq. 4, the same form as the
  strains of Eq. 3), so its generalised force is Q = (2 / |q|²) Σ_k m_k B_k q with m_k the
  moment's components on the unit directors d̂_k = d_k / |q|² (Eq. 2).

``frame = "world"``: force and moment are fixed in the world frame. The force is a dead
load (energy −F · r(s), no Jacobian); the moment is not conservative under large 3-D
rotations (a fixed-axis moment has no potential on SO(3)), m_k = M · d̂_k(q) depends on q
and gets its exact, non-symmetric Jacobian.
``frame = "body"``: components on the segment's directors (d1, d2, d3), a follower load:
F = Σ_k f_k d̂_k(q) and m_k constant, with their analytic Jacobians; not conservative.

One element per load, coordinates (r_j, r_{j+1}, q_j) (the centerline penalty's element, so
no new Jacobian pattern). The term is conservative (and has no Jacobian) when every load is
a world-frame force without moment.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.rod.quaternion import B, director, director_gradient
from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Parameter, SceneError, shown
from rodsim.core.terms.base import RodTerm

#: Frames a load's components may be given in.
LOAD_FRAMES = ("world", "body")

LOAD_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("s", "float", None, "m", "rest arclength where the load acts, 0 <= s <= L",
              0.0, 100.0),
    Parameter("force", "vector", [0.0, 0.0, 0.0], "N", "point force", -1e7, 1e7, length=3),
    Parameter("moment", "vector", [0.0, 0.0, 0.0], "N*m", "point moment", -1e7, 1e7,
              length=3),
    Parameter("frame", "str", "world", "-",
              "'world' (fixed components; the force is a dead load) or 'body' (components "
              "on the directors d1, d2, d3 of the segment holding s: a follower load)",
              choices=LOAD_FRAMES),
)


def segment_of(s: np.ndarray, segment_length: float, segments: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """Segment index j holding each arclength ``s`` and the position t ∈ [0, 1] in it
    (s = (j + t) l; an interior node belongs to the segment it starts, s = L to the last)."""
    j = np.minimum(np.floor(s / segment_length).astype(int), segments - 1)
    t = np.clip(s / segment_length - j, 0.0, 1.0)
    return j, t


class PointLoads(RodTerm):
    """Point forces and moments at any arclength, world or body frame."""

    name = "point_loads"
    equation = "point wrenches (not in the paper); enter F_net of Eq. (17)"
    is_load = True
    parameters = (
        Parameter("loads", "tables", [], "-",
                  "the point loads, one [[rods.<name>.point_loads.loads]] table each",
                  items=LOAD_PARAMETERS),
    )

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        for i, load in enumerate(options.loads):
            if load["s"] > owner.length:
                raise SceneError(f"{prefix}.loads.{i}.s = {shown(load['s'])}: beyond the "
                                 f"rod's length {owner.length!r} m; allowed: 0 <= s <= length",
                                 key=f"{prefix}.loads.{i}.s", value=load["s"],
                                 reason="out of range")

    def __init__(self, rod: Rod, options: Any) -> None:
        super().__init__(rod, options)
        loads = options.loads
        n = len(loads)
        s = np.array([load["s"] for load in loads], dtype=float)
        j, t = segment_of(s, rod.geometry.segment_length, rod.geometry.segments)
        pos, quat = rod.layout.position_index, rod.layout.quaternion_index
        self.dofs = (np.concatenate([pos[j], pos[j + 1], quat[j]], axis=1) if n
                     else np.zeros((0, 10), dtype=int))
        self._weights = np.stack([1.0 - t, t], axis=1) if n else np.zeros((0, 2))
        body = np.array([load["frame"] == "body" for load in loads], dtype=bool)
        force = np.array([load["force"] for load in loads], dtype=float).reshape(n, 3)
        moment = np.array([load["moment"] for load in loads], dtype=float).reshape(n, 3)
        self._world_force = np.where(body[:, None], 0.0, force)
        self._body_force = np.where(body[:, None], force, 0.0)
        self._world_moment = np.where(body[:, None], 0.0, moment)
        self._body_moment = np.where(body[:, None], moment, 0.0)
        follower = bool(np.any(self._body_force) or np.any(moment))
        self.has_jacobian = follower
        self.conservative = not follower

    def kernel_arguments(self) -> tuple:
        return (self.dofs, self._weights, self._world_force, self._body_force,
                self._world_moment, self._body_moment, bool(self.has_jacobian))

    def energy(self, x: np.ndarray) -> float | None:
        """−Σ F · r(s) for world-frame forces; ``None`` if any load is a follower or a moment."""
        if not self.conservative:
            return None
        point = (self._weights[:, :1] * x[self.dofs[:, :3]]
                 + self._weights[:, 1:] * x[self.dofs[:, 3:6]])
        return float(-np.sum(self._world_force * point))

    def _state(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """q (n, 4), |q|², the unnormalised directors d_k (n, 3, 3: [e, k, m]) and their
        gradients ∂d_k/∂q (n, 3, 3, 4: [e, k, m, a])."""
        q = x[self.dofs[:, 6:]]
        n2 = np.sum(q * q, axis=1)
        d = np.stack([director(q, k) for k in range(3)], axis=1)
        g = np.stack([director_gradient(q, k) for k in range(3)], axis=1)
        return q, n2, d, g

    def _moments(self, d: np.ndarray, n2: np.ndarray) -> np.ndarray:
        """m_k: body moment plus the world moment on the unit directors, (n, 3)."""
        return self._body_moment + np.einsum("nm,nkm->nk", self._world_moment, d) / n2[:, None]

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(self.dofs.shape)
        if not self.has_jacobian:
            out[:, :3] = self._weights[:, :1] * self._world_force
            out[:, 3:6] = self._weights[:, 1:] * self._world_force
            return out
        q, n2, d, _ = self._state(x)
        force = self._world_force + np.einsum("nk,nkm->nm", self._body_force, d) / n2[:, None]
        m = self._moments(d, n2)
        bq = np.einsum("kab,nb->nka", B, q)  # B_k q, (n, 3, 4)
        out[:, :3] = self._weights[:, :1] * force
        out[:, 3:6] = self._weights[:, 1:] * force
        out[:, 6:] = 2.0 * np.einsum("nk,nka->na", m, bq) / n2[:, None]
        return out

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        q, n2, d, g = self._state(x)
        n = len(q)
        out = np.zeros((n, 10, 10))
        # F = F_w + Σ_k f_k d_k / |q|²:  ∂F/∂q = Σ_k f_k (G_k / |q|² − d_k 2qᵀ / |q|⁴)
        dforce = (np.einsum("nk,nkma->nma", self._body_force, g) / n2[:, None, None]
                  - 2.0 * np.einsum("nk,nkm,na->nma", self._body_force, d, q)
                  / (n2**2)[:, None, None])
        out[:, :3, 6:] = self._weights[:, :1, None] * dforce
        out[:, 3:6, 6:] = self._weights[:, 1:, None] * dforce
        # Q = (2/|q|²) Σ_k m_k B_k q, m_k = m_b,k + M · d_k / |q|²
        m = self._moments(d, n2)
        dm = (np.einsum("nm,nkma->nka", self._world_moment, g) / n2[:, None, None]
              - 2.0 * np.einsum("nm,nkm,na->nka", self._world_moment, d, q)
              / (n2**2)[:, None, None])  # ∂m_k/∂q, (n, 3, 4)
        bq = np.einsum("kab,nb->nka", B, q)
        moment_force = 2.0 * np.einsum("nk,nka->na", m, bq) / n2[:, None]
        out[:, 6:, 6:] = (2.0 * (np.einsum("nk,kab->nab", m, B)
                                 + np.einsum("nka,nkb->nab", bq, dm)) / n2[:, None, None]
                          - 2.0 * moment_force[:, :, None] * q[:, None, :]
                          / n2[:, None, None])
        return out
