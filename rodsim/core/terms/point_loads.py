"""Point wrenches (force and moment) at any arclength s of a rod (not in the paper).

Each load ``{s, force, moment, frame}`` acts at rest arclength s ∈ [0, L] of the rod. With
the segment j that contains s (l its rest length, s = (j + t) l, t ∈ [0, 1]; a load at an
interior node acts on the segment that starts there, one at s = L on the last segment):

- the force acts at the centerline point r(s) = (1 − t) r_j + t r_{j+1}, so its virtual work
  F · δr(s) puts (1 − t) F on r_j and t F on r_{j+1} (the linear interpolation's consistent
  share; a force at a node goes to that node only);
- the moment acts on the quaternions q_a, q_b of the two segment midpoints around s, in the
  shares (1 − w, w) of s between them (w clipped to [0, 1]: within half a segment of an end
  the outer quaternion takes it all), each through its angular variation
  δθ = Σ_k δΩ_k d̂_k, δΩ_k = 2 (B_k q) · δq / |q|² (B_k of Eq. 4, the same form as the
  strains of Eq. 3): the generalised force on q_c is its share of Q(q_c) = (2 / |q_c|²)
  Σ_k m_k B_k q_c with m_k = M · d̂_k(q_c) the world moment M on the unit directors
  d̂_k = d_k / |q|² (Eq. 2). So the bending elements' internal moment jumps by M where the
  load is: the element between the two midpoints carries the share w, and the rotation
  beyond it is M s / (E I) of the continuum's. With the whole moment on the segment q_j that
  holds s the jump sat up to l/2 off, and a moment at L/2 converged at first order (tip
  error 8.7e-3, 4.3e-3, 2.2e-3, 1.1e-3 L at N = 21 → 161; tests/test_point_loads.py).

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

One element per load, coordinates (r_j, r_{j+1}, q_a, q_b) (for a world-frame force without
moment both are q_j: no frame at s is needed). The term is conservative (and has no
Jacobian) when every load is a world-frame force without moment.
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
    figure_layer = "load"
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
        force = np.array([load["force"] for load in loads], dtype=float).reshape(n, 3)
        moment = np.array([load["moment"] for load in loads], dtype=float).reshape(n, 3)
        # A world-frame force needs no frame at s: its pair is (q_j, q_j) with q̃ = q_j, so
        # its element is the centerline's (r_j, r_{j+1}, q_j) and the band does not widen.
        # A body-frame load reads the frame at s; a moment is shared by the pair (below).
        paired = body | np.any(moment != 0.0, axis=1)
        a = np.where(paired, a, j)
        b = np.where(paired, a + 1, j)
        w_b = np.where(paired, w_b, 0.0)
        pos, quat = rod.layout.position_index, rod.layout.quaternion_index
        self.dofs = (np.concatenate([pos[j], pos[j + 1], quat[a], quat[b]], axis=1) if n
                     else np.zeros((0, 14), dtype=int))
        self._weights = np.stack([1.0 - t, t], axis=1) if n else np.zeros((0, 2))
        #: (w_a, w_b) of q̃ = w_a q_a + w_b q_b
        self._frame_weights = np.stack([1.0 - w_b, w_b], axis=1) if n else np.zeros((0, 2))
        #: The moment's share on q_a and q_b: w_b clipped to [0, 1] (module docstring).
        share = np.clip(w_b, 0.0, 1.0)
        self._moment_weights = np.stack([1.0 - share, share], axis=1) if n else np.zeros((0, 2))
        self._world_force = np.where(body[:, None], 0.0, force)
        self._body_force = np.where(body[:, None], force, 0.0)
        self._world_moment = np.where(body[:, None], 0.0, moment)
        self._body_moment = np.where(body[:, None], moment, 0.0)
        follower = bool(np.any(self._body_force) or np.any(moment))
        self.has_jacobian = follower
        self.conservative = not follower

    def kernel_arguments(self) -> KernelArguments:
        return {"dofs": self.dofs, "weights": self._weights,
                "frame_weights": self._frame_weights, "moment_weights": self._moment_weights,
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
        """Everything the force and Jacobian share (see the module docstring); the moment's
        pieces for each quaternion c of the pair (index 1: c)."""
        pair = x[self.dofs[:, 6:]].reshape(-1, 2, 4)
        qi = np.einsum("ni,nia->na", self._frame_weights, pair)  # q̃
        ni2, di, gi = self._frame(qi)
        # unit directors at s and their derivative: ∂D_k/∂q̃ = G_k/|q̃|² − 2 d_k q̃ᵀ/|q̃|⁴
        unit = di / ni2[:, None, None]
        dunit = (gi / ni2[:, None, None, None]
                 - 2.0 * di[..., None] * qi[:, None, None, :] / (ni2**2)[:, None, None, None])
        force = self._world_force + np.einsum("nk,nkm->nm", self._body_force, unit)
        total = self._world_moment + np.einsum("nk,nkm->nm", self._body_moment, unit)  # M
        parts: dict[str, np.ndarray] = {"force": force, "total": total, "dunit": dunit}
        sides = [self._frame(pair[:, c]) for c in range(2)]
        parts["q"] = pair
        parts["n2"] = np.stack([side[0] for side in sides], axis=1)
        parts["d"] = np.stack([side[1] for side in sides], axis=1)
        parts["g"] = np.stack([side[2] for side in sides], axis=1)
        parts["m"] = np.einsum("nm,nckm->nck", total, parts["d"]) / parts["n2"][:, :, None]
        parts["bq"] = np.einsum("kab,ncb->ncka", B, pair)  # B_k q_c
        parts["Q"] = 2.0 * np.einsum("nck,ncka->nca", parts["m"], parts["bq"]) / (
            parts["n2"][:, :, None])  # the whole moment on q_c
        return parts

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(self.dofs.shape)
        if not self.has_jacobian:
            out[:, :3] = self._weights[:, :1] * self._world_force
            out[:, 3:6] = self._weights[:, 1:] * self._world_force
            return out
        p = self._parts(x)
        out[:, :3] = self._weights[:, :1] * p["force"]
        out[:, 3:6] = self._weights[:, 1:] * p["force"]
        out[:, 6:] = (self._moment_weights[:, :, None] * p["Q"]).reshape(-1, 8)
        return out

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        p = self._parts(x)
        n = len(p["force"])
        # ∂F/∂q̃ and ∂M/∂q̃ (n, 3, 4)
        dforce = np.einsum("nk,nkma->nma", self._body_force, p["dunit"])
        dtotal = np.einsum("nk,nkma->nma", self._body_moment, p["dunit"])
        out = np.zeros((n, 14, 14))
        for c in range(2):  # columns of q_a, q_b: the force's frame
            cols = slice(6 + 4 * c, 10 + 4 * c)
            w = self._frame_weights[:, c][:, None, None]
            out[:, :3, cols] = self._weights[:, :1, None] * w * dforce
            out[:, 3:6, cols] = self._weights[:, 1:, None] * w * dforce
        for c in range(2):  # rows of q_c: its share of the moment, Q_c = (2/|q_c|²) Σ m_k B_k q_c
            q, n2, d, g = p["q"][:, c], p["n2"][:, c], p["d"][:, c], p["g"][:, c]
            m, bq, moment = p["m"][:, c], p["bq"][:, c], p["Q"][:, c]
            # m_k = M · d_k(q_c) / |q_c|²: ∂m_k/∂q_c (direct) and ∂m_k/∂q̃ (through M)
            dm_q = (np.einsum("nm,nkma->nka", p["total"], g) / n2[:, None, None]
                    - 2.0 * np.einsum("nk,na->nka", m, q) / n2[:, None, None])
            dm_i = np.einsum("nkm,nma->nka", d, dtotal) / n2[:, None, None]
            direct = (2.0 * (np.einsum("nk,kab->nab", m, B)
                             + np.einsum("nka,nkb->nab", bq, dm_q)) / n2[:, None, None]
                      - 2.0 * moment[:, :, None] * q[:, None, :] / n2[:, None, None])
            through = 2.0 * np.einsum("nka,nkb->nab", bq, dm_i) / n2[:, None, None]
            share = self._moment_weights[:, c][:, None, None]
            rows = slice(6 + 4 * c, 10 + 4 * c)
            for col in range(2):
                cols = slice(6 + 4 * col, 10 + 4 * col)
                block = self._frame_weights[:, col][:, None, None] * through
                if col == c:
                    block = block + direct
                out[:, rows, cols] += share * block
        return out
