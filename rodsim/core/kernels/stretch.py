"""Kernel of :mod:`rodsim.core.terms.stretch`, Eq. (6): per segment (r_j, r_{j+1}) the energy
½ K_s l (|e|/l − 1)² is a spring of stiffness K_s / l and rest length l
(:func:`rodsim.core.kernels._spring.springs`, K_s of each segment): F = K_s ε ê on r_j,
minus on r_{j+1}, ε = |e|/l − 1.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._spring import springs, springs_energy


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, stiffness: np.ndarray, rest: float,
             scale: float, want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    springs(x, dofs, stiffness / rest, rest, scale, want_force, force, force_target,
            want_jacobian, jacobian, jacobian_target)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, stiffness: np.ndarray, rest: float) -> float:
    """Σ ½ K_s l ε² = Σ ½ (K_s / l)(|e| − l)²."""
    return springs_energy(x, dofs, stiffness / rest, rest)
