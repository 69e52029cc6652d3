"""Kernel of ``rodsim.core.terms.endpoint_coupling``, Eq. (29): a spring of stiffness K_C and
rest length r_L between the catheter's tip r_N and the tendon's tip t
(``rodsim.core.kernels._spring.spring``, edge e = t − r_N).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._spring import spring, spring_energy


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, stiffness: float, offset: float, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    spring(x, dofs, stiffness, offset, scale, want_force, force, force_target,
           want_jacobian, jacobian, jacobian_target)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, stiffness: float, offset: float) -> float:
    """½ K_C (|e| − r_L)²."""
    return spring_energy(x, dofs, stiffness, offset)
