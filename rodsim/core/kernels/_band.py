"""Compiled fills of LAPACK band storage straight from a CSC matrix's data (the linear solves of
rodsim/solvers/linear.py on large models): one pass over the CSC columns, each band column
zeroed and then written, with no index arrays. The numpy fill through precomputed offsets
(:class:`rodsim.solvers.linear.LinearSolver`) is the reference; tests/test_linear_band.py
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
