"""Frictionless contact of a rod's surface with a rigid obstacle (issue 25; not in the paper).

One term per (obstacle, rod) pair of the scene's ``[obstacles.<name>]`` tables (the model
builds them; a rod's ``terms`` does not list it). Node-based: each control point r_i is a
sphere of the rod's radius r, and its penetration into the obstacle is

    p_i = r − φ(r_i)          (φ: the obstacle's signed gap, rodsim/core/obstacles/)

The energy is E = k Σ_i ψ(p_i) with the C² penalty

    ψ(p) = 0                               p ≤ 0
    ψ(p) = p³ / (6 δ)                      0 < p < δ
    ψ(p) = p²/2 − δ p/2 + δ²/6             p ≥ δ

— a linear spring (force k (p − δ/2)) whose stiffness is switched on over the smoothing length
δ by a linear ramp of ψ''. Why this law: ψ, ψ' and ψ'' are continuous (ψ'' = p/δ, then 1), so
F and its Jacobian are continuous in the state and Newton converges quadratically through a
contact that appears or vanishes, and CVODE's error control sees no kink; unlike a log-barrier
it is defined for every state (a Newton step may overshoot into the obstacle) and its
stiffness is bounded (k), so the conditioning does not blow up near contact. The cost is a
compliance: a contact force f penetrates by p = √(2 δ f / k) while f < k δ/2 (the onset; with
the defaults this holds for any force a catheter meets: k δ/2 ≈ 0.5 E I r / l³), else by
f/k + δ/2.

Scales (defaults from the rod, not tuned per scene): k = stiffness_scale · E I / l³ [N/m],
l the segment length (the stiffness of one segment bent as a cantilever, so the penetration
under a node force f is ~ f l³/(E I) / stiffness_scale), and δ = smoothing_scale · r [m].

Force on node i: F_i = k ψ'(p_i) ∇φ; Jacobian ∂F_i/∂r_i = k (−ψ''(p_i) ∇φ ∇φᵀ + ψ'(p_i) ∇²φ),
symmetric. Each element is one node's three coordinates, so the Jacobian pattern is fixed and
never changes when a contact appears or vanishes. What node-based contact misses: the
segments between nodes may cut a convex obstacle's corner or a concave wall by up to
~l²κ/8 (measured in docs/contact.md).

Regularised Coulomb friction (the obstacle's ``friction`` μ > 0; docs/contact.md,
"Friction"). Each node holds an anchor a_i, its position at the last converged equilibrium
(of a track step; for a single solve, the rest state the solve starts from). With
n = ∇φ/|∇φ| the contact normal, P = I − n nᵀ, |f_n| = k ψ'(p) |∇φ| the normal force, the
slip v = P (r_i − a_i) and ε = slip_scale · r, the friction force is

    f_t = −μ |f_n| g(v),     g(v) = v / √(|v|² + ε²)

— the implicit (backward) quasi-static step of Coulomb's law: for |v| ≫ ε it is μ|f_n|
against the slip (sliding), for |v| ≲ ε a tangential spring of stiffness μ|f_n|/ε (sticking,
up to a pre-sliding slip of order ε). The force is not −∇ of an energy (``conservative`` is
False when μ > 0) and its Jacobian is not symmetric; it is exact, with
∂|f_n|/∂r = k(−ψ'' |∇φ|² n + ψ' ∇²φ n), ∂n/∂r = P ∇²φ/|∇φ| and
∂v/∂r = P − (n·d) ∂n/∂r − n (dᵀ ∂n/∂r), d = r_i − a_i. The anchors are set explicitly
(``Contact.anchored``, through ``rodsim.core.model.Model.anchored``): a term never
changes once built. With μ = 0 none of this is evaluated: the frictionless numbers, bitwise.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.core.contact_penalty import penalty
from rodsim.core.obstacles import Obstacle, build_obstacle
from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options
from rodsim.core.terms.base import KernelArguments, RodTerm, Term

if TYPE_CHECKING:
    from rodsim.core.model import Model

__all__ = ["Contact", "contact_forces", "penalty"]


@dataclass(frozen=True, kw_only=True)
class ContactOptions(Options):
    """The options of the ``contact`` term: one field per
    parameter, checked against them when the term class is defined."""


class Contact(RodTerm):
    """Penalty contact of one rod's nodes with one obstacle."""

    name = "contact"
    figure_layer = "contact"
    Options = ContactOptions
    options: ContactOptions
    equation = "contact penalty (not in the paper; docs/contact.md)"
    scope = "obstacle"
    scene_table = "obstacles"
    constraint_constant = "stiffness_scale"
    penalty_advice = "the contact stiffness (obstacles.<name>.stiffness_scale)"
    unilateral = True

    @classmethod
    def from_table(cls, name: str, table: Mapping[str, Any],
                   rods: Mapping[str, Rod]) -> list[tuple[str, Term]]:
        """One term per rod the obstacle ``[obstacles.<name>]`` touches, keyed by the rod."""
        obstacle = build_obstacle(name, table)
        return [(rod, cls(rods[rod], obstacle)) for rod in table["rods"]]

    def __init__(self, rod: Rod, obstacle: Obstacle) -> None:
        super().__init__(rod, self.Options())
        self.obstacle = obstacle
        #: The obstacle type's own kernel (rodsim/core/kernels/contact_<type>.py): the
        #: compiled path dispatches on the obstacle, not on a closed list of kinds.
        self.kernel = obstacle.kernel
        table = obstacle.table
        segment = rod.geometry.segment_length
        #: Contact stiffness k [N/m] and smoothing length δ [m].
        self.stiffness = float(table["stiffness_scale"]) * rod.bending_stiffness / segment**3
        self.smoothing = float(table["smoothing_scale"]) * rod.options.radius
        self.radius = float(rod.options.radius)
        self.dofs = np.ascontiguousarray(rod.layout.position_index)
        #: Coulomb coefficient μ and the friction's regularisation length ε [m].
        self.friction = float(table["friction"])
        self.slip = float(table["slip_scale"]) * self.radius
        #: Position of each node at the last converged equilibrium [m], shape (N, 3): at
        #: first the rod's rest (held) positions, where a solve starts.
        self.anchors = np.ascontiguousarray(rod.held_positions(), dtype=float)
        self.conservative = self.friction == 0.0

    def latent_stiffness(self) -> tuple[np.ndarray, float]:
        """Every node's three position coordinates and k: a node that touches meets the
        stiffness k (ψ'' = 1 past the onset δ), which the rest state, out of contact, does
        not show."""
        return self.dofs.ravel(), self.stiffness

    def anchor_positions(self) -> np.ndarray | None:
        """The friction anchors (N, 3) [m]; None without friction (nothing depends on the
        path)."""
        return self.anchors if self.friction > 0.0 else None

    def anchors_at(self, full: np.ndarray) -> np.ndarray | None:
        """The anchors an equilibrium ``full`` (full state) gives: its node positions; None
        without friction."""
        return np.ascontiguousarray(full[self.dofs]) if self.friction > 0.0 else None

    def anchored(self, anchors: np.ndarray) -> Contact:
        """A copy of this term with the friction anchors ``anchors`` (N, 3) [m]."""
        anchors = np.ascontiguousarray(anchors, dtype=float)
        if anchors.shape != self.anchors.shape:
            raise ValueError(f"anchors of shape {anchors.shape}, expected {self.anchors.shape}")
        other = copy.copy(self)
        other.anchors = anchors
        return other

    def penetration(self, x: np.ndarray) -> np.ndarray:
        """p_i = r − φ(r_i) of every node [m] (> 0 where the node's sphere touches)."""
        return self.radius - self.obstacle.gap(x[self.dofs])[0]

    def nodal_forces(self, x: np.ndarray) -> np.ndarray:
        """Contact force on every node, shape (N, 3) [N]."""
        return self.element_forces(x)

    def energy(self, x: np.ndarray) -> float | None:
        if self.friction > 0.0:
            return None  # friction is not the gradient of an energy
        phi = self.obstacle.gap(x[self.dofs])[0]
        return float(self.stiffness * np.sum(penalty(self.radius - phi, self.smoothing)[0]))

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        points = x[self.dofs]
        phi, grad, hess = self.obstacle.gap(points)
        _, d1, d2 = penalty(self.radius - phi, self.smoothing)
        normal = self.stiffness * d1[:, None] * grad
        if self.friction == 0.0:
            return normal
        return normal + self._friction(points, grad, hess, d1, d2, jacobian=False)[0]

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        points = x[self.dofs]
        phi, grad, hess = self.obstacle.gap(points)
        _, d1, d2 = penalty(self.radius - phi, self.smoothing)
        active = d1 > 0.0
        curvature = np.where(active[:, None, None], d1[:, None, None] * hess, 0.0)
        normal = self.stiffness * (curvature - d2[:, None, None]
                                   * np.einsum("ni,nj->nij", grad, grad))
        if self.friction == 0.0:
            return normal
        return normal + self._friction(points, grad, hess, d1, d2, jacobian=True)[1]

    def _friction(self, points: np.ndarray, grad: np.ndarray, hess: np.ndarray,
                  d1: np.ndarray, d2: np.ndarray, jacobian: bool
                  ) -> tuple[np.ndarray, np.ndarray | None]:
        """Friction force f_t (N, 3) on every node and, if asked, ∂f_t/∂r_i (N, 3, 3)
        (module docstring); zero where the node does not touch (ψ' = 0)."""
        active = d1 > 0.0
        size = np.linalg.norm(grad, axis=1)
        size = np.where(active, size, 1.0)
        n = grad / size[:, None]
        normal_force = self.stiffness * d1 * size  # |f_n|
        d = points - self.anchors
        along = np.einsum("ni,ni->n", n, d)
        v = d - along[:, None] * n
        q = np.sqrt(np.einsum("ni,ni->n", v, v) + self.slip**2)
        g = v / q[:, None]
        force = np.where(active[:, None], -self.friction * normal_force[:, None] * g, 0.0)
        if not jacobian:
            return force, None
        eye = np.eye(3)
        projector = eye - np.einsum("ni,nj->nij", n, n)
        dn = np.einsum("nij,njk->nik", projector, hess) / size[:, None, None]
        hn = np.einsum("nij,nj->ni", hess, n)
        dfn = self.stiffness * (-(d2 * size * size)[:, None] * n + d1[:, None] * hn)
        dv = (projector - along[:, None, None] * dn
              - np.einsum("ni,nk->nik", n, np.einsum("nj,njk->nk", d, dn)))
        dg = (eye - np.einsum("ni,nj->nij", v, v) / (q * q)[:, None, None]) / q[:, None, None]
        block = -self.friction * (np.einsum("ni,nj->nij", g, dfn)
                                  + normal_force[:, None, None]
                                  * np.einsum("nij,njk->nik", dg, dv))
        return force, np.where(active[:, None, None], block, 0.0)

    def kernel_arguments(self) -> KernelArguments:
        return {"dofs": self.dofs.astype(np.int64), **self.obstacle.kernel_arguments(),
                "radius": self.radius, "stiffness": self.stiffness, "delta": self.smoothing,
                "friction": self.friction, "slip": self.slip, "anchors": self.anchors}

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        return None


def contact_forces(model: Model, full: np.ndarray) -> np.ndarray | None:
    """The contact force on every control point of ``model``'s rods (stacked in their order,
    shape (nodes, 3) [N]; zero on rods no obstacle acts on), summed over its contact terms at
    the full state ``full`` (by the compiled kernels on the compiled path,
    ``Model.element_forces``); None when no term is a contact (a scene without
    obstacles)."""
    contacts = [(index, term) for index, term in enumerate(model.terms)
                if isinstance(term, Contact)]
    if not contacts:
        return None
    force = {name: np.zeros((rod.options.nodes, 3)) for name, rod in model.rods.items()}
    for index, term in contacts:
        force[term.rod.name] += model.element_forces(index, full)
    return np.concatenate(list(force.values()))
