"""Kernel of the elastic base support (``ElasticSupport.energy_kernel``,
rodsim/core/support_kinds/elastic.py, evaluated by rodsim/core/terms/support_energy.py): the
zero-length spring ½ k_t |r_0 − r_c|² on the base node and the bending element of
``rodsim.core.kernels.bend_twist`` between the support frame q_c (constant) and the first
quaternion q_0 — that kernel, called with its constant-frame side on q_0's coordinates and
slots (the side's entries are zeros)."""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels import bend_twist


@njit(cache=True)
def _bend_dofs(dofs: np.ndarray) -> np.ndarray:
    """(q_0, q_0) per element: the bend_twist element with its side a the constant frame."""
    out = np.empty((dofs.shape[0], 8), dtype=dofs.dtype)
    for e in range(dofs.shape[0]):
        for i in range(4):
            out[e, i] = dofs[e, 3 + i]
            out[e, 4 + i] = dofs[e, 3 + i]
    return out


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, stiffness: float, point: np.ndarray,
             frame: np.ndarray, dual_lengths: np.ndarray, bend_stiffness: np.ndarray,
             scale: float, want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    for e in range(dofs.shape[0]):
        for m in range(3):
            if want_force:
                force[force_target[e, m]] -= scale * stiffness * (x[dofs[e, m]] - point[m])
            if want_jacobian:
                jacobian[jacobian_target[e, m, m]] -= scale * stiffness
    elements = dofs.shape[0]
    bend_force_target = np.empty((elements, 8), dtype=force_target.dtype)
    bend_jacobian_target = np.empty((elements, 8, 8), dtype=jacobian_target.dtype)
    for e in range(elements):
        for i in range(8):
            bend_force_target[e, i] = force_target[e, 3 + i % 4]
            for j in range(8):
                bend_jacobian_target[e, i, j] = jacobian_target[e, 3 + i % 4, 3 + j % 4]
    bend_twist.evaluate(x, _bend_dofs(dofs), dual_lengths, bend_stiffness,
                        np.ones(elements, np.int8), frame, scale, want_force, force,
                        bend_force_target, want_jacobian, jacobian, bend_jacobian_target)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, stiffness: float, point: np.ndarray,
           frame: np.ndarray, dual_lengths: np.ndarray, bend_stiffness: np.ndarray) -> float:
    """½ k_t |r_0 − r_c|² plus the bending element's energy."""
    total = 0.0
    for e in range(dofs.shape[0]):
        for m in range(3):
            gap = x[dofs[e, m]] - point[m]
            total += 0.5 * stiffness * gap * gap
    return total + bend_twist.energy(x, _bend_dofs(dofs), dual_lengths, bend_stiffness,
                                     np.ones(dofs.shape[0], np.int8), frame)
