"""Supports that move in physical time: the velocity of what a support holds, and the damping
forces and energy it brings into a step (issue 33 item 2; docs/dynamics.md, "Moving
supports").

A program on a rod's base (``rods.<rod>.base.insertion`` d(t), ``rods.<rod>.base.rotation``
θ(t)) moves the base as a rigid body: the support point c = o + d e_x with the velocity
V = ḋ e_x, turning at Ω = θ̇ e_x about the axis through c. Its rigid velocity field is

    ṙ = V + Ω × (r − c),    ω_k = d_k · Ω  (body rates: q̇ = ½ Σ_k ω_k B_k q)

at every coordinate of the rod (``rigid_rates``). A program on a node support's
``displacement`` moves the held node by its rate (world frame) on top of that.

Where the supports move, the held coordinates' rates enter the step through the damping
(rodsim/core/damping.py):

- Kelvin–Voigt: the strain rates are those of ẋ − a, a the rigid field (strains are
  invariant under rigid motions, so the rigid field adds no strain rate, and the clamp
  frame that the rotation turns — a parameter of the bending term, no coordinate — moves
  with it exactly): the force on the free coordinates is −K_ff (ẋ_f − a_f) − K_fh d_h,
  d_h the node supports' displacement rates;
- drag acts on the absolute velocity: −C_ff ẋ_f − C_fh ẋ_h (the consistent drag couples a
  held node to its free neighbours).

``SupportVelocity.damping_force`` is the part of these that the free equations do not
already hold (−K_ff ẋ_f − C_ff ẋ_f is the step's D_t). The energy: the dissipation is the
whole of it, the held coordinates included,

    P_D = (ẋ − a)ᵀ K (ẋ − a) + ẋᵀ C ẋ ≥ 0

(full matrices, ``Damping.full_matrices``), and what the free coordinates lose through
the damping forces is P_D less the power the support puts in through them — reaction ·
support velocity — which the run adds to the work (``support_work``). The elastic
reaction's work is the change of V(x, t) at fixed free x, which the run counts as a
program's work already (rodsim/solvers/physical/trajectory.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rodsim.core.damping import Damping
from rodsim.core.model import Model
from rodsim.core.rod.quaternion import directors
from rodsim.solvers.physical.coordinates import velocity_rows

__all__ = ["RigidMotion", "SupportVelocity"]


@dataclass(frozen=True)
class RigidMotion:
    """A rod's base moving as a rigid body: ``velocity`` V [m/s] of the support point,
    ``spin`` Ω [rad/s] (world frame), both along the base axis."""

    rod: str
    velocity: np.ndarray
    spin: np.ndarray


@dataclass(frozen=True)
class SupportVelocity:
    """What the supports' programs do at one time: the rods whose base moves rigidly, and
    the node supports' displacement rates (``moved``: full-state vector, nonzero only at
    held position coordinates) [m/s]."""

    rigid: tuple[RigidMotion, ...]
    moved: np.ndarray

    def rigid_rates(self, model: Model, full: np.ndarray) -> np.ndarray:
        """a: the rate of every full-state coordinate under the bases' rigid motions at the
        full state ``full`` (zero on rods whose base does not move; module docstring)."""
        out = np.zeros(model.full_size)
        for motion in self.rigid:
            rod = model.rods[motion.rod]
            centre = rod.support.position
            position = rod.layout.position_index
            r = full[position]
            out[position] = motion.velocity + np.cross(motion.spin, r - centre)
            index = rod.layout.quaternion_index
            q = full[index]
            body = directors(q / np.linalg.norm(q, axis=1)[:, None]) @ motion.spin
            out[index] = 0.5 * np.einsum("ska,sk->sa", velocity_rows(q), body)
        return out

    def damping_force(self, damping: Damping, x: np.ndarray, x_dot: np.ndarray
                      ) -> tuple[np.ndarray, float]:
        """(b, P_D): the damping force on the free coordinates that the moving supports
        add, K_ff a_f − K_fh d_h − C_fh ẋ_h (n,), and the whole dissipated power P_D
        [W] for the free rates ``x_dot`` at ``x`` (free coordinates themselves; module
        docstring)."""
        model = damping.model
        full = model.full(x - model.reference[model.free])
        material, drag = damping.full_matrices(x)
        a = self.rigid_rates(model, full)
        held = np.ones(model.full_size, dtype=bool)
        held[model.free] = False
        rate = np.zeros(model.full_size)  # ẋ on every coordinate
        rate[model.free] = x_dot
        rate[held] = a[held] + self.moved[held]
        relative = rate - a  # the strain-rate part: free ẋ_f − a_f, held d_h
        z = np.where(held, -self.moved, a)
        y = np.where(held, rate, 0.0)
        force = (material @ z - drag @ y)[model.free]
        power = float(relative @ (material @ relative) + rate @ (drag @ rate))
        return force, power
