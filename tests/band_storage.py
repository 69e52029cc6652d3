"""A dense band matrix in LAPACK's band storage and its band LU (dgbtrf), for the tests of
the band factorisations (tests/test_stability_band.py, tests/test_stability_tracking.py)."""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

from rodsim.core.stability_band import BandLU


def band_lu(dense: np.ndarray, lower: int, upper: int) -> BandLU:
    """dgbtrf's LU of ``dense`` (``lower`` and ``upper`` diagonals), stored with the
    ``lower`` extra rows its pivoting needs."""
    n = dense.shape[0]
    ab = np.zeros((2 * lower + upper + 1, n), order="F")
    for j in range(n):
        for i in range(max(0, j - upper), min(n, j + lower + 1)):
            ab[lower + upper + i - j, j] = dense[i, j]
    lu, pivots, info = lapack.dgbtrf(ab, lower, upper)
    assert info == 0
    return BandLU(lu, pivots, lower, upper)
