"""The linear solves of the Newton iterations (``static``, ``paper`` and the Newton finish of
CVODE/IDA): J Δx = b for matrices that share one fixed CSC pattern.

The rod's interleaved layout (Eq. 18) makes J banded (Eq. 20), and the model orders coupled
rods so that the tendon system stays banded too (``Model._order_for_band``). So:

- ``cholesky``: when the model is conservative, −J is symmetric, and positive definite at a
  stable state: LAPACK's band Cholesky (dpbsv). A factorisation that fails (−J indefinite:
  an unstable state, or a step far from equilibrium) falls back to band LU for that solve.
- ``band_lu``: LAPACK's band LU with partial pivoting (dgbsv), for non-symmetric J (the
  paper's tendon coupling) or as the fallback above.
- ``sparse_lu``: SuperLU, where the band is too wide for band storage to pay;
- ``dense_lu``: LAPACK's dense LU (dgesv), where such a pattern holds at least
  ``DENSE_SHARE`` of the n² entries (a string tendon's span element, whose friction
  coupling fills the block of its span's coordinates, rodsim/core/terms/_string_span.py):
  SuperLU took 30 ms a factorisation there (the self-bent catheter with a friction
  profile at N = 81, 567 unknowns, its whole block filled), dgesv 8–9 ms.

Measured at N = 40 (273 unknowns): SuperLU 490–540 µs per solve against
50 µs (dpbsv) and 68 µs (dgbsv); at N = 4000, 43–53 ms against 4.5 ms (docs/benchmark-history.md).
The values are written into Fortran-ordered band storage through offsets built once per
pattern (sequential, in CSC order); from ``COMPILED_FILL_SIZE`` unknowns on, by a compiled
pass over the CSC columns instead (rodsim/core/kernels/_band.py: no offset arrays, no
temporaries, a band array kept from solve to solve): at N = 100 000 on table1-50g (700 000
unknowns, 12.3 million entries) the offsets cost 0.39 s (Cholesky) and 0.23 s (LU) to build
and each fill 54 / 60 ms, against 21 / 30 ms compiled (the same array).

From ``REFINED_SOLVE_SIZE`` unknowns on, ``LinearSolver.solve`` refines its solution
once with the residual rhs − J Δx computed in twice the working precision
(rodsim/core/kernels/_refinement.py): the band factorisation's forward error grows with the
condition number (on table1-50g 4e-9 of the step at N = 2 000, 3.5e-5 at 100 000) and at
100 000 it cost static three Newton iterations; refined, 5 at every N (docs/benchmark-history.md,
"Large N").

``LinearSolver.factorized`` factors J once and solves for many right-hand sides (the
sensitivities of rodsim/app/inverse/sensitivity.py: one column per parameter): band Cholesky
(dpbtrf/dpbtrs) of −J when symmetric and positive definite, else band LU (dgbtrf/dgbtrs), or
SuperLU for wide bands.
"""

from __future__ import annotations

import threading
import warnings
from collections.abc import Callable
from functools import cached_property

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import lapack

from rodsim.core.stability_band import BandLU

__all__ = ["BandCholeskySolve", "LinearSolver", "MAX_BAND"]

#: Widest band (lower + upper + 1) solved in band storage; wider patterns use SuperLU.
MAX_BAND = 256
#: Smallest share of the n² entries from which a pattern too wide for band storage is solved
#: dense (module docstring, ``dense_lu``).
DENSE_SHARE = 0.2
#: Unknowns from which band storage is filled by the compiled pass (below, the numpy offsets:
#: no numba to load for a small model's solves).
COMPILED_FILL_SIZE = 4000
#: Unknowns from which :meth:`LinearSolver.solve` refines its band solution once with a
#: residual in twice the working precision (rodsim/core/kernels/_refinement.py): where it
#: pays. Measured on table1-50g (static, best of 3, CPU): the refinement costs 13–19 % of
#: the solve at N = 10 000 and 20 000 nodes (70 000 and 140 000 unknowns) with the same
#: 5 Newton iterations; at 40 000 (280 000) it is even (5 iterations against 6), at
#: 100 000 (700 000) it saves three of eight.
REFINED_SOLVE_SIZE = 200_000


class BandCholeskySolve:
    """X ↦ J⁻¹ X by the band Cholesky factor L of −J = L Lᵀ (LAPACK dpbtrs), what
    ``LinearSolver.factorized`` returns for a conservative model when the factorisation
    succeeds. That it exists says −J = K, the stiffness, is positive definite (Sylvester;
    Cholesky's success is invariant under diagonal scaling to within a factor of the order
    of n·eps, Demmel 1989): the stability verdict of the same state takes it for its
    certificate instead of factoring K again (``proves_stable``,
    ``rodsim.core.stability.assess``)."""

    #: Read by :func:`rodsim.core.stability.assess`: this factorisation proves K stable.
    proves_stable = True

    def __init__(self, factor: np.ndarray) -> None:
        self._factor = factor

    def __call__(self, rhs: np.ndarray) -> np.ndarray:
        x, _ = lapack.dpbtrs(self._factor, -rhs, lower=1)
        return x


class LinearSolver:
    """Solves J Δx = b for J given as CSC data in one fixed pattern.

    Parameters
    ----------
    pattern
        The CSC pattern (n × n) of J.
    rows, cols
        Row and column of every entry of the CSC data.
    band
        (lower, upper) bandwidth of the pattern.
    symmetric
        True when J is symmetric (a conservative model): −J is then tried with Cholesky.

    ``counts`` records how many solves each method did (since the solver was made: the
    runs on one pattern share a solver, rodsim/solvers/run_state.py).
    """

    def __init__(self, pattern: sp.csc_matrix, rows: np.ndarray, cols: np.ndarray,
                 band: tuple[int, int], symmetric: bool) -> None:
        self.n = pattern.shape[0]
        self._pattern = pattern
        lower, upper = band
        self.lower, self.upper = lower, upper
        self.banded = lower + upper + 1 <= MAX_BAND
        self.symmetric = symmetric and lower == upper
        self.counts = {"cholesky": 0, "band_lu": 0, "sparse_lu": 0, "dense_lu": 0}
        #: Solved dense (module docstring): a wide pattern that fills much of n².
        self.dense = not self.banded and len(rows) >= DENSE_SHARE * self.n ** 2
        diagonal = np.flatnonzero(rows == cols)
        self._diagonal = diagonal[np.argsort(cols[diagonal])]
        self._rows, self._cols = rows, cols
        self._compiled_fill = self.banded and self.n >= COMPILED_FILL_SIZE
        self.refined = self.banded and self.n >= REFINED_SOLVE_SIZE
        #: The band arrays :meth:`solve` fills and LAPACK overwrites, by height (compiled
        #: fill only: kept from solve to solve instead of fresh memory each time), per
        #: thread (a solver is shared by the runs on one pattern, run_state.py).
        self._scratch = threading.local()
        # Band storage is kept in Fortran order (what LAPACK reads: no copy on the call), so
        # an entry's offset in it is column × rows + row, which increases along the CSC data
        # (sorted by column, then row): the values are written straight in, in one
        # sequential pass (the flat iterator's scatter, ab.flat[index] = ..., was 24 ms of a
        # 54 ms solve at N = 40 000). The offsets are built at their first use: a symmetric
        # J whose Cholesky succeeds never needs the LU's, a non-symmetric one never the
        # Cholesky's (at N = 100 000 each is ~0.2 s of fresh memory).
        # dgbsv: ab[kl + ku + i − j, j] = J[i, j] in a (2 kl + ku + 1) × n array.
        self._lu_rows = 2 * lower + upper + 1

    @cached_property
    def _lu_index(self) -> np.ndarray:
        """Offset of every entry in dgbsv's band storage."""
        rows, cols = self._rows, self._cols
        return cols * self._lu_rows + (self.lower + self.upper + rows - cols)

    @cached_property
    def _cholesky_slots(self) -> tuple[np.ndarray, np.ndarray]:
        """(the entries on or below the diagonal, their offsets in dpbsv's lower-form band
        storage: ab[i − j, j] = −J[i, j] for i ≥ j)."""
        rows, cols = self._rows, self._cols
        below = np.flatnonzero(rows >= cols)
        return below, cols[below] * (self.lower + 1) + (rows[below] - cols[below])

    def _band_storage(self, height: int, index: np.ndarray, values: np.ndarray) -> np.ndarray:
        """A (height × n) Fortran-ordered band array with ``values`` at the Fortran-order
        offsets ``index`` (zeros elsewhere)."""
        ab = np.zeros((height, self.n), order="F")
        ab.T.reshape(-1)[index] = values  # ab.T is C-contiguous: reshape is a view
        return ab

    def _filled(self, data: np.ndarray, cholesky: bool, keep: bool) -> np.ndarray:
        """J's band storage: −J's lower band (dpbsv) if ``cholesky``, else J's (dgbsv). With
        ``keep`` (the array is overwritten by its one use), the compiled fill writes into the
        array kept for its height."""
        height = self.lower + 1 if cholesky else self._lu_rows
        if not self._compiled_fill:
            if cholesky:
                below, index = self._cholesky_slots
                ab = self._band_storage(height, index, data[below])
                return np.negative(ab, out=ab)
            return self._band_storage(height, self._lu_index, data)
        from rodsim.core.kernels._band import fill_band

        kept: dict[int, np.ndarray] = self._scratch.__dict__.setdefault("arrays", {})
        band = kept.get(height) if keep else None
        if band is None:
            band = np.empty((height, self.n), order="F")
            if keep:
                kept[height] = band
        pattern = self._pattern
        fill_band(band.T, data, pattern.indptr, pattern.indices,
                  0 if cholesky else self.lower + self.upper, -1.0 if cholesky else 1.0,
                  cholesky)
        return band

    def diagonal(self, data: np.ndarray) -> np.ndarray:
        """The diagonal of J."""
        return data[self._diagonal]

    def solve(self, data: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """Δx with J Δx = rhs; non-finite entries mean J is singular."""
        if not self.banded:
            return self._dense(data, rhs) if self.dense else self._sparse(data, rhs)
        n = self.n
        if self.symmetric:
            ab = self._filled(data, True, keep=True)
            factor, x, info = lapack.dpbsv(ab, -rhs, lower=1, overwrite_ab=1, overwrite_b=1)
            if info == 0:
                self.counts["cholesky"] += 1
                if not self._compiled_fill:  # a fresh array: the factor stays valid
                    self._scratch.last = data.copy(), BandCholeskySolve(factor)
                if self.refined:
                    x += lapack.dpbtrs(factor, -self._refinement_residual(data, x, rhs), lower=1)[0]
                return x
        ab = self._filled(data, False, keep=True)
        lu, pivots, x, info = lapack.dgbsv(self.lower, self.upper, ab, rhs.copy(),
                                           overwrite_ab=1, overwrite_b=1)
        self.counts["band_lu"] += 1
        if info != 0:
            return np.full(n, np.nan)
        if self.refined:
            x += lapack.dgbtrs(lu, self.lower, self.upper, self._refinement_residual(data, x, rhs),
                               pivots)[0]
        return x

    def _refinement_residual(self, data: np.ndarray, x: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """rhs − J x in twice the working precision, rounded: one step of iterative
        refinement with it makes the solution accurate to working precision while J's
        condition number is below 1/eps, where a double residual (error eps·|J|·|x|)
        leaves the error of the factorisation in place. At N = 100 000 on table1-50g that
        error was 1e-5 of the step, in stiff zig-zag modes of the quaternions whose force
        then cost static three more Newton iterations than at N = 10 000 (8 against 5;
        refined: 5 and 5)."""
        from rodsim.core.kernels._refinement import compensated_residual

        out = np.empty(self.n)
        compensated_residual(data, self._pattern.indptr, self._pattern.indices, x, rhs, out)
        return out

    def factorized(self, data: np.ndarray, keep: bool = False
                   ) -> Callable[[np.ndarray], np.ndarray] | None:
        """J factored once: a function solving J X = B for a vector or an (n, k) matrix B,
        or None when J is singular. With ``keep``, a large model's factors are made in the
        band array ``solve`` keeps (no fresh memory: at N = 100 000 a fresh LU array
        made a factorisation 230–540 ms against ~110 ms): the function is then valid only
        until the next ``solve`` or kept factorisation on this solver in this thread (a
        SUNDIALS preconditioner, which replaces its factorisation each time).

        A symmetric J equal to the last one ``solve`` factored by Cholesky in this thread
        (a model below ``COMPILED_FILL_SIZE`` unknowns, whose band arrays are fresh) takes
        that factor: dpbsv's is dpbtrf's, bit for bit. The verification of a Newton solve's
        last state (rodsim/solvers/base.py, ``equilibrium_factor``) factors nothing again:
        one of ~9 factorisations of a tdcr-two-segment batch case."""
        if self.dense:
            lu, pivots, info = lapack.dgetrf(self._dense_matrix(data), overwrite_a=1)
            if info != 0:
                return None
            return lambda rhs: lapack.dgetrs(lu, pivots, rhs)[0]
        if not self.banded:
            matrix = sp.csc_matrix((data, self._pattern.indices, self._pattern.indptr),
                                   shape=(self.n, self.n))
            try:
                return spla.splu(matrix).solve
            except RuntimeError:
                return None
        if self.symmetric:
            last = getattr(self._scratch, "last", None)
            if last is not None and bool((last[0] == data).all()):
                return last[1]  # the factor the last solve made of the same J: dpbsv's dpbtrf
            ab = self._filled(data, True, keep=keep)
            factor, info = lapack.dpbtrf(ab, lower=1, overwrite_ab=1)
            if info == 0:
                return BandCholeskySolve(factor)
        ab = self._filled(data, False, keep=keep)
        lu, pivots, info = lapack.dgbtrf(ab, self.lower, self.upper, overwrite_ab=1)
        if info != 0:
            return None
        return BandLU(lu, pivots, self.lower, self.upper)  # with the sign of det J

    def _dense_matrix(self, data: np.ndarray) -> np.ndarray:
        """J as a dense Fortran-ordered array."""
        matrix = np.zeros((self.n, self.n), order="F")
        matrix[self._rows, self._cols] = data
        return matrix

    def _dense(self, data: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        self.counts["dense_lu"] += 1
        x, info = lapack.dgesv(self._dense_matrix(data), rhs.copy(), overwrite_a=1,
                               overwrite_b=1)[2:]
        if info != 0:
            return np.full(self.n, np.nan)
        return np.asarray(x)

    def _sparse(self, data: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        self.counts["sparse_lu"] += 1
        matrix = sp.csc_matrix((data, self._pattern.indices, self._pattern.indptr),
                               shape=(self.n, self.n))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", spla.MatrixRankWarning)
            try:
                return spla.spsolve(matrix, rhs)
            except RuntimeError:
                return np.full(self.n, np.nan)
