"""Point wrenches (force and moment) at any arclength s of a rod (not in the paper).

Each load ``{s, force, moment, frame}`` acts at rest arclength s ∈ [0, L] of the rod. With
the segment j that contains s (l its rest length, s = (j + t) l, t ∈ [0, 1]; a load at an
interior node acts on the segment that starts there, one at s = L on the last segment):

- the force acts at the centerline point r(s) = (1 − t) r_j + t r_{j+1}, so its virtual work
  F · δr(s) puts (1 − t) F on r_j and t F on r_{j+1} (the linear interpolation's consistent
  share; a force at a node goes to that node only);
- the moment acts on the segment's quaternion q = q_j through the angular variation
  δθ = Σ_k δΩ_k d̂_k, δΩ_k = 2 (B_k q) · δq / |q|² (B_k of Eq. 4, the same form as the
  strains of Eq. 3), so its generalised force is Q = (2 / |q|²) Σ_k m_k B_k q with
  m_k = M · d̂_k(q) the world moment M on the unit directors d̂_k = d_k / |q|² (Eq. 2).

``frame = "world"``: force and moment are fixed in the world frame. The force is a dead
load (energy −F · r(s), no Jacobian); the moment is not conservative under large 3-D
rotations (a fixed-axis moment has no potential on SO(3)): m_k depends on q and gets its
exact, non-symmetric Jacobian.
``frame = "body"``: components on the directors at s, a follower load: F = Σ_k f_k D_k and
M = Σ_k m_k D_k with D_k = d̂_k(q̃) of the quaternion interpolated at s between the two
segment midpoints around it, q̃ = w_a q_a + w_b q_b (extrapolated within the half segments
at the ends). The frame of q_j alone sits up to l/2 away from s, which made a follower tip
moment converge at first order only; q̃ keeps it second order. On a rod with sections w_b is
measured in the twist compliance between the two midpoints (rodsim/core/rod/sections.py,
``compliance_fraction``), as a string tendon's routing points are: where G J jumps the
linear weight puts the frame O(h) off (a body-frame force at the boundary of
catheter-pull-ring's sections converged at order 1.02, 1.01; with the weight 2.0).
Analytic Jacobians.

One element per load, coordinates (r_j, r_{j+1}, q_a, q_b), q_j being one of q_a, q_b (for a
world-frame load both are q_j: no frame at s is needed). The term is conservative (and has
no Jacobian) when every load is a world-frame force without moment.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rodsim.core.rod.quaternion import B, director, director_gradient
from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter, SceneError, shown
from rodsim.core.terms.base import KernelArguments, RodTerm

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
              "on the directors d1, d2, d3 at s: a follower load)",
              choices=LOAD_FRAMES),
)


def segment_of(s: np.ndarray, segment_length: float, segments: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """Segment index j holding each arclength ``s`` and the position t ∈ [0, 1] in it
    (s = (j + t) l; an interior node belongs to the segment it starts, s = L to the last)."""
    j = np.minimum(np.floor(s / segment_length).astype(int), segments - 1)
    t = np.clip(s / segment_length - j, 0.0, 1.0)
    return j, t


@dataclass(frozen=True, kw_only=True)
class PointLoadsOptions(Options):
    """The options of the ``point_loads`` term: one field per
    parameter, checked against them when the term class is defined."""

    loads: list[dict[str, Any]] = field(default_factory=list)


class PointLoads(RodTerm):
    """Point forces and moments at any arclength, world or body frame."""

    name = "point_loads"
    Options = PointLoadsOptions
    options: PointLoadsOptions
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

    def __init__(self, rod: Rod, options: PointLoadsOptions) -> None:
        super().__init__(rod, options)
        loads = options.loads
        n = len(loads)
        geometry = rod.geometry
        s = np.array([load["s"] for load in loads], dtype=float)
        j, t = segment_of(s, geometry.segment_length, geometry.segments)
        # the two segment midpoints around s (the outer pair within half a segment of an end)
        a = np.clip(np.floor(s / geometry.segment_length - 0.5).astype(int), 0,
                    geometry.segments - 2)
        w_b = s / geometry.segment_length - 0.5 - a
        profile = rod.profile
        if profile is not None:  # between the midpoints: in the twist compliance (docstring)
            mid = geometry.segment_s
            between = (w_b >= 0.0) & (w_b <= 1.0)
            w_b = np.where(between, profile.compliance_fraction(
                profile.shear_modulus * profile.polar_moment, mid[a], s, mid[a + 1]), w_b)
        body = np.array([load["frame"] == "body" for load in loads], dtype=bool)
        # A world-frame load needs no frame at s: its pair is (q_j, q_j) with q̃ = q_j, so
        # its element is the centerline's (r_j, r_{j+1}, q_j) and the band does not widen.
        a = np.where(body, a, j)
        b = np.where(body, a + 1, j)
        w_b = np.where(body, w_b, 0.0)
        pos, quat = rod.layout.position_index, rod.layout.quaternion_index
        self.dofs = (np.concatenate([pos[j], pos[j + 1], quat[a], quat[b]], axis=1) if n
                     else np.zeros((0, 14), dtype=int))
        self._weights = np.stack([1.0 - t, t], axis=1) if n else np.zeros((0, 2))
        #: (w_a, w_b) of q̃ = w_a q_a + w_b q_b, and which of the pair is q_j (0 or 1)
        self._frame_weights = np.stack([1.0 - w_b, w_b], axis=1) if n else np.zeros((0, 2))
        self._own = (j - a).astype(np.int64) if n else np.zeros(0, dtype=np.int64)
        force = np.array([load["force"] for load in loads], dtype=float).reshape(n, 3)
        moment = np.array([load["moment"] for load in loads], dtype=float).reshape(n, 3)
        self._world_force = np.where(body[:, None], 0.0, force)
        self._body_force = np.where(body[:, None], force, 0.0)
        self._world_moment = np.where(body[:, None], 0.0, moment)
        self._body_moment = np.where(body[:, None], moment, 0.0)
        follower = bool(np.any(self._body_force) or np.any(moment))
        self.has_jacobian = follower
        self.conservative = not follower

    def kernel_arguments(self) -> KernelArguments:
        return {"dofs": self.dofs, "weights": self._weights,
                "frame_weights": self._frame_weights, "own": self._own,
                "world_force": self._world_force, "body_force": self._body_force,
                "world_moment": self._world_moment, "body_moment": self._body_moment,
                "follower": bool(self.has_jacobian)}

    def energy(self, x: np.ndarray) -> float | None:
        """−Σ F · r(s) for world-frame forces; ``None`` if any load is a follower or a moment."""
        if not self.conservative:
            return None
        point = (self._weights[:, :1] * x[self.dofs[:, :3]]
                 + self._weights[:, 1:] * x[self.dofs[:, 3:6]])
        return float(-np.sum(self._world_force * point))

    @staticmethod
    def _frame(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """|q|², the unnormalised directors d_k (n, 3, 3: [e, k, m]) and their gradients
        ∂d_k/∂q (n, 3, 3, 4: [e, k, m, a])."""
        n2 = np.sum(q * q, axis=1)
        d = np.stack([director(q, k) for k in range(3)], axis=1)
        g = np.stack([director_gradient(q, k) for k in range(3)], axis=1)
        return n2, d, g

    def _parts(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Everything the force and Jacobian share (see the module docstring)."""
        pair = x[self.dofs[:, 6:]].reshape(-1, 2, 4)
        rows = np.arange(len(pair))
        q = pair[rows, self._own]  # q_j
        qi = np.einsum("ni,nia->na", self._frame_weights, pair)  # q̃
        n2, d, g = self._frame(q)
        ni2, di, gi = self._frame(qi)
        # unit directors at s and their derivative: ∂D_k/∂q̃ = G_k/|q̃|² − 2 d_k q̃ᵀ/|q̃|⁴
        unit = di / ni2[:, None, None]
        dunit = (gi / ni2[:, None, None, None]
                 - 2.0 * di[..., None] * qi[:, None, None, :] / (ni2**2)[:, None, None, None])
        force = self._world_force + np.einsum("nk,nkm->nm", self._body_force, unit)
        total = self._world_moment + np.einsum("nk,nkm->nm", self._body_moment, unit)  # M
        m = np.einsum("nm,nkm->nk", total, d) / n2[:, None]  # M · d̂_k(q)
        bq = np.einsum("kab,nb->nka", B, q)  # B_k q
        generalised = 2.0 * np.einsum("nk,nka->na", m, bq) / n2[:, None]  # Q
        return {"q": q, "n2": n2, "d": d, "g": g, "force": force, "total": total, "m": m,
                "bq": bq, "Q": generalised, "dunit": dunit}

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(self.dofs.shape)
        if not self.has_jacobian:
            out[:, :3] = self._weights[:, :1] * self._world_force
            out[:, 3:6] = self._weights[:, 1:] * self._world_force
            return out
        p = self._parts(x)
        out[:, :3] = self._weights[:, :1] * p["force"]
        out[:, 3:6] = self._weights[:, 1:] * p["force"]
        rows = np.arange(len(out))
        quaternion = out[:, 6:].reshape(-1, 2, 4)
        quaternion[rows, self._own] = p["Q"]
        out[:, 6:] = quaternion.reshape(-1, 8)
        return out

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        p = self._parts(x)
        q, n2, d, g, m, bq = p["q"], p["n2"], p["d"], p["g"], p["m"], p["bq"]
        n = len(q)
        rows = np.arange(n)
        # ∂F/∂q̃ and ∂M/∂q̃ (n, 3, 4)
        dforce = np.einsum("nk,nkma->nma", self._body_force, p["dunit"])
        dtotal = np.einsum("nk,nkma->nma", self._body_moment, p["dunit"])
        # m_k = M · d_k(q) / |q|²: ∂m_k/∂q (direct) and ∂m_k/∂q̃ (through M)
        dm_q = (np.einsum("nm,nkma->nka", p["total"], g) / n2[:, None, None]
                - 2.0 * np.einsum("nk,na->nka", m, q) / n2[:, None, None])
        dm_i = np.einsum("nkm,nma->nka", d, dtotal) / n2[:, None, None]
        # Q = (2/|q|²) Σ_k m_k B_k q
        dq_direct = (2.0 * (np.einsum("nk,kab->nab", m, B)
                            + np.einsum("nka,nkb->nab", bq, dm_q)) / n2[:, None, None]
                     - 2.0 * p["Q"][:, :, None] * q[:, None, :] / n2[:, None, None])
        dq_frame = 2.0 * np.einsum("nka,nkb->nab", bq, dm_i) / n2[:, None, None]
        out = np.zeros((n, 14, 14))
        for c in range(2):  # columns of q_a, q_b
            cols = slice(6 + 4 * c, 10 + 4 * c)
            w = self._frame_weights[:, c][:, None, None]
            out[:, :3, cols] = self._weights[:, :1, None] * w * dforce
            out[:, 3:6, cols] = self._weights[:, 1:, None] * w * dforce
            block = w * dq_frame + np.where((self._own == c)[:, None, None], dq_direct, 0.0)
            quaternion_rows = out[:, 6:, cols].reshape(n, 2, 4, 4)
            quaternion_rows[rows, self._own] = block
            out[:, 6:, cols] = quaternion_rows.reshape(n, 8, 4)
        return out
