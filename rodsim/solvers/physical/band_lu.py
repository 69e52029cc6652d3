"""The Newton matrix of a physical-time step factored as a band (LAPACK's dgbtrf, partial
pivoting) in the rod's band order, SuperLU where the band is wide
(rodsim/solvers/physical/fixed_step.py; docs/dynamics.md, "What a step costs").

The step's unknowns (node positions, then three angles per segment) couple only along the
rod, except through the ordering: the positions come first and the angles after them, so
the matrix's band is as wide as the rod (188 on tdcr-two-segment, N = 61). In the band
order — each segment's angles right after the last coordinate of its quaternion, as IDA's
and CVODE's band order (rodsim/solvers/physical/dae.py) — it is narrow (14 there), and a
band LU factors the 360 × 360 matrix in about a third of SuperLU's time with its ordering
(0.11 against 0.35–0.5 ms measured alone); its solves are cheaper too. The order is the
coordinates' (no clock, no value): a scene gets the same factorisation every run. A band
wider than ``BAND_LIMIT`` (rods joined far apart in the coordinates, contact with another
rod) goes to SuperLU with its own column ordering.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.linalg.lapack as lapack
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from rodsim.solvers.physical.coordinates import PhysicalCoordinates

__all__ = ["band_order", "factor", "BAND_LIMIT"]

#: The widest band (lower + upper + 1) factored as a band; wider goes to SuperLU.
BAND_LIMIT = 64


def band_order(c: PhysicalCoordinates) -> np.ndarray:
    """The band order of a step's unknowns (positions, then 3 angles per segment): each
    position at its free coordinate, each segment's angles right after the last free
    coordinate of its quaternion (``unknowns[order]`` is in band order)."""
    key = np.concatenate([c.positions.astype(float),
                          (np.max(c.quaternions, axis=1)[:, None] + 0.5
                           + 0.1 * np.arange(3)[None]).ravel()])
    return np.argsort(key, kind="stable")


def factor(matrix: sp.csr_matrix, order: np.ndarray | None
           ) -> Callable[[np.ndarray], np.ndarray]:
    """The solve of ``matrix`` (canonical CSR: sorted, no duplicate entries): a band LU in
    ``order`` (``band_order``) when its band is at most ``BAND_LIMIT`` wide there,
    SuperLU otherwise or when ``order`` is None. RuntimeError when it is singular."""
    if order is None:
        return spla.splu(matrix.tocsc()).solve
    m = matrix.shape[0]
    place = np.empty(m, dtype=np.intp)
    place[order] = np.arange(m)
    rows = place[np.repeat(np.arange(m), np.diff(matrix.indptr))]
    cols = place[matrix.indices]
    offset = rows - cols
    lower = int(max(0, offset.max(initial=0)))
    upper = int(max(0, -offset.min(initial=0)))
    if lower + upper + 1 > BAND_LIMIT:
        return spla.splu(matrix.tocsc()).solve
    band = np.zeros((2 * lower + upper + 1, m))
    band[lower + upper + offset, cols] = matrix.data
    lu, pivots, info = lapack.dgbtrf(band, lower, upper, overwrite_ab=True)
    if info > 0:
        raise RuntimeError(f"factor is exactly singular (pivot {info})")
    if info < 0:
        raise ValueError(f"dgbtrf: argument {-info} is invalid")

    def solve(rhs: np.ndarray) -> np.ndarray:
        x, status = lapack.dgbtrs(lu, lower, upper, rhs[order], pivots)
        out = np.empty(m)
        out[order] = x
        return out

    return solve
