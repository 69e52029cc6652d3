"""Kernel of the dead loads (tip load, gravity, proximal tendon actuation): a constant force
per element, no Jacobian."""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._scatter import add_force


@njit(cache=True)
def evaluate(x: np.ndarray, forces: np.ndarray, scale: float, want_force: bool,
             force: np.ndarray, force_target: np.ndarray, want_jacobian: bool,
             jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    if want_force:
        for e in range(forces.shape[0]):
            add_force(force, force_target, e, forces[e], scale)
