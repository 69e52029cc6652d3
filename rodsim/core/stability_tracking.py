"""The stability verdict along a sequence of nearby stiffnesses (a ``Tracker``'s steps, a
``track``'s): the eigenvalues of K nearest zero from the last step's.

The verdict of a non-symmetric K (rodsim/core/stability.py, ``_smallest_real_part``) is the
smallest real part of the ``NEAREST`` eigenvalues of K nearest zero, found by ARPACK in
shift-invert mode at σ = 0 (the largest eigenvalues θ = 1/λ of K⁻¹, K⁻¹ from the step's own
factorisation), started from a fixed pseudo-random vector. Its first, coarse pass builds a
Krylov space of ``ncv`` = 20 vectors before it tests anything: 21 back-solves a verdict on
table3-catheter1, whatever the start.

Along a path, K moves little from one step to the next, and so do its eigenvectors nearest
zero. ``NearestModes`` keeps, from one verdict to the next, a start vector in their span:
the sum of the last step's Ritz vectors of the ``REMEMBERED`` eigenvalues nearest zero (each
real Ritz vector and each real and imaginary part of a complex one, at unit length), plus
``RANDOM_SHARE`` of the fixed pseudo-random vector (every eigenvector keeps a share of the
start, as in ARPACK's: an eigenvalue that comes nearer zero than the remembered ones is in
the Krylov space; 0.8 back-solves a verdict on table3-catheter1). From it, an Arnoldi
process on K⁻¹ (Gram–Schmidt with one reorthogonalisation where the first pass lost more
than 1 − 1/√2 of the vector, no restarts),
with ARPACK's own convergence test (dnaupd's ``dnconv``): the Ritz value θ of the Krylov
space of dimension m with Ritz vector y (unit length) is converged when its residual
‖K⁻¹ V y − θ V y‖ = h_{m+1,m} |e_mᵀ y| is at most ``COARSE_TOLERANCE`` · max(ε^(2/3), |θ|).
The test runs from the dimension one below the last step's (one eigenvalue problem of the
small Hessenberg matrix a dimension). When the ``NEAREST`` Ritz values largest in modulus
are converged and the smallest real part of λ = 1/θ exceeds ``COARSE_MARGIN`` times their
largest modulus — the coarse ARPACK pass's own rule for keeping its "stable" — that real
part is the verdict's: the same test on the same quantities as the coarse pass, from another
start. Anything else (no convergence within ``WARM_DIMENSION`` vectors, a real part left of
zero or near the axis, a singular or non-finite solve) is judged by ARPACK as before: no
convergence, the coarse pass and then the full one from the fixed start, bit for bit today's
call; a converged Ritz set that fails the margin, the full pass at once (the coarse pass
would fail it too but within ~1e-11 of it, where it keeps a number that differs from the
full pass's by round-off: 5.3e-15 measured; the same verdict).
A sequence's first verdict (nothing remembered) is ARPACK's, and the start for the next is
then made by the same Arnoldi process from the fixed pseudo-random vector.

The Arnoldi steps are compiled (rodsim/core/kernels/_arnoldi.py: the band LU's
back-solve in dgbtrs's order of operations and the Gram–Schmidt, one call to the first test
and one a step after) where K⁻¹ is a band LU and the model evaluates by its compiled kernels,
else numpy's (``_numpy_steps``, the reference): ARPACK's reverse communication costs ~15 µs
of Python and Fortran a back-solve beside the ~12 µs of the back-solve itself.

Deterministic: the same scene and the same sequence of values give the same verdicts bit
for bit; no choice depends on the clock. A verdict's smallest real part depends on the
sequence (the start), within the tolerance above: measured over table3-catheter1's tendon
ramp (0 → 4 N, 200 Tracker steps) at most 1.8e-11 relative from the ARPACK verdict of the
same K, the verdicts the same at every step; on seeded wires and catheters with a follower
tip force (ill-conditioned K: the dense eigenvalues of K⁻¹ differ from ARPACK's by up to
3.4e-8) within 1e-7, and the step where a divergence flips the verdict the same
(tests/test_stability_tracking.py).

Measured on table3-catheter1's ramp: 15.6 back-solves a verdict (13 to 19; 2.0 small
eigenvalue problems) against ARPACK's 21; the Tracker's verdict 0.92 → 0.70 ms a step, its
step 2.35 → 2.11 ms (CPU, best of 5, interleaved in one run; docs/benchmark-history.md,
"A warm start for the verdict of a non-symmetric K", with what did not pay).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.linalg import lapack

from rodsim.core.stability_band import BandLU

__all__ = ["NearestModes", "WARM_DIMENSION", "REMEMBERED", "RANDOM_SHARE"]

#: Largest Krylov space of the warm start before ARPACK takes over.
WARM_DIMENSION = 24
#: Ritz vectors summed into the next start: the NEAREST eigenvalues and the next two (a
#: mode about to enter the nearest six is then in the start already).
REMEMBERED = 8
#: Share of the fixed pseudo-random vector in the start (relative length).
RANDOM_SHARE = 1e-2
#: ARPACK's floor of a Ritz value's scale in its convergence test (dnconv: ε^(2/3)).
_EPS23 = float(np.finfo(float).eps) ** (2.0 / 3.0)


class _Ritz:
    """The Ritz values θ of a Krylov space of dimension m (its Hessenberg matrix ``h``,
    m × m, and h_{m+1,m} = ``beta``), their eigenvectors (``vectors``: LAPACK's real storage,
    dgeev), their residual estimates and their order by decreasing |θ|."""

    def __init__(self, h: np.ndarray, beta: float) -> None:
        real, imaginary, _, vectors, info = lapack.dgeev(h, compute_vl=0)
        if info != 0:
            raise np.linalg.LinAlgError("dgeev failed")
        last = vectors[-1]
        estimate = np.abs(last)
        pairs = np.flatnonzero(imaginary > 0.0)  # y = v_j ± i v_{j+1}: unit length (dgeev)
        if pairs.size:
            modulus = np.hypot(last[pairs], last[pairs + 1])
            estimate[pairs] = modulus
            estimate[pairs + 1] = modulus
        self.theta = real + 1j * imaginary
        self.imaginary = imaginary
        self.vectors = vectors
        self.estimate = beta * estimate
        self.order = np.argsort(-np.abs(self.theta), kind="stable")

    def converged(self, count: int, tolerance: float) -> bool:
        """Whether the ``count`` Ritz values largest in modulus pass dnconv's test."""
        near = self.order[:count]
        scale = np.maximum(_EPS23, np.abs(self.theta[near]))
        return bool(np.all(self.estimate[near] <= tolerance * scale))

    def start(self, basis: np.ndarray, count: int) -> np.ndarray:
        """The sum of the real Ritz vectors (and real and imaginary parts of complex ones) of
        the ``count`` Ritz values largest in modulus, each at unit length."""
        chosen = self.order[:count]
        m = self.theta.shape[0]
        columns = np.unique(np.concatenate([chosen, chosen[self.imaginary[chosen] < 0.0] - 1,
                                            chosen[self.imaginary[chosen] > 0.0] + 1]))
        columns = columns[columns < m]
        parts = self.vectors[:, columns]
        parts = parts / np.sqrt(np.einsum("ij,ij->j", parts, parts))
        return np.asarray(parts.sum(axis=1) @ basis)


#: Extend an Arnoldi factorisation (``basis`` rows, ``hessenberg``) from dimension
#: ``first`` to ``last``; returns the dimension reached.
Steps = Callable[[np.ndarray, np.ndarray, int, int], int]


def _numpy_steps(inverse: Callable[[np.ndarray], np.ndarray]) -> Steps:
    """Arnoldi steps on K⁻¹ = ``inverse`` in numpy: classical Gram–Schmidt, once more where
    the vector lost more than 1 − 1/√2 of its length (ARPACK's criterion); the reference of
    the compiled steps (rodsim/core/kernels/_arnoldi.py)."""

    def steps(basis: np.ndarray, hessenberg: np.ndarray, first: int, last: int) -> int:
        for j in range(first, last):
            w = np.array(inverse(basis[j]), dtype=float)
            previous = basis[:j + 1]
            before = w @ w
            h = previous @ w
            w -= h @ previous
            beta2 = w @ w
            if beta2 < 0.5 * before:
                again = previous @ w
                w -= again @ previous
                h += again
                beta2 = w @ w
            beta = float(np.sqrt(beta2))
            if not 0.0 < beta < np.inf:  # a breakdown, or numbers that are not finite
                return j
            hessenberg[:j + 1, j] = h
            hessenberg[j + 1, j] = beta
            basis[j + 1] = w / beta
        return last
    return steps


def _band_steps(factors: BandLU, sign: float) -> Steps:
    """Arnoldi steps on K⁻¹ = ``sign`` · A⁻¹, A factored by band LU (``factors``), compiled
    (rodsim/core/kernels/_arnoldi.py): one call for the steps to the first test, one a step
    after (~2 µs of Python each, against ~12 µs a step for the numpy steps' own)."""
    from rodsim.core.kernels._arnoldi import arnoldi_steps

    lu, pivots, lower, upper = factors.factors

    def steps(basis: np.ndarray, hessenberg: np.ndarray, first: int, last: int) -> int:
        return int(arnoldi_steps(lu, pivots, lower, upper, sign, basis, hessenberg, first,
                                 last))
    return steps


def _arnoldi(steps: Steps, start: np.ndarray, count: int, tolerance: float, first_check: int,
             dimension: int) -> tuple[_Ritz, np.ndarray] | None:
    """The Arnoldi process on K⁻¹ (``steps``) from ``start``, tested from the dimension
    ``first_check`` on, until the ``count`` Ritz values largest in modulus are converged:
    (their Ritz set, the Krylov basis (rows)), or None (not within ``dimension`` vectors, a
    breakdown, or numbers that are not finite)."""
    n = start.shape[0]
    basis = np.empty((dimension + 1, n))
    hessenberg = np.zeros((dimension + 1, dimension))
    size = float(np.sqrt(start @ start))
    if not 0.0 < size < np.inf:
        return None
    basis[0] = start / size
    m = min(max(first_check, count), dimension)
    if steps(basis, hessenberg, 0, m) < m:
        return None
    while True:
        try:
            ritz = _Ritz(hessenberg[:m, :m], float(hessenberg[m, m - 1]))
        except np.linalg.LinAlgError:
            return None
        if ritz.converged(count, tolerance):
            return ritz, basis[:m]
        if m == dimension or steps(basis, hessenberg, m, m + 1) < m + 1:
            return None
        m += 1


class NearestModes:
    """What a sequence of stability verdicts carries from one step to the next (module
    docstring): the start vector for the next verdict's Arnoldi process, and the Krylov
    dimension where the last one converged. Empty: the next verdict is ARPACK's from the
    fixed start. One object per sequence (a ``Tracker``, a ``track``); not shared between
    threads."""

    def __init__(self) -> None:
        self.start: np.ndarray | None = None
        self.converged_at = 0
        #: Back-solves (K⁻¹ v) made by the warm starts and the seeding runs (a count, for
        #: measurements).
        self.solves = 0

    def _steps(self, inverse: Callable[[np.ndarray], np.ndarray],
               band: tuple[BandLU, float] | None) -> Steps:
        """The Arnoldi steps: compiled on ``band`` (A's band LU and the sign s of
        K⁻¹ = s A⁻¹) when given, else numpy's on ``inverse``; counted."""
        steps = _numpy_steps(inverse) if band is None else _band_steps(*band)

        def counted(basis: np.ndarray, hessenberg: np.ndarray, first: int, last: int) -> int:
            reached = steps(basis, hessenberg, first, last)
            self.solves += max(reached - first, 0) + (reached < last)
            return reached
        return counted

    def _remember(self, found: tuple[_Ritz, np.ndarray] | None, random: np.ndarray) -> None:
        if found is None:
            self.start = None
            return
        ritz, basis = found
        self.converged_at = basis.shape[0]
        start = ritz.start(basis, REMEMBERED)
        self.start = (start / float(np.sqrt(start @ start))
                      + (RANDOM_SHARE / float(np.sqrt(random @ random))) * random)

    def nearest(self, inverse: Callable[[np.ndarray], np.ndarray], random: np.ndarray,
                count: int, tolerance: float, band: tuple[BandLU, float] | None = None
                ) -> np.ndarray | None:
        """The ``count`` eigenvalues of K nearest zero (λ = 1/θ) by the Arnoldi process from
        the remembered start, converged by ARPACK's test at ``tolerance``; None when nothing
        is remembered for a K of this size or the process does not converge (then nothing is
        remembered). ``random``: the fixed pseudo-random vector (ARPACK's start); ``band``:
        K⁻¹ as a band LU and a sign, for the compiled steps."""
        start = self.start
        if start is None or start.shape != random.shape:
            self.start = None
            return None
        found = _arnoldi(self._steps(inverse, band), start, count, tolerance,
                         max(count + 2, self.converged_at - 1), WARM_DIMENSION)
        self._remember(found, random)
        if found is None:
            return None
        ritz = found[0]
        return np.asarray(1.0 / ritz.theta[ritz.order[:count]])

    def seed(self, inverse: Callable[[np.ndarray], np.ndarray], random: np.ndarray,
             count: int, tolerance: float, band: tuple[BandLU, float] | None = None) -> None:
        """Remember a start for the next verdict: the Arnoldi process from ``random`` (the
        sequence's first verdict, or one after a warm start that did not converge)."""
        self._remember(_arnoldi(self._steps(inverse, band), random, count, tolerance,
                                count + 2, 2 * WARM_DIMENSION), random)
