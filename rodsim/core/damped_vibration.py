"""Damped modes about an equilibrium: the quadratic eigenproblem (λ² M + λ D + K) φ = 0.

Small motions x = x* + φ e^{λt} of M ẍ + D ẋ + K x = 0 (paper Eqs. 10–13 with the physical
masses of rodsim/core/inertia.py and the damping of rodsim/core/damping.py: Kelvin–Voigt
D = τ K_el and a drag c per unit length) about an equilibrium x*. Each lightly damped mode
gives a conjugate pair λ = ω_n (−ζ ± i √(1 − ζ²)): its damped angular frequency Im λ, its
decay rate −Re λ, its undamped frequency |λ| and its damping ratio ζ = −Re λ / |λ|.
Without damping λ = ± i ω with the ω of K φ = ω² M φ (rodsim/core/vibration.py).

M = L Lᵀ is singular (each quaternion's norm has no mass; every quaternion without rotary
inertia), so the problem is posed in its flexibility form with μ = 1/λ, as the undamped one
(rodsim/core/vibration.py): dividing by λ² and applying K⁻¹,

    μ² x + μ K⁻¹ D x + K⁻¹ M x = 0,

linearised with w = μ x into the standard eigenproblem of size 2n

    μ (x, w) = A (x, w),   A = [[0, I], [−K⁻¹ M, −K⁻¹ D]].

A massless, undamped direction (a quaternion's norm) gives μ = 0 (λ infinite: it follows
the others quasi-statically, as in the undamped condensation); a massless, damped one (the
rotations without rotary inertia) a real μ, a relaxation. The slowest motions are A's
eigenvalues of largest |μ|: ARPACK (``eigs``, one solve with K per product, from a fixed
seeded start) or, for n ≤ ``DENSE_SIZE`` (≤ ``DENSE_FALLBACK`` where ARPACK does
not converge), a dense eigensolve. Each conjugate pair is kept once (Im λ > 0) and each
real root once; the roots are ordered by |λ|.

A real root is a motion that does not oscillate: an overdamped mode's pair of real roots
(Kelvin–Voigt damps the n-th mode with ζ_n = τ ω_n / 2, so from some mode on), or a
relaxation; its damping ratio −Re λ / |λ| is 1 and its damped frequency 0. The roots of
Kelvin–Voigt's overdamped modes gather near λ = −1/τ.

Each root keeps its complex mode shape φ, the x part of A's eigenvector (x, w = μ x):
(λ² M + λ D + K) φ = 0. ``rodsim.app.modes`` matches them to the undamped modes by the
modal assurance criterion (the mass-weighted MAC). For a damping proportional to K (one
Kelvin–Voigt τ) or to M, φ is the undamped mode up to a complex factor.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from rodsim.core.stability_band import BandStiffness
from rodsim.core.vibration import ARPACK_SEED, ModesError, check_count, stiffness_solver

__all__ = ["DampedVibration", "damped_modes", "DENSE_SIZE", "REAL_TOLERANCE"]

#: Largest number of free coordinates solved densely first (the linearised problem is twice
#: that).
DENSE_SIZE = 150
#: Largest number solved densely when ARPACK does not converge (Kelvin–Voigt's cluster of
#: real roots near −1/τ); beyond, the roots ARPACK did converge, the others NaN.
DENSE_FALLBACK = 400
#: Smallest Arnoldi basis ARPACK builds.
MIN_BASIS = 40
#: ARPACK's restarts before it stops with the roots it has converged (the others NaN).
MAX_RESTARTS = 300
#: A root with |Im λ| at most this times |λ| counts as real (no oscillation).
REAL_TOLERANCE = 1e-10


@dataclass(frozen=True)
class DampedVibration:
    """The ``count`` roots λ of lowest |λ| of (λ² M + λ D + K) φ = 0, one of each conjugate
    pair (Im λ > 0) and each real root.

    Attributes
    ----------
    eigenvalues
        λ [1/s], shape (count,), by |λ| (NaN where fewer roots were found).
    roots
        Every root found (one of each pair, each real root), by |λ|: the ``count`` first
        are ``eigenvalues``; the others are candidates for matching the undamped modes.
    vectors
        The complex mode shape φ of each of ``roots`` on the free coordinates, shape
        (len(roots), n): the x part of A's eigenvector (x, μ x), unnormalised.
    """

    eigenvalues: np.ndarray
    roots: np.ndarray
    vectors: np.ndarray

    @property
    def damped_frequencies(self) -> np.ndarray:
        """Im λ / 2π [Hz]: 0 for a real root."""
        return np.asarray(self.eigenvalues.imag / (2.0 * np.pi))

    @property
    def damping_ratios(self) -> np.ndarray:
        """ζ = −Re λ / |λ|: the mode's damping ratio for an oscillating root; 1 for a
        decaying real root."""
        return np.asarray(-self.eigenvalues.real / np.abs(self.eigenvalues))

    @property
    def undamped_frequencies(self) -> np.ndarray:
        """|λ| / 2π [Hz], the ω_n of an oscillating root."""
        return np.asarray(np.abs(self.eigenvalues) / (2.0 * np.pi))


def damped_modes(stiffness: sp.spmatrix, factor: sp.spmatrix, damping: sp.spmatrix,
                 count: int, *, band: BandStiffness | None = None,
                 jacobian: np.ndarray | None = None) -> DampedVibration:
    """The ``count`` roots of lowest |λ| of (λ² L Lᵀ + λ D + K) φ = 0 (module docstring).

    ``stiffness``: K (n × n, sparse); ``factor``: L (n × m), M = L Lᵀ; ``damping``: D
    (n × n, sparse); ``band`` and ``jacobian``: K factored in band storage, as for
    ``rodsim.core.vibration.natural_modes``. ModesError for a count outside 1..m or a
    singular K.
    """
    stiffness = sp.csc_matrix(stiffness)
    factor = sp.csr_matrix(factor)
    damping = sp.csr_matrix(damping)
    n, m = factor.shape
    check_count(count, m)
    if not (np.all(np.isfinite(stiffness.data)) and np.all(np.isfinite(damping.data))):
        raise ModesError("the stiffness or the damping is not finite at this equilibrium")
    solve = stiffness_solver(stiffness, jacobian, band)
    mass = (factor @ factor.T).tocsr()
    found = None if n <= DENSE_SIZE else _arpack(mass, damping, solve,
                                                  min(2 * count + 2, 2 * n - 2))
    if found is None or (found[0].size < min(2 * count + 2, 2 * n - 2)
                         and n <= DENSE_FALLBACK):
        found = _dense(mass, damping, solve)
    mu, z = found
    finite = mu != 0.0
    roots, shapes = 1.0 / mu[finite], z[:n, finite].T
    keep = roots.imag > REAL_TOLERANCE * np.abs(roots)
    real = np.abs(roots.imag) <= REAL_TOLERANCE * np.abs(roots)
    every = np.concatenate([roots[keep], roots[real].real.astype(complex)])
    vectors = np.concatenate([shapes[keep], shapes[real]]).astype(complex)
    order = np.argsort(np.abs(every), kind="stable")
    every, vectors = every[order], vectors[order]
    chosen = every[:count]
    if len(chosen) < count:
        chosen = np.concatenate([chosen, np.full(count - len(chosen), np.nan + 0j)])
    return DampedVibration(chosen, every, vectors.reshape(len(every), n))


Solve = Callable[[np.ndarray], np.ndarray]


def _dense(mass: sp.csr_matrix, damping: sp.csr_matrix, solve: Solve
           ) -> tuple[np.ndarray, np.ndarray]:
    """Every eigenpair (μ, z) of A, dense (``solve``: v ↦ K⁻¹ v on an (n, k) block)."""
    n = mass.shape[0]
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -solve(mass.toarray())
    a[n:, n:] = -solve(damping.toarray())
    mu, z = la.eig(a)
    return np.asarray(mu), np.asarray(z)


def _arpack(mass: sp.csr_matrix, damping: sp.csr_matrix, solve: Solve, k: int
            ) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` eigenpairs (μ, z) of A of largest magnitude, by ARPACK from a fixed
    start."""
    n = mass.shape[0]

    def apply(z: np.ndarray) -> np.ndarray:
        z = np.asarray(z, dtype=float).ravel()
        x, w = z[:n], z[n:]
        return np.concatenate([w, -solve(mass @ x + damping @ w)])

    operator = spla.LinearOperator((2 * n, 2 * n), matvec=apply, dtype=float)
    start = np.random.default_rng(ARPACK_SEED).standard_normal(2 * n)
    try:
        mu, z = spla.eigs(operator, k=k, which="LM", v0=start, maxiter=MAX_RESTARTS,
                          ncv=min(2 * n - 1, max(2 * k + 1, MIN_BASIS)))
    except spla.ArpackNoConvergence as exc:  # a cluster (Kelvin–Voigt's near −1/τ): partial
        return np.asarray(exc.eigenvalues), np.asarray(exc.eigenvectors)
    return np.asarray(mu), np.asarray(z)
