"""Kernel of ``rodsim.core.terms.joint``: per joint, the zero-length spring
½ K_J |r_B − r_A|² on (r_A, r_B) and, with the frame tied, the bending element of
``rodsim.core.kernels.bend_twist`` on the two quaternions (a, b) — that kernel, called
on the joint's quaternion coordinates and their slots."""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels import bend_twist


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, stiffness: float, bend_dofs: np.ndarray,
             dual_lengths: np.ndarray, bend_stiffness: np.ndarray, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    for e in range(dofs.shape[0]):
        for m in range(3):
            pull = stiffness * (x[dofs[e, 3 + m]] - x[dofs[e, m]])  # F on r_A
            if want_force:
                force[force_target[e, m]] += scale * pull
                force[force_target[e, 3 + m]] -= scale * pull
            if want_jacobian:
                k = scale * stiffness
                jacobian[jacobian_target[e, m, m]] -= k
                jacobian[jacobian_target[e, 3 + m, 3 + m]] -= k
                jacobian[jacobian_target[e, m, 3 + m]] += k
                jacobian[jacobian_target[e, 3 + m, m]] += k
    if bend_dofs.shape[0] > 0:
        bend_twist.evaluate(x, bend_dofs, dual_lengths, bend_stiffness,
                            np.zeros(bend_dofs.shape[0], np.int8),
                            np.zeros((bend_dofs.shape[0], 4)), scale, want_force, force,
                            np.ascontiguousarray(force_target[:, 6:14]), want_jacobian,
                            jacobian, np.ascontiguousarray(jacobian_target[:, 6:14, 6:14]))


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, stiffness: float, bend_dofs: np.ndarray,
           dual_lengths: np.ndarray, bend_stiffness: np.ndarray) -> float:
    """½ K_J |r_B − r_A|² (+ the bending element's energy)."""
    total = 0.0
    for e in range(dofs.shape[0]):
        for m in range(3):
            gap = x[dofs[e, 3 + m]] - x[dofs[e, m]]
            total += 0.5 * stiffness * gap * gap
    if bend_dofs.shape[0] > 0:
        total += bend_twist.energy(x, bend_dofs, dual_lengths, bend_stiffness,
                                   np.zeros(bend_dofs.shape[0], np.int8),
                                   np.zeros((bend_dofs.shape[0], 4)))
    return total
