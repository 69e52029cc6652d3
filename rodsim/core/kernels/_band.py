"""Compiled fills of LAPACK band storage straight from a CSC matrix's data (the linear solves of
rodsim/solvers/linear.py on large models): one pass over the CSC columns, each band column
zeroed and then written, with no index arrays. The numpy fill through precomputed offsets
(``rodsim.solvers.linear.LinearSolver``) is the reference; tests/test_linear_band.py
checks that both write the same array. Standalone: no other kernel calls them."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def fill_band(ab: np.ndarray, data: np.ndarray, indptr: np.ndarray, indices: np.ndarray,
              diagonal_row: int, sign: float, lower_only: bool) -> None:
    """Write ``sign`` · J into the band array ``ab`` (height × n, Fortran order, given as its
    transpose ``ab.T``: n × height, C order): J[i, j] at ab[diagonal_row + i − j, j], zeros
    in every other slot; with ``lower_only`` only the entries with i ≥ j (dpbsv's lower
    form, ``diagonal_row`` = 0). J is the CSC matrix (``data``, ``indices``, ``indptr``)."""
    n, height = ab.shape
    for j in range(n):
        column = ab[j]
        for k in range(height):
            column[k] = 0.0
        for k in range(indptr[j], indptr[j + 1]):
            i = indices[k]
            if lower_only and i < j:
                continue
            column[diagonal_row + i - j] = sign * data[k]


@njit(cache=True)
def scaled_symmetric_band(ab: np.ndarray, data: np.ndarray, rows: np.ndarray,
                          cols: np.ndarray) -> int:
    """Write into ``ab`` (width + 1 × n, Fortran order, given as its transpose ``ab.T``) the
    lower band of D S D, S = (K + Kᵀ)/2, K = −J, D = diag(S)^(−1/2), J's entries at ``rows``,
    ``cols`` with values ``data``: S[i, j] (i ≥ j) at ab[i − j, j], each of K[i, j] and
    K[j, i] bringing half. The same operations in the same order as the numpy reference
    (``rodsim.core.stability_band.BandStiffness.certified``: a ``bincount`` of the halves
    in entry order, negated, times the row's scale, times the column's), so the same array.
    Returns 0, or 1 when ``data`` is not finite, 2 when a diagonal entry of S is not
    positive (``ab`` then partly written)."""
    n, height = ab.shape
    for j in range(n):
        for k in range(height):
            ab[j, k] = 0.0
    for k in range(data.shape[0]):
        value = data[k]
        if not np.isfinite(value):
            return 1
        i, j = rows[k], cols[k]
        if i == j:
            ab[j, 0] += 1.0 * value
        elif i > j:
            ab[j, i - j] += 0.5 * value
        else:
            ab[i, j - i] += 0.5 * value
    scale = np.empty(n)
    for j in range(n):
        diagonal = -ab[j, 0]
        if diagonal <= 0.0:
            return 2
        scale[j] = 1.0 / np.sqrt(diagonal)
    for j in range(n):
        for k in range(height):
            row = j + k
            ab[j, k] = -ab[j, k] * (scale[row] if row < n else 0.0) * scale[j]
    return 0
