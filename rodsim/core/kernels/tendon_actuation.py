"""Kernel of ``rodsim.core.terms.tendon_actuation`` at the distal end (§4.3, F_A in F_net of
Eq. 31): a follower load on (t, q_last),

    F = (−F_A d3(q), 0),   ∂F/∂x = −F_A ∂d3/∂q in the (t, q) block, zero elsewhere,

with d3 and ∂d3/∂q from ``rodsim.core.kernels._quaternion``. The proximal pull is a dead load
and uses ``rodsim.core.kernels.constant_force``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._quaternion import director_and_gradient
from rodsim.core.kernels._scatter import add_force, add_jacobian


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, pull: float, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    q = np.empty(4)
    d3 = np.empty(3)
    grad_d3 = np.empty((3, 4))
    local_force = np.zeros(7)
    local_jacobian = np.zeros((7, 7))
    for e in range(dofs.shape[0]):
        for a in range(4):
            q[a] = x[dofs[e, 3 + a]]
        director_and_gradient(q, 2, d3, grad_d3)
        if want_force:
            for m in range(3):
                local_force[m] = -pull * d3[m]
            add_force(force, force_target, e, local_force, scale)
        if want_jacobian:
            for m in range(3):
                for a in range(4):
                    local_jacobian[m, 3 + a] = -pull * grad_d3[m, a]
            add_jacobian(jacobian, jacobian_target, e, local_jacobian, scale)
