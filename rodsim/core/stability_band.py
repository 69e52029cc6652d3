"""The stability verdict's factorisations in band storage, straight from the Jacobian's data.

The verdict (rodsim/core/stability.py) first factors the scaled symmetric part of the
stiffness K = −∂F/∂x and, for a non-symmetric K whose symmetric part is indefinite (the
paper's tendon coupling: table3-catheter1 at every tendon force), computes the eigenvalues
of K nearest zero by ARPACK in shift-invert mode. Done on scipy.sparse matrices, that cost
2.8 ms per verdict on table3-catheter1 (the sparse symmetric part and its band storage
0.3 ms, SuperLU and ARPACK 1.9 ms): half of a track step. ``BandStiffness`` does the
same two things from the CSC data of J in the model's fixed pattern, through offsets into
Fortran-ordered band storage built once per pattern:

- ``BandStiffness.certified``: the band Cholesky (LAPACK dpbtrf) of D S D,
  S = (K + Kᵀ)/2, D = diag(S)^(−1/2): the same matrix and the same test as before (no
  sparse sum, no COO scatter).
- ``BandStiffness.inverse``: K⁻¹ through a band LU (dgbtrf/dgbtrs) instead of SuperLU,
  the operator ARPACK's shift-invert iterations apply (about 30 times a verdict).

A cheaper screen was measured and rejected: the sign of det K from the band LU flips when
one real eigenvalue crosses zero, but not when two do. On table3-catheter1 with a
compressive tip load the straight catheter buckles in two planes at once (a double
eigenvalue): over 8 steps to 1.5 N the sign stayed +1 and four unstable steps would have
been reported stable. The verdict is therefore computed in full at every step.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from scipy.linalg import lapack

__all__ = ["BandLU", "BandStiffness", "COMPILED_SIZE"]

#: Unknowns from which :meth:`BandStiffness.certified` fills its band by a compiled pass over
#: J's entries (no offset arrays, no temporaries; the same array as the numpy offsets) rather
#: than a ``bincount`` through offsets (below: no numba to load for a small model's verdict).
#: At N = 100 000 on table1-50g (12.3 million entries) the offsets cost ~1 s to build and the
#: numpy verdict ~0.5 s more.
COMPILED_SIZE = 4000


class BandStiffness:
    """The verdict's factorisations for the Jacobians of one CSC pattern (n × n, entries at
    ``rows``, ``cols`` in CSC data order, bandwidths ``lower`` and ``upper``)."""

    def __init__(self, rows: np.ndarray, cols: np.ndarray, n: int, lower: int,
                 upper: int, compiled: bool = False) -> None:
        self.n, self.lower, self.upper = n, lower, upper
        width = max(lower, upper)
        self.width = width
        self._rows = np.asarray(rows, dtype=np.int64)
        self._cols = np.asarray(cols, dtype=np.int64)
        self._lu_rows = 2 * lower + upper + 1
        #: Whether :meth:`certified` runs the compiled pass (rodsim/core/kernels/_band.py)
        #: instead of the offsets below, which are then never built: from
        #: ``COMPILED_SIZE`` on, or when asked (``compiled``: a model that evaluates
        #: with its compiled kernels has numba loaded already; on tdcr-two-segment the
        #: pass fills the band in 32 µs against 91 µs through the offsets).
        self.compiled = compiled or n >= COMPILED_SIZE

    # S's lower band, Fortran order: S[i, j] (i ≥ j) at j (width + 1) + i − j; K[i, j] above
    # the diagonal lands on S[j, i]. Each of K[i, j] and K[j, i] brings half. Built at their
    # first use, in place (min(i, j) (width + 1) + |i − j|): at N = 100 000 (12 million
    # entries) each temporary array is ~0.1 s of fresh memory.
    @cached_property
    def _symmetric_index(self) -> np.ndarray:
        index = np.minimum(self._rows, self._cols)
        index *= self.width + 1
        offset = self._rows - self._cols
        index += np.abs(offset, out=offset)
        return index

    @cached_property
    def _symmetric_weight(self) -> np.ndarray:
        return np.where(self._rows == self._cols, 1.0, 0.5)

    @cached_property
    def _slot_rows(self) -> np.ndarray:
        """Row of S of each band slot (n: a padding slot below the last row)."""
        n = self.n
        return np.minimum(np.arange(self.width + 1)[:, None] + np.arange(n)[None, :], n)

    # The two below serve a stiffness whose symmetric part is not certified (a
    # non-symmetric K): built at its first verdict, never for a conservative model's.
    @cached_property
    def _skew_weight(self) -> np.ndarray:
        """Half of K[i, j] − K[j, i] on the same slot: +½ below the diagonal, −½ above."""
        return 0.5 * np.sign(self._rows - self._cols).astype(float)

    @cached_property
    def _lu_index(self) -> np.ndarray:
        """Offset of every entry in dgbtrf's Fortran-ordered band storage."""
        return (self._cols * self._lu_rows
                + (self.lower + self.upper + self._rows - self._cols))

    def certified(self, jacobian: np.ndarray, shift: float = 0.0,
                  scaled_shift: float = 0.0) -> bool:
        """Whether the scaled symmetric part of K = −J (``jacobian``: J's CSC data) is
        positive definite (its band Cholesky succeeds): K is then stable. With ``shift``
        σ: whether S + σ I is (D (S + σ I) D = D S D + σ D², D² = 1 / diag S), i.e. every
        eigenvalue of S is above −σ; with ``scaled_shift`` τ: whether D S D + τ I is (every
        eigenvalue of the unit-diagonal D S D above −τ: the neutral test of
        rodsim/core/stability.py)."""
        ab = self._scaled_band(jacobian)
        if ab is None:
            return False
        if shift:
            ab[0] += shift / -jacobian[self._diagonal]
        if scaled_shift:
            ab[0] += scaled_shift
        _, info = lapack.dpbtrf(ab, lower=1, overwrite_ab=1)
        return info == 0

    @cached_property
    def _diagonal(self) -> np.ndarray:
        """Position in the CSC data of each column's diagonal entry, column by column."""
        return np.flatnonzero(self._rows == self._cols)

    def skew_norm_bound(self, jacobian: np.ndarray) -> float:
        """An upper bound on ‖A‖₂, A = (K − Kᵀ)/2 the skew part of K = −J: its largest
        absolute column sum (‖A‖₂ ≤ √(‖A‖₁ ‖A‖∞), and ‖A‖₁ = ‖A‖∞ for a skew matrix)."""
        skew = np.abs(0.5 * (jacobian - jacobian[self._transposed]))
        return float(np.max(np.bincount(self._cols, weights=skew, minlength=self.n)))

    @cached_property
    def _transposed(self) -> np.ndarray:
        """Position in the CSC data of the entry (j, i) for each entry (i, j) (the pattern
        of J is structurally symmetric: every term couples its coordinates both ways)."""
        key = self._rows * self.n + self._cols
        order = np.argsort(key)
        mirrored = self._cols * self.n + self._rows
        return order[np.searchsorted(key, mirrored, sorter=order)]

    def _scaled_band(self, jacobian: np.ndarray) -> np.ndarray | None:
        """D S D's lower band (Fortran order, what dpbtrf reads), or None when ``jacobian``
        is not finite or a diagonal entry of S is not positive (no certificate)."""
        n, width = self.n, self.width
        if self.compiled:
            from rodsim.core.kernels._band import scaled_symmetric_band

            scaled = np.empty((width + 1, n), order="F")
            if scaled_symmetric_band(scaled.T, jacobian, self._rows, self._cols) != 0:
                return None
            return scaled
        if not np.all(np.isfinite(jacobian)):
            return None
        values = np.bincount(self._symmetric_index, weights=self._symmetric_weight * jacobian,
                             minlength=(width + 1) * n)
        ab = -values.reshape(n, width + 1).T  # (width + 1) × n
        diagonal = ab[0]
        if np.any(diagonal <= 0.0):
            return None
        scale = np.append(1.0 / np.sqrt(diagonal), 0.0)
        ab = ab * scale[self._slot_rows] * scale[:n][None, :]  # (S_ij d_i) d_j
        return np.asfortranarray(ab)

    def asymmetry(self, jacobian: np.ndarray) -> float:
        """max |K − Kᵀ| relative to max |K| (K = −J; ``jacobian``: J's CSC data)."""
        skew = np.bincount(self._symmetric_index, weights=self._skew_weight * jacobian,
                           minlength=(self.width + 1) * self.n)
        largest = float(np.max(np.abs(jacobian))) if jacobian.size else 0.0
        return 2.0 * float(np.max(np.abs(skew))) / largest if largest > 0.0 else 0.0

    def inverse(self, jacobian: np.ndarray) -> BandLU | None:
        """v ↦ K⁻¹ v (K = −J; ``jacobian``: J's CSC data) by band LU, with the sign of
        det K, or None when K is singular or not finite."""
        if not np.all(np.isfinite(jacobian)):
            return None
        ab = np.zeros((self._lu_rows, self.n), order="F")
        ab.T.reshape(-1)[self._lu_index] = -jacobian
        lu, pivots, info = lapack.dgbtrf(ab, self.lower, self.upper, overwrite_ab=1)
        if info != 0:
            return None
        return BandLU(lu, pivots, self.lower, self.upper)


class BandLU:
    """A matrix A factored by LAPACK's band LU (dgbtrf: ``lu``, ``pivots``, bandwidths
    ``lower`` and ``upper``): called with B, it solves A X = B (dgbtrs).
    ``determinant_sign`` is the sign of det A, read off the factors for nothing:
    det A = ± Π U_ii, the sign of the row permutation times that of the pivots. The stability
    verdict takes det K < 0 as a proof of an odd number of negative real eigenvalues of K
    (rodsim/core/stability.py)."""

    def __init__(self, lu: np.ndarray, pivots: np.ndarray, lower: int, upper: int) -> None:
        self._lu, self._pivots, self._lower, self._upper = lu, pivots, lower, upper

    @cached_property
    def determinant_sign(self) -> float:
        """+1.0 or −1.0, the sign of det A (0.0: a zero pivot); read off the factors when
        asked, while they are valid (a Newton solve's or a chord's factorisation never is)."""
        lower, upper, pivots = self._lower, self._upper, self._pivots
        diagonal = self._lu[lower + upper]
        swaps = np.count_nonzero(pivots != np.arange(len(pivots)))  # scipy: 0-based rows
        negative = np.count_nonzero(diagonal < 0.0)
        return (0.0 if np.any(diagonal == 0.0)
                else -1.0 if (swaps + negative) % 2 else 1.0)

    @property
    def factors(self) -> tuple[np.ndarray, np.ndarray, int, int]:
        """(dgbtrf's ``lu``, its 0-based ``pivots``, ``lower``, ``upper``): for compiled
        solves (rodsim/core/kernels/_arnoldi.py)."""
        return self._lu, self._pivots, self._lower, self._upper

    def __call__(self, rhs: np.ndarray) -> np.ndarray:
        x, _ = lapack.dgbtrs(self._lu, self._lower, self._upper, rhs, self._pivots)
        return x
