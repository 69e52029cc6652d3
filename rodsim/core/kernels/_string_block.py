"""A string tendon's summed chord block on and above its diagonal (the kernel
``rodsim.core.kernels.tendon_string``, ``evaluate_group``).

The chords of a set (the tendons of a catheter between the same two nodes) sum minus their
element Jacobians at frozen tension into one local block on their distinct columns:
Jdᵀ P Jd, P = τ (I − u uᵀ)/|d|, and each point's curvature τ Σ_m u_m ∂²p[m] (the module
docstring of ``tendon_string``). Both are symmetric, and each entry below the diagonal was
formed as the mirror of the one above it — the same operations in the same order, so the
same bits. Without the friction coupling (whose outer product f ⊗ ∂τ/∂x is not symmetric)
the block is therefore summed on and above the diagonal only, along its rows (contiguous),
and each entry is written into both of its CSC slots: half the additions of the full block,
and F, ∂F/∂x and the equilibria bit for bit the same.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels.tendon_string_path import _curvature


@njit(cache=True, inline="always")
def subtract_frozen(merged: np.ndarray, u: np.ndarray, factor: float, count: int,
                    pj: np.ndarray, proj: np.ndarray, summed: np.ndarray,
                    upper: bool) -> None:
    """``summed`` −= Jdᵀ P Jd, P = ``factor`` (I − u uᵀ), on the first ``count`` (distinct)
    columns ``merged`` of Jd: entry (k, j), k ≤ j, as Jd_kᵀ (P Jd_j), mirrored below the
    diagonal unless ``upper``. ``pj`` (3, ·) and ``proj`` (3, 3) are scratch. The rows'
    loops count from zero (``j = k + i``): numba's ``range(k, count)`` is not vectorised,
    this is (the same operations on each entry)."""
    for a in range(3):
        for b in range(3):
            proj[a, b] = ((1.0 if a == b else 0.0) - u[a] * u[b]) * factor
    for k in range(count):
        j0, j1, j2 = merged[0, k], merged[1, k], merged[2, k]
        for a in range(3):
            pj[a, k] = proj[a, 0] * j0 + proj[a, 1] * j1 + proj[a, 2] * j2
    if upper:
        for k in range(count):
            j0, j1, j2 = merged[0, k], merged[1, k], merged[2, k]
            for i in range(count - k):
                j = k + i
                summed[k, j] -= j0 * pj[0, j] + j1 * pj[1, j] + j2 * pj[2, j]
        return
    for k in range(count):
        j0, j1, j2 = merged[0, k], merged[1, k], merged[2, k]
        summed[k, k] -= j0 * pj[0, k] + j1 * pj[1, k] + j2 * pj[2, k]
        for j in range(k + 1, count):
            value = j0 * pj[0, j] + j1 * pj[1, j] + j2 * pj[2, j]
            summed[k, j] -= value
            summed[j, k] -= value


@njit(cache=True, inline="always")
def subtract_curvature(forms: np.ndarray, point: int, side: int, u: np.ndarray,
                       q: np.ndarray, n: np.ndarray, gq: np.ndarray, g: np.ndarray,
                       weights: np.ndarray, knot: np.ndarray, factor: float,
                       curvature: np.ndarray, summed: np.ndarray, upper: bool) -> None:
    """``summed`` −= ``factor`` Σ_m u_m ∂²p[m] of routing point ``point`` (side ``side`` of
    the chord) on its knots' quaternion columns (``knot[side]``: the first merged column of
    each, −1 without a weight), times the knots' weights; with ``upper`` the blocks and
    entries on and above the diagonal only. ``curvature`` (4, 4) is scratch."""
    _curvature(forms, point, u, q, n, gq, g, factor, curvature)
    for a in range(2):
        ka = knot[side, a]
        if ka < 0:
            continue
        for b in range(2):
            kb = knot[side, b]
            if kb < 0 or (upper and kb < ka):
                continue
            weight = weights[point, 2 + a] * weights[point, 2 + b]
            for i in range(4):
                start = i if upper and ka == kb else 0
                for step in range(4 - start):
                    j = start + step
                    summed[ka + i, kb + j] -= weight * curvature[i, j]


@njit(cache=True, inline="always")
def add_upper(jacobian: np.ndarray, target: np.ndarray, chord: int, local: np.ndarray,
              count: int, summed: np.ndarray) -> None:
    """A block summed on and above its diagonal into the CSC data: entry (k, j) of the
    symmetric block into slot ``target[chord, local k, local j]``, each slot once."""
    for k in range(count):
        lk = local[k]
        for j in range(k):
            jacobian[target[chord, lk, local[j]]] += summed[j, k]
        for i in range(count - k):
            j = k + i
            jacobian[target[chord, lk, local[j]]] += summed[k, j]
