"""The energies of a group of string tendons in one call (``energy_group``), the companion of
``evaluate_group`` in rodsim/core/kernels/tendon_string.py: the line search of ``static``
evaluates the energy at every trial (seven times a solve of tdcr-two-segment), and one
call for the six tendons there saves five calls' fixed cost (the dispatcher's type checks
of fourteen arguments) and the Python loop around them.

Loaded by rodsim/core/kernels/__init__.py as the ``energy_group`` of the kernel module
``tendon_string`` (a module ``NAME_energy`` beside a kernel ``NAME``); called by
``rodsim.core.model_evaluation.ModelEvaluation.energy`` for a ``KernelGroup``."""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels.tendon_string_path import path_length


@njit(cache=True)
def energy_group(x: np.ndarray, chord_start: np.ndarray, point_start: np.ndarray,
                 shared_order: np.ndarray, shared_start: np.ndarray,
                 dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
                 forms: np.ndarray, tension: np.ndarray, friction: np.ndarray,
                 profile: np.ndarray, weighted: np.ndarray, mu_in: np.ndarray,
                 mu_out: np.ndarray, entry_forms: np.ndarray, entry_slope: np.ndarray,
                 split: np.ndarray, energies: np.ndarray) -> None:
    """Write into ``energies[t]`` the energy T Σ |p_{k+1} − p_k| of tendon t of the group
    (unscaled; the constants packed as for ``evaluate_group``), computed as the kernel's
    ``energy`` computes it for that tendon alone: the same numbers, bit for bit
    (tests/test_energy_group.py). Frictionless tendons only: with friction the model asks
    for no energy."""
    for t in range(tension.shape[0]):
        if tension[t] == 0.0:
            energies[t] = 0.0
            continue
        c0, c1 = chord_start[t], chord_start[t + 1]
        p0, p1 = point_start[t], point_start[t + 1]
        energies[t] = tension[t] * path_length(x, dofs[c0:c1], weights[p0:p1],
                                               constant[p0:p1], forms[p0:p1])
