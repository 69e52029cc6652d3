"""A joint: this rod's base tied to a point of another backbone rod (an anchor,
rodsim/core/anchors.py; docs/model.md, "Supports and anchors").

For the rod B listing the term, tied at its base r_B,0 (and its first quaternion b = q_B,0)
to node k of rod A (``rod``, at arclength ``s``; the quaternion a of A's segment that
starts at node k, or its last segment at its last node):

    E = ½ K_J |r_B,0 − r_A,k|²  +  ½ l̄ Σ_k K_k u_k(a, b)²        (the second with
                                                                   ``orientation``)

The first is a zero-length spring, a penalty holding the two points together (the
residual gap is F/K_J for a force F through the joint). The second is the bending element
of Eqs. (3), (7) (rodsim/core/terms/bend_twist.py) between a and b, with dual length
l̄ = (l_A + l_B)/2 and the two half segments' stiffness tensors (Eq. 8) in series,
K_k = l̄ / (l_A / (2 K_k,A) + l_B / (2 K_k,B)): at A's tip and for equal sections this
is exactly the element a single rod has between those two segments, so two rods joined
end to end are the one rod to within F/K_J. Without ``orientation`` the joint is a ball
joint (no moment passes).

Rod B's own base support holds nothing (``clamp = "free"``) and its rest base is placed at
A's rest point, in A's base frame; A is built first.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.anchors import Anchor, node_at
from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter
from rodsim.core.terms._relative import absolute, check_one, penalty_parameters
from rodsim.core.terms._segment import two_node_block
from rodsim.core.terms.base import KernelArguments, RodTerm
from rodsim.core.terms.bend_twist import (
    bend_forces,
    bend_jacobians,
    bend_kinematics,
    element_stiffness,
)

#: Default K_J / (E_s A / L) (rodsim/core/terms/_relative.py): the joint adds 1e-4 of the
#: rod's own axial compliance.
DEFAULT_K_J_RELATIVE = 1e4


@dataclass(frozen=True, kw_only=True)
class JointOptions(Options):
    """The options of the ``joint`` term: one field per
    parameter, checked against them when the term class is defined."""

    rod: str
    s: float
    K_J: float = 0.0
    K_J_relative: float = DEFAULT_K_J_RELATIVE
    orientation: bool = True


class Joint(RodTerm):
    """This rod's base tied to a node of another rod: a position penalty and, optionally,
    the bending element between the two rods' segments there."""

    name = "joint"
    figure_layer = "shape"
    Options = JointOptions
    options: JointOptions
    equation = "anchor (not in the paper); Eqs. (3), (7), (8) for the frame"
    joins_rods = True
    holds_base = True
    constraint_constant = "K_J"
    penalty_advice = "the joint penalty (rods.<name>.joint.K_J_relative, or K_J)"
    parameters = (
        Parameter("rod", "str", None, "-", "name of the rod this rod's base is tied to"),
        Parameter("s", "float", None, "m",
                  "arclength on that rod where the base is tied (a node of that rod: "
                  "k L/(N − 1))", 0.0, 100.0),
        *penalty_parameters("K_J", "N/m",
                            "position penalty of the joint (the points part by F/K_J under a "
                            "force F)", DEFAULT_K_J_RELATIVE,
                            "this rod's axial stiffness E_s A / L"),
        Parameter("orientation", "bool", True, "-",
                  "tie the frames too (a welded joint: the bending element between the two "
                  "rods' segments); false: a ball joint"),
    )

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        check_one(options, "K_J", DEFAULT_K_J_RELATIVE, prefix)

    def __init__(self, rod: Rod, options: JointOptions, rods: dict[str, Rod]) -> None:
        super().__init__(rod, options)
        parent = rods[options.rod]
        #: The anchor: this rod's node 0 tied to the other rod's node at ``s``.
        self.anchor = Anchor(rod, 0, parent, node_at(parent.nodes, parent.length, options.s))
        #: The absolute joint penalty constant [N/m].
        self.K_J = absolute(options, "K_J", rod.stretch_stiffness / rod.length)
        self._stiffness = self.K_J
        self._orientation = bool(options.orientation)
        blocks = [self.anchor.to_position_index, self.anchor.position_index]
        l_a, l_b = parent.geometry.segment_length, rod.geometry.segment_length
        self._dual_lengths = np.array([0.5 * (l_a + l_b)])
        # The two half-segments either side of the joint, in series (each with its
        # sections' stiffness): the other rod's segment that orients the anchor, this rod's
        # first segment.
        start_a = self.anchor.to_segment * l_a + (0.0 if
                                                   self.anchor.to_segment == self.anchor.to_node
                                                   else 0.5 * l_a)
        k_a = element_stiffness(parent, "corrected", 0.0, np.array([start_a]),
                                np.array([start_a + 0.5 * l_a]))
        k_b = element_stiffness(rod, "corrected", 0.0, np.zeros(1), np.array([0.5 * l_b]))
        #: (1, 3): one bending element, as the bend_twist kernel takes per-element stiffness.
        self._bend_stiffness = self._dual_lengths[0] / (0.5 * l_a / k_a + 0.5 * l_b / k_b)
        if self._orientation:
            blocks += [self.anchor.to_quaternion_index, rod.layout.quaternion_index[0]]
        self.dofs = np.concatenate(blocks)[None, :]  # (r_A, r_B[, a, b])

    def kernel_arguments(self) -> KernelArguments:
        bend_dofs = (np.ascontiguousarray(self.dofs[:, 6:14]) if self._orientation
                     else np.zeros((0, 8), dtype=self.dofs.dtype))
        return {"dofs": self.dofs, "stiffness": self._stiffness, "bend_dofs": bend_dofs,
                "dual_lengths": self._dual_lengths, "bend_stiffness": self._bend_stiffness}

    def _gap(self, x: np.ndarray) -> np.ndarray:
        return x[self.dofs[0, 3:6]] - x[self.dofs[0, 0:3]]  # r_B,0 − r_A,k

    def _pair(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return x[self.dofs[:, 6:10]], x[self.dofs[:, 10:14]]

    def energy(self, x: np.ndarray) -> float:
        gap = self._gap(x)
        total = 0.5 * self._stiffness * float(gap @ gap)
        if self._orientation:
            u = bend_kinematics(*self._pair(x), self._dual_lengths).u
            total += float(0.5 * np.sum(self._dual_lengths[:, None] * self._bend_stiffness
                                        * u**2))
        return total

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        pull = self._stiffness * self._gap(x)
        forces = [pull, -pull]
        if self._orientation:
            forces.append(bend_forces(*self._pair(x), self._dual_lengths,
                                      self._bend_stiffness)[0])
        return np.concatenate(forces)[None, :]

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        k = self.dofs.shape[1]
        jac = np.zeros((1, k, k))
        jac[:, :6, :6] = two_node_block(self._stiffness * np.eye(3)[None, :, :])
        if self._orientation:
            jac[:, 6:, 6:] = bend_jacobians(*self._pair(x), self._dual_lengths,
                                            self._bend_stiffness)
        return jac
