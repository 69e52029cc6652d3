"""Accumulation of element forces and Jacobians into the model's arrays (see the package
docstring for the target maps)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def add_force(force: np.ndarray, target: np.ndarray, e: int, local: np.ndarray,
              scale: float) -> None:
    """force[target[e, a]] += scale · local[a]."""
    for a in range(local.shape[0]):
        force[target[e, a]] += scale * local[a]


@njit(cache=True, inline="always")
def add_jacobian(jacobian: np.ndarray, target: np.ndarray, e: int, local: np.ndarray,
                 scale: float) -> None:
    """jacobian[target[e, a, b]] += scale · local[a, b]."""
    for a in range(local.shape[0]):
        for b in range(local.shape[1]):
            jacobian[target[e, a, b]] += scale * local[a, b]
