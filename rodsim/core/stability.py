"""Stability verdict of an equilibrium: is the stiffness K = −∂F/∂x positive definite?

An equilibrium F(x) = 0 of a conservative system is a stable one (a strict minimum of the
potential) when the stiffness K = −∂F/∂x on the free coordinates — the Hessian of the
energy — is positive definite. A straight rod compressed beyond its Euler load is an
equilibrium too, and every integrator may stop on it (Newton from the straight rest state
never leaves the symmetric branch); its K has a negative eigenvalue, and the verdict says so.

Method: a Cholesky factorisation of the symmetric part S = (K + Kᵀ)/2, in band storage
(``scipy.linalg.cholesky_banded``, bandwidth ``model.band``), succeeds exactly when S is
positive definite. K is scaled symmetrically first, S → D S D with D = diag(S)^(−1/2) (a
congruence: the same definiteness), so that positions [m] and quaternion components and
stiff penalties (K_P) next to soft bending do not make the factorisation's round-off depend
on units. When the factorisation fails, the smallest eigenvalue of S is reported
(``min_eigenvalue``, in K's units: N/m, N or N·m per quaternion unit): dense ``eigvalsh`` for
up to ``DENSE_LIMIT`` coordinates, else by bisection on the shift σ with Cholesky
factorisations of S − σ I (ARPACK's smallest-algebraic mode did not converge in minutes on
a straight compressed rod of 1000 nodes; the bisection takes about 30 banded
factorisations).

No direction is null at an equilibrium of the shipped scenes: positions are clamped at the
base, each quaternion's norm is held by the centerline penalty (|d3| = |q|², Eq. 9), and
its rotation about d3 by the bending–twisting term. IDA's unit quaternions are exact, but it
returns the state in the same coordinates, so K is the same matrix. Measured: table1-50g
with each of static, cvode, ida and paper gives a positive definite K.

Non-conservative terms (the paper's tendon coupling) make K non-symmetric. A positive
definite symmetric part still proves stability (every eigenvalue of K then has a positive
real part); but the paper's coupling gives table3-catheter1 an indefinite symmetric part
at an equilibrium where every eigenvalue of K has a positive real part. So for a
non-symmetric K whose symmetric part is not positive definite, the verdict comes from the
eigenvalues of K itself: stable when each has a positive real part (no divergence: no
static perturbation grows), and ``min_eigenvalue`` is then the smallest real part — of all
eigenvalues up to 200 coordinates, of the six nearest zero above. Those six can all lie
right of zero while one further out lies left of it (many soft modes first): when the
skew part A = (K − Kᵀ)/2 is small enough, K's symmetric part proves that eigenvalue
(``_proven_left_eigenvalue``; one shifted band Cholesky decides whether to look, a
dense symmetric eigensolve up to ``DENSE_LIMIT`` coordinates looks); and det K < 0,
read off the band LU that ARPACK's shift-invert uses anyway, proves an odd number of
negative real eigenvalues wherever they are (``min_eigenvalue`` NaN: not located). Not
seen: an even number of negative real eigenvalues, or complex pairs with negative real
parts, beyond the six nearest zero when the skew part is large (measured on rod tendons
pulled at their distal ends: 2 of the 6 states with negative real eigenvalues had an
even number there). Flutter (growing oscillations of the pseudo-dynamics) is not assessed.

Neutral states. A mechanism or a rigid-body mode (a rod hung from a ball joint turns about
its own axis for free; an unloaded one swings freely) has zero eigenvalues, which round-off
puts on either side of zero: Cholesky certified a ball joint with no load "positive definite"
and called a hanging rod "UNSTABLE, smallest eigenvalue 2.09e-10", the sign following the
kernel choice. The verdict is therefore read on the diagonally scaled symmetric part
D S D (unit diagonal, dimensionless) with a stated tolerance τ = ``neutral_tolerance``
(100 n ε, n free coordinates): every eigenvalue above τ: stable; one below −τ: unstable;
otherwise neutral, with the number of eigenvalues within τ of zero (``neutral_modes``;
counted densely up to ``DENSE_LIMIT`` coordinates, −1 above: not counted). Measured
(n = 101: τ = 2.2e-12): the zero modes of ball-jointed rods at 3e-16 from static and up to
3.0e-13 from IDA (its state a residual away from the exact equilibrium: the zero mode's
curvature is not exactly zero there), the pendulum's swing 1.3e-7; the smallest scaled
eigenvalue of a shipped scene 4.6e-11 (tip-on-tissue, n = 280: τ = 6.2e-12), of the others
6e-10 and above. One more band Cholesky (of D S D − τ I) per certified verdict tells a strict
minimum from a neutral one, up to ``DENSE_LIMIT`` coordinates only: a slender rod's
smallest scaled eigenvalue falls like (h/L)³, below τ (which grows like n) at large N —
table1-50g at N = 4 000 (28 000 coordinates) was called neutral and CVODE's finish refused
it seven times — so above the limit a positive definite K is stable, as before the neutral
test. The non-symmetric path (the paper's tendon coupling) is judged
by its eigenvalues' real parts as before: no neutral state there.

``assess`` (a model's verdict, what every run and every track step gets) does the
factorisations in band storage straight from the Jacobian's data (rodsim/core/
stability_band.py: the same Cholesky test; K⁻¹ for ARPACK by band LU instead of SuperLU);
``stiffness_stability`` (any sparse K) builds the sparse matrices. Along a sequence of steps
(a Tracker's, a track's) the eigenvalues nearest zero start from the last step's
(rodsim/core/stability_tracking.py): the same verdicts, the same tolerance.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from rodsim.core.stability_band import BandLU, BandStiffness
from rodsim.core.stability_tracking import NearestModes

if TYPE_CHECKING:
    from rodsim.core.model import Model

__all__ = ["Stability", "stiffness_stability", "assess", "eigenvalue_text", "neutral_tolerance",
           "DENSE_LIMIT"]

#: Largest system (free coordinates) whose smallest eigenvalue is computed densely.
DENSE_LIMIT = 2000
#: Largest non-symmetric K whose eigenvalues are all computed (dense ``eigvals`` is O(n³);
#: docs/benchmark-history.md, "Measurements behind the core's constants"); above, the NEAREST ones
#: to zero.
DENSE_NONSYMMETRIC_LIMIT = 200
NEAREST = 6
#: Relative precision of the smallest eigenvalue found by bisection (larger systems).
BISECTION_TOLERANCE = 1e-6
#: At most this many factorisations in the bisection (it needs about 30).
MAX_BISECTIONS = 200
#: Widest band (lower + upper + 1) factored in band storage by :func:`assess` (the Newton
#: solves' limit, rodsim/solvers/linear.py); wider: the sparse path.
MAX_BAND = 256
#: Seed of ARPACK's start vector (a fixed pseudo-random one: the same K gives the same
#: eigenvalues, bit for bit, where ARPACK's own random start made a verdict's smallest real
#: part differ by ~1e-11 relative from one call to the next).
ARPACK_SEED = 24
#: ARPACK's tolerance for the verdict's eigenvalues nearest zero, and that of its first,
#: coarse pass (``_smallest_real_part``), whose "stable" is kept where every real part
#: exceeds ``COARSE_MARGIN`` times the largest modulus among them.
ARPACK_TOLERANCE = 1e-10
COARSE_TOLERANCE = 1e-6
COARSE_MARGIN = 1e-3


def neutral_tolerance(n: int) -> float:
    """τ: an eigenvalue of the unit-diagonal D S D of n coordinates within τ of zero is a
    neutral mode (module docstring, "Neutral states")."""
    return 100.0 * n * float(np.finfo(float).eps)


@dataclass(frozen=True)
class Stability:
    """The verdict: ``stable`` when K's symmetric part is positive definite beyond the
    neutral tolerance; otherwise ``min_eigenvalue`` is its smallest eigenvalue (NaN when it
    could not be computed), and ``neutral_modes`` > 0 (−1: not counted) says that no
    eigenvalue lies below −``tolerance`` but that many lie within it of zero: a neutral
    state, neither stable nor unstable (module docstring)."""

    stable: bool
    min_eigenvalue: float = float("nan")
    neutral_modes: int = 0
    tolerance: float = float("nan")

    @property
    def neutral(self) -> bool:
        """A mechanism or rigid-body mode: zero eigenvalues within the tolerance, none
        below it."""
        return not self.stable and self.neutral_modes != 0

    @property
    def unstable(self) -> bool:
        """An eigenvalue below −tolerance (or a real part below zero): a perturbation grows."""
        return not self.stable and self.neutral_modes == 0

    @property
    def neutral_text(self) -> str:
        """'k zero modes within τ' for a neutral verdict."""
        count = "zero modes" if self.neutral_modes < 0 else (
            f"{self.neutral_modes} zero mode{'s' if self.neutral_modes != 1 else ''}")
        return f"{count} within {self.tolerance:.2g}"

    @property
    def eigenvalue_text(self) -> str:
        """The smallest eigenvalue as the messages quote it (``eigenvalue_text``)."""
        return eigenvalue_text(self.min_eigenvalue)


def eigenvalue_text(value: float) -> str:
    """'smallest eigenvalue <value>' for a verdict's ``min_eigenvalue``, or, for NaN (an
    unstable K whose negative eigenvalue was proven by det K < 0 but not located, or a
    value that could not be computed), what is known."""
    if np.isnan(value):
        return "smallest eigenvalue not located: det K < 0 or not computed"
    return f"smallest eigenvalue {value:.3g}"


def _band_storage(matrix: sp.coo_matrix, width: int) -> np.ndarray:
    """Lower band storage of a symmetric matrix: ``ab[i - j, j] = a[i, j]`` for i ≥ j."""
    ab = np.zeros((width + 1, matrix.shape[0]))
    lower = matrix.row >= matrix.col
    np.add.at(ab, (matrix.row[lower] - matrix.col[lower], matrix.col[lower]),
              matrix.data[lower])
    return ab


def stiffness_stability(stiffness: sp.spmatrix, width: int | None = None, *,
                        indefinite: bool = False,
                        inverse: Callable[[np.ndarray], np.ndarray] | None = None
                        ) -> Stability:
    """The verdict for the stiffness matrix K (sparse, n × n) of bandwidth ``width``
    (default: computed from the matrix). ``indefinite``: the scaled symmetric part is
    already known not to be positive definite (the test is skipped); ``inverse``: v ↦ K⁻¹ v,
    for the eigenvalues nearest zero (default: a sparse LU of K)."""
    stiffness = sp.csc_matrix(stiffness)
    if stiffness.shape[0] == 0:
        return Stability(True)
    entries = stiffness.tocoo()
    if width is None:
        width = int(np.max(np.abs(entries.row - entries.col)))
    tolerance = neutral_tolerance(stiffness.shape[0])
    if not indefinite and _symmetric_part_positive_definite(entries, width):
        if (stiffness.shape[0] > DENSE_LIMIT
                or _symmetric_part_positive_definite(entries, width, -tolerance)):
            return Stability(True)
        return _neutral(stiffness)
    symmetric = (0.5 * (stiffness + stiffness.T)).tocoo()
    asymmetry = abs(stiffness - stiffness.T).max()
    if asymmetry <= 1e-12 * abs(stiffness).max():
        if _symmetric_part_positive_definite(entries, width, tolerance):
            return _neutral(stiffness)
        return Stability(False, _smallest_eigenvalue(symmetric, width))
    real_part = _smallest_real_part(stiffness, inverse)
    if real_part > 0.0 and stiffness.shape[0] > DENSE_NONSYMMETRIC_LIMIT:
        skew = 0.5 * (stiffness - stiffness.T)
        left = _proven_left_eigenvalue(stiffness, float(abs(skew).sum(axis=0).max()))
        if left is not None:
            return Stability(False, left)
    return Stability(bool(real_part > 0.0), real_part)


def _cholesky_succeeds(ab: np.ndarray) -> bool:
    try:
        la.cholesky_banded(ab, lower=True)
    except la.LinAlgError:
        return False
    return True


def _symmetric_part_positive_definite(entries: sp.coo_matrix, width: int,
                                      scaled_shift: float = 0.0) -> bool:
    """Whether the Cholesky factorisation of the diagonally scaled symmetric part (K + Kᵀ)/2
    succeeds, from K's entries (no duplicates) without forming the sparse sum: its lower
    band accumulated directly, 0.5 K_ij + 0.5 K_ji (= 0.5 (K_ij + K_ji) exactly: halving is
    exact), entry (i, j) scaled by 1/√S_ii · 1/√S_jj — the numbers the sparse sum gave, at a
    fraction of the time (the verdict of every converged solve)."""
    n = entries.shape[0]
    row, col = entries.row.astype(np.int64), entries.col.astype(np.int64)
    lower = np.abs(row - col)
    weights = np.where(row == col, entries.data, 0.5 * entries.data)
    ab = np.bincount(lower * n + np.minimum(row, col), weights=weights,
                     minlength=(width + 1) * n)[:(width + 1) * n].reshape(width + 1, n)
    diagonal = ab[0]
    if np.any(diagonal <= 0.0) or not np.all(np.isfinite(ab)):
        return False
    scale = 1.0 / np.sqrt(diagonal)
    for k in range(width + 1):  # entry (j + k, j): value · scale[j + k] · scale[j]
        ab[k, :n - k] = ab[k, :n - k] * scale[k:] * scale[:n - k]
        ab[k, n - k:] = 0.0
    ab[0] += scaled_shift  # D S D + τ I (the neutral test)
    return _cholesky_succeeds(ab)


def _scaled_symmetric(stiffness: sp.spmatrix) -> tuple[np.ndarray, np.ndarray] | None:
    """(S, D S D) dense, or None when S has a diagonal entry that is not positive."""
    dense = stiffness.toarray()
    symmetric = 0.5 * (dense + dense.T)
    diagonal = np.diag(symmetric)
    if np.any(diagonal <= 0.0) or not np.all(np.isfinite(symmetric)):
        return None
    scale = 1.0 / np.sqrt(diagonal)
    return symmetric, symmetric * scale[:, None] * scale[None, :]


def _neutral(stiffness: sp.spmatrix) -> Stability:
    """The neutral verdict of a K whose D S D has no eigenvalue below −τ and one within τ
    of zero: the count of those (dense up to DENSE_LIMIT, else −1) and S's smallest
    eigenvalue."""
    n = stiffness.shape[0]
    tolerance = neutral_tolerance(n)
    if n > DENSE_LIMIT:
        return Stability(False, float("nan"), -1, tolerance)
    parts = _scaled_symmetric(stiffness)
    if parts is None:
        return Stability(False, float("nan"), -1, tolerance)
    symmetric, scaled = parts
    count = int(np.sum(np.abs(la.eigvalsh(scaled)) <= tolerance))
    smallest = float(la.eigvalsh(symmetric, subset_by_index=[0, 0])[0])
    return Stability(False, smallest, max(count, 1), tolerance)


#: The stiff terms of a rod (its stretch and the centerline penalty): what makes a slender
#: rod's scaled stiffness ill-conditioned.
STIFF_TERMS = ("stretch", "centerline")
#: A mode within τ of zero whose Rayleigh quotient on the other terms, relative to their own
#: diagonal along it, exceeds this is resisted (a slender rod's bending), not neutral.
RESISTED = 1e-9


def _model_neutral(model: Model, x: np.ndarray, stiffness: sp.spmatrix) -> Stability:
    """``_neutral`` of a positive definite K, with the modes within τ of zero checked on
    the model's soft terms (everything but ``STIFF_TERMS``) alone: a mechanism or a rigid
    body mode costs them nothing, but a slender rod's lowest bending mode falls below τ
    only because the stretch and penalty stiffness set the scale (a clamped 0.014-inch
    nitinol wire, L/r 1 100 at N = 81: smallest scaled eigenvalue below τ = 1.2e-11, called
    "neutral: 2 zero modes", and `--require-stable` refused it). The soft terms' quotient
    along each such mode, over their diagonal along it, tells the two apart: measured 3.0e-4
    on the bending modes of that wire, 3.8e-17 to 4.6e-17 on the ball-jointed rods' zero
    modes (tests/test_stability_neutral.py)."""
    verdict = _neutral(stiffness)
    n = stiffness.shape[0]
    stiff = [k for k, term in enumerate(model.terms)
             if getattr(term, "key", "") in STIFF_TERMS]
    if verdict.neutral_modes <= 0 or not stiff or n > DENSE_LIMIT:
        return verdict
    parts = _scaled_symmetric(stiffness)
    if parts is None:
        return verdict
    symmetric, scaled = parts
    values, vectors = la.eigh(scaled)
    near = np.abs(values) <= verdict.tolerance
    if not np.any(near):
        return verdict
    modes = vectors[:, near] / np.sqrt(np.diag(symmetric))[:, None]
    soft_model = copy.copy(model)
    factors = model.term_scales.copy()
    factors[stiff] = 0.0
    soft_model.term_scales = factors
    soft_model._scale_list = factors.tolist()
    soft = -soft_model.jacobian(x).toarray()
    soft = 0.5 * (soft + soft.T)
    weight = np.abs(np.diag(soft))
    reduced = modes.T @ soft @ modes
    size = np.sqrt(np.maximum((modes**2).T @ weight, np.finfo(float).tiny))
    reduced = reduced / size[:, None] / size[None, :]
    quotients = la.eigvalsh(0.5 * (reduced + reduced.T))
    if np.any(quotients < -RESISTED):
        return verdict
    count = int(np.sum(quotients <= RESISTED))
    if count == 0:
        return Stability(True)
    return Stability(False, verdict.min_eigenvalue, count, verdict.tolerance)


def _smallest_eigenvalue(symmetric: sp.coo_matrix, width: int) -> float:
    """The smallest eigenvalue of a symmetric matrix that is not positive definite: dense
    for up to DENSE_LIMIT coordinates, else by bisection on the shift σ — the Cholesky
    factorisation of S − σ I succeeds exactly when σ is below it — to a relative
    ``BISECTION_TOLERANCE`` (about 30 banded factorisations). NaN if not finite."""
    if not np.all(np.isfinite(symmetric.data)):
        return float("nan")
    n = symmetric.shape[0]
    if n <= DENSE_LIMIT:
        return float(la.eigvalsh(symmetric.toarray(), subset_by_index=[0, 0])[0])
    ab = _band_storage(symmetric, width)

    def below(sigma: float) -> bool:
        shifted = ab.copy()
        shifted[0] -= sigma
        return _cholesky_succeeds(shifted)

    radius = np.asarray(abs(symmetric).sum(axis=1)).ravel() - np.abs(symmetric.diagonal())
    low = float(np.min(symmetric.diagonal() - radius))  # Gershgorin: no eigenvalue below
    low -= 1e-9 * abs(low) + np.finfo(float).tiny
    high = 0.0
    for _ in range(MAX_BISECTIONS):
        if high - low <= BISECTION_TOLERANCE * abs(low):
            break
        trial = low / 10.0 if high == 0.0 and low < -1e-300 else 0.5 * (low + high)
        if below(trial):
            low = trial
        else:
            high = trial
    return float(0.5 * (low + high))


class _Applied(spla.LinearOperator):
    """v ↦ ``apply(v)`` as ARPACK calls it (``matvec`` itself: no shape checks or reshapes
    of LinearOperator's wrapper at each of the ~27 calls of a verdict; ``rodsim.core.
    stability.assess`` measured 0.1 ms of table3-catheter1's 1.0 ms in them)."""

    def __init__(self, n: int, apply: Callable[[np.ndarray], np.ndarray]) -> None:
        super().__init__(np.dtype(float), (n, n))
        self._apply = apply

    def matvec(self, x: np.ndarray) -> np.ndarray:
        return self._apply(x)

    _matvec = matvec


def _smallest_real_part(stiffness: sp.csc_matrix | Callable[[], sp.csc_matrix],
                        inverse: Callable[[np.ndarray], np.ndarray] | None = None,
                        n: int | None = None, coarse: bool = False,
                        modes: NearestModes | None = None,
                        band: tuple[BandLU, float] | None = None) -> float:
    """The smallest real part of an eigenvalue of a general matrix (NaN if not computed):
    of all eigenvalues up to ``DENSE_NONSYMMETRIC_LIMIT`` coordinates, else of the
    ``NEAREST`` eigenvalues nearest zero (shift-invert at 0, one sparse LU) — a
    divergence instability is an eigenvalue crossing zero; it finds the same smallest real
    part as all eigenvalues at a twentieth of the time (docs/benchmark-history.md, "Measurements
    behind the core's constants"). ``inverse`` (v ↦ K⁻¹ v) replaces the sparse LU. ARPACK
    starts from a fixed pseudo-random vector (``ARPACK_SEED``): reproducible.

    ``stiffness`` may be a function making K (with ``n`` its size): it is then made only
    where needed — the dense path, or no ``inverse`` — since shift-invert at a real σ with
    ``inverse`` given never multiplies by K (scipy's ``eigs`` reads its shape alone).

    ``coarse`` (the model verdict, ``assess``): ARPACK first to ``COARSE_TOLERANCE``, and its
    smallest real part is kept when every real part of those eigenvalues exceeds
    ``COARSE_MARGIN`` times their largest modulus (stable by a wide margin); anything else —
    an eigenvalue left of zero, near the imaginary axis, or no convergence — is computed
    again to ``ARPACK_TOLERANCE`` from the same start, the verdict it always had. The
    tolerance bounds each Ritz residual relative to its value; the smallest eigenvalue of K
    (K⁻¹'s largest) converges first, and its real part moved by at most 5.3e-15 (relative)
    over table3-catheter1's tendon ramp of 200 steps (0 → 4 N), where the coarse pass took
    21.0 solves against 26.6 (tests/test_stability_coarse.py).

    ``modes`` (a sequence of verdicts: a Tracker's, a track's; with ``coarse`` and
    ``inverse``): the coarse pass by an Arnoldi process from the last verdict's eigenvectors
    nearest zero instead, the same test and the same rule for keeping its "stable"
    (rodsim/core/stability_tracking.py); where it converges but does not keep, the full pass
    at once. ``band``: K⁻¹ as (a band LU, a sign), for its compiled steps."""
    if callable(stiffness):
        if n is None or n <= DENSE_NONSYMMETRIC_LIMIT or inverse is None:
            stiffness = stiffness()
        else:
            make = stiffness
            stiffness = _Applied(n, lambda v: make() @ v)
    n = stiffness.shape[0]
    try:
        if n <= DENSE_NONSYMMETRIC_LIMIT:
            assert sp.issparse(stiffness)
            return float(np.min(la.eigvals(stiffness.toarray()).real))
        operator = None if inverse is None else _Applied(n, inverse)
        start = np.random.default_rng(ARPACK_SEED).standard_normal(n)
        sequence = modes if coarse and inverse is not None else None
        if coarse:
            values = None if sequence is None or inverse is None else sequence.nearest(
                inverse, start, min(NEAREST, n - 2), COARSE_TOLERANCE, band)
            if values is None:
                values = _nearest(stiffness, operator, start, COARSE_TOLERANCE)
            if values is not None and np.min(values.real) > COARSE_MARGIN * np.max(
                    np.abs(values)):
                _seeded(sequence, inverse, start, n, band)
                return float(np.min(values.real))
        values = spla.eigs(stiffness, k=min(NEAREST, n - 2), sigma=0.0, which="LM",
                           OPinv=operator, return_eigenvectors=False, maxiter=20 * n,
                           tol=ARPACK_TOLERANCE, v0=start)
        _seeded(sequence, inverse, start, n, band)
        return float(np.min(values.real))
    except (la.LinAlgError, spla.ArpackError, RuntimeError, ValueError):
        return float("nan")


def _seeded(modes: NearestModes | None, inverse: Callable[[np.ndarray], np.ndarray] | None,
            start: np.ndarray, n: int, band: tuple[BandLU, float] | None) -> None:
    """A start for the sequence's next verdict where it has none (``NearestModes.seed``)."""
    if modes is not None and inverse is not None and modes.start is None:
        modes.seed(inverse, start, min(NEAREST, n - 2), COARSE_TOLERANCE, band)


def _nearest(stiffness: sp.csc_matrix | spla.LinearOperator,
             operator: spla.LinearOperator | None, start: np.ndarray, tolerance: float
             ) -> np.ndarray | None:
    """The ``NEAREST`` eigenvalues of K nearest zero by ARPACK to ``tolerance`` (the
    coarse pass of ``_smallest_real_part``), None where it fails."""
    n = stiffness.shape[0]
    try:
        return spla.eigs(stiffness, k=min(NEAREST, n - 2), sigma=0.0, which="LM",
                         OPinv=operator, return_eigenvectors=False, maxiter=20 * n,
                         tol=tolerance, v0=start)
    except (la.LinAlgError, spla.ArpackError, RuntimeError, ValueError):
        return None


def _proven_left_eigenvalue(stiffness: sp.csc_matrix, skew_norm: float) -> float | None:
    """For a non-symmetric K = S + A (S symmetric, A skew, ‖A‖₂ ≤ ``skew_norm`` = ρ) whose
    eigenvalues nearest zero all have positive real parts: S's smallest eigenvalue when it
    proves that K has an eigenvalue with a negative real part, else None.

    The proof (Bauer–Fike for the normal S, along K(t) = S + t A, t: 0 → 1): every eigenvalue
    of K(t) lies within t ρ of one of S's, so the union of the disks of radius ρ about S's
    eigenvalues holds all of them, and each connected part of it keeps as many as it holds
    at t = 0. If the part holding S's smallest eigenvalue lies left of zero, K has an
    eigenvalue there. The eigenvalues nearest zero miss it when many small positive ones come
    first: a slender robot with a pin moved and a small world-frame moment (nearly
    symmetric: ρ = 6.5e-6) had a double eigenvalue −0.067 behind 87 smaller ones and was
    reported stable (tests/test_stability_band.py). Dense: up to ``DENSE_LIMIT``
    coordinates (above, None: the verdict is that of the nearest eigenvalues)."""
    n = stiffness.shape[0]
    if n > DENSE_LIMIT or not np.all(np.isfinite(stiffness.data)):
        return None
    symmetric = 0.5 * (stiffness + stiffness.T).toarray()
    values = la.eigvalsh(symmetric)
    top = values[0]
    for value in values[1:]:  # the connected part of the disks about values[0]
        if value - top > 2.0 * skew_norm:
            break
        top = value
    return float(values[0]) if top + skew_norm < 0.0 else None


def _negated(solve: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
    """v ↦ −solve(v): K⁻¹ from a solve of J X = B (J = −K)."""
    return lambda v: -solve(v)


#: The band factorisations of the last pattern assessed (a track's steps share one), and
#: whether they fill their band by the compiled pass.
_LAST_BAND: tuple[object, bool, BandStiffness] | None = None


def _band_of(model: Model) -> BandStiffness | None:
    """The band factorisations of ``model``'s Jacobian pattern, or None when its band is
    too wide for band storage; filled by the compiled pass when ``model`` evaluates with
    its compiled kernels (the same band, bit for bit: tests/test_stability_band.py)."""
    global _LAST_BAND
    band = model.band
    if band.lower + band.upper + 1 > MAX_BAND:
        return None
    compiled = model._compiled()
    if _LAST_BAND is None or _LAST_BAND[0] is not model.pattern or _LAST_BAND[1] != compiled:
        _LAST_BAND = model.pattern, compiled, BandStiffness(
            model.pattern_rows, model.pattern_cols, model.n, band.lower, band.upper, compiled)
    return _LAST_BAND[2]


def assess(model: Model, x: np.ndarray,
           factored: tuple[np.ndarray, Callable[[np.ndarray], np.ndarray] | None] | None
           = None, certify_first: bool = True, modes: NearestModes | None = None
           ) -> Stability:
    """The verdict at the free state ``x`` of ``model`` (a ``rodsim.core.model.Model``),
    from its analytic Jacobian ∂F/∂x at full load: the verdict of
    ``stiffness_stability``, its factorisations in band storage (module docstring).
    ``factored``: (J's CSC data at ``x``, a solve of J X = B or None), when the caller has
    them (the integrators' verification of the same state, rodsim/solvers/base.py). A solve
    whose ``proves_stable`` is True is the band Cholesky factor of −J = K
    (``rodsim.solvers.linear.BandCholeskySolve``): K is then positive definite, the
    verdict stable, and nothing is factored again.

    ``certify_first`` False (a track whose last step's symmetric part was not certified,
    rodsim/app/inverse/track.py): for a non-symmetric K above
    ``DENSE_NONSYMMETRIC_LIMIT`` the eigenvalues nearest zero come first, and the
    Cholesky certificate (~0.17 ms on table3-catheter1, failing at every step of its
    tendon ramp) only when they do not say stable. The same ``stable`` as the default order
    and, for an unstable K, the same ``min_eigenvalue`` (ARPACK's fixed start); a stable
    K's ``min_eigenvalue`` is then its smallest real part where the certificate gives
    NaN.

    ``modes`` (a Tracker's or a track's, one per sequence of steps): the eigenvalues
    nearest zero of a non-symmetric K from the last verdict's eigenvectors
    (rodsim/core/stability_tracking.py); the same verdicts, the smallest real part within
    the coarse pass's tolerance."""
    solve = None if factored is None else factored[1]
    band = model.band
    width = max(band.lower, band.upper)
    banded = _band_of(model)
    tolerance = neutral_tolerance(model.n)
    if getattr(solve, "proves_stable", False):  # −J's band Cholesky: K is positive definite
        assert factored is not None
        if (banded is None or model.n > DENSE_LIMIT
                or banded.certified(factored[0], scaled_shift=-tolerance)):
            return Stability(True)
        return _model_neutral(model, x, -model.pattern_matrix(factored[0]))  # not beyond τ
    data = model.jacobian_data(x) if factored is None else factored[0]
    if banded is None:
        return stiffness_stability(-model.pattern_matrix(data), width)
    nearest = (not certify_first and model.n > DENSE_NONSYMMETRIC_LIMIT
               and banded.asymmetry(data) > 1e-12)
    if not nearest:
        if banded.certified(data):
            if model.n > DENSE_LIMIT or banded.certified(data, scaled_shift=-tolerance):
                return Stability(True)
            return _model_neutral(model, x, -model.pattern_matrix(data))
        if banded.asymmetry(data) <= 1e-12 or model.n <= DENSE_NONSYMMETRIC_LIMIT:
            return stiffness_stability(-model.pattern_matrix(data), width, indefinite=True)
    inverse: Callable[[np.ndarray], np.ndarray] | None
    sign: float | None
    if solve is None:
        lu = banded.inverse(data)
        inverse, sign = lu, None if lu is None else lu.determinant_sign  # of K
    else:
        inverse = _negated(solve)
        sign = getattr(solve, "determinant_sign", None)  # of J = −K: det K = (−1)ⁿ det J
        if sign is not None and model.n % 2:
            sign = -sign
    factors = lu if solve is None else solve  # compiled warm steps on a band LU
    compiled = ((factors, 1.0 if solve is None else -1.0) if modes is not None
                and isinstance(factors, BandLU) and model._compiled() else None)
    real_part = _smallest_real_part(lambda: -model.pattern_matrix(data), inverse, model.n,
                                    coarse=True, modes=modes, band=compiled)
    if real_part > 0.0 and sign is not None and sign < 0.0:
        # det K < 0: an odd number of K's real eigenvalues are negative, though none of
        # those nearest zero is: unstable, the eigenvalue not located.
        return Stability(False, float("nan"))
    if nearest and not real_part > 0.0 and banded.certified(data):
        return Stability(True)
    if real_part > 0.0 and model.n > DENSE_NONSYMMETRIC_LIMIT:
        # The nearest eigenvalues say stable; an eigenvalue further left is possible only if
        # S has one below −ρ (one band Cholesky says whether): then the proof above.
        skew_norm = banded.skew_norm_bound(data)
        if not banded.certified(data, shift=skew_norm):
            left = _proven_left_eigenvalue(-model.pattern_matrix(data), skew_norm)
            if left is not None:
                return Stability(False, left)
    return Stability(bool(real_part > 0.0), real_part)
