"""Natural frequencies and mode shapes about an equilibrium: K φ = ω² M φ.

Small motions x = x* + φ e^{iωt} about an equilibrium x* of the equations of motion
M ẍ = F(x) (Eqs. 10–13 with the physical masses of rodsim/core/inertia.py) obey
K φ = ω² M φ with the stiffness K = −∂F/∂x on the free coordinates (the model's analytic
Jacobian; rodsim/core/stability.py uses the same K for the stability verdict).

M is singular: each quaternion's norm direction has no mass (it is held by the centerline
penalty, a stiffness), and so is every quaternion when rotary inertia is left out. Such
directions follow the others quasi-statically; they are condensed out exactly by working
with the factor M = L Lᵀ (L: n × m, m the physical degrees of freedom). With ψ = Lᵀ φ the
problem becomes the standard one

    C ψ = μ ψ,   C = Lᵀ K⁻¹ L (m × m),   μ = 1/ω²,

and φ = ω² K⁻¹ L ψ. C is symmetric when K is (a conservative scene: Lanczos, ARPACK's
``eigsh``) and positive definite at a stable equilibrium; the lowest frequencies are C's
largest eigenvalues, well separated for a rod (ω_n² grows like n⁴), so no shift is needed
beyond the one factorisation of K that C applies. A non-conservative coupling (the paper's
lumen coupling, erratum 13) makes K non-symmetric: then ARPACK's ``eigs``, and ω² may be
complex (``eigenvalues``; a growing or decaying oscillation). K⁻¹ comes from a band LU in
band storage (rodsim/core/stability_band.py) or, for a wider band, SuperLU.

ARPACK starts from a fixed pseudo-random vector (``ARPACK_SEED``): the same model and
state give the same modes, bit for bit. Small systems (m ≤ ``DENSE_SIZE``) are solved
densely. Each mode is scaled to unit modal mass (φᴴ M φ = 1) and its sign (phase) fixed so
that its largest component is real and positive.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from rodsim.core.stability_band import BandStiffness

__all__ = ["Vibration", "natural_modes", "stiffness_solver", "check_count", "ModesError",
           "ARPACK_SEED", "DENSE_SIZE"]

#: Seed of ARPACK's start vector (reproducible modes).
ARPACK_SEED = 33
#: Largest number of physical degrees of freedom solved densely.
DENSE_SIZE = 150
#: Widest band (lower + upper + 1) factored in band storage; wider: SuperLU.
MAX_BAND = 256
#: K − Kᵀ below this, relative to max |K|, counts as symmetric.
SYMMETRY_TOLERANCE = 1e-12


class ModesError(ValueError):
    """The eigenproblem cannot be posed or solved (one line: what and why)."""


@dataclass(frozen=True)
class Vibration:
    """The ``count`` lowest modes of K φ = ω² M φ.

    Attributes
    ----------
    eigenvalues
        ω² of each mode [rad²/s²], ascending by real part; complex only when K is not
        symmetric (otherwise real, imaginary parts exactly zero).
    vectors
        The modes on the free coordinates, shape (count, n), unit modal mass; complex
        when K is not symmetric.
    symmetric
        Whether K was symmetric (a conservative scene).
    """

    eigenvalues: np.ndarray
    vectors: np.ndarray
    symmetric: bool

    @property
    def angular_frequencies(self) -> np.ndarray:
        """ω = √(ω²) [rad/s] (principal root; imaginary for ω² < 0: divergence)."""
        return np.sqrt(self.eigenvalues.astype(complex))


def stiffness_solver(stiffness: sp.csc_matrix, jacobian: np.ndarray | None,
                     band: BandStiffness | None) -> Callable[[np.ndarray], np.ndarray]:
    """v ↦ K⁻¹ v, by band LU when ``band`` is given (``jacobian``: J's CSC data, K = −J),
    else SuperLU; ModesError when K is singular."""
    if band is not None and jacobian is not None:
        lu = band.inverse(jacobian)
        if lu is None:
            raise ModesError("the stiffness K = -dF/dx is singular at this equilibrium (a "
                             "free motion without stiffness: an unheld rod, or a mechanism)")
        return lu
    try:
        return spla.splu(stiffness).solve
    except RuntimeError:
        raise ModesError("the stiffness K = -dF/dx is singular at this equilibrium (a free "
                         "motion without stiffness: an unheld rod, or a mechanism)") from None


def check_count(count: int, degrees: int) -> None:
    """ModesError, one line, for a number of modes outside 1..``degrees`` (the system's
    physical degrees of freedom)."""
    if not 1 <= count <= degrees:
        raise ModesError(f"count = {count}: allowed 1 to {degrees}, the system's physical "
                         "degrees of freedom")


def natural_modes(stiffness: sp.spmatrix, factor: sp.spmatrix, count: int, *,
                  band: BandStiffness | None = None,
                  jacobian: np.ndarray | None = None) -> Vibration:
    """The ``count`` modes of lowest ω² (by real part) of K φ = ω² L Lᵀ φ (module docstring).

    ``stiffness``: K (n × n, sparse); ``factor``: L (n × m); ``band`` and ``jacobian`` (the
    model's ``rodsim.core.stability_band.BandStiffness`` and J's CSC data, K = −J):
    K is then factored in band storage. ModesError for a count outside 1..m or a singular K.
    """
    stiffness = sp.csc_matrix(stiffness)
    factor = sp.csr_matrix(factor)
    n, m = factor.shape
    check_count(count, m)
    if not np.all(np.isfinite(stiffness.data)):
        raise ModesError("the stiffness K = -dF/dx is not finite at this equilibrium")
    largest = float(abs(stiffness).max()) if stiffness.nnz else 0.0
    symmetric = bool(abs(stiffness - stiffness.T).max() <= SYMMETRY_TOLERANCE * largest)
    solve = stiffness_solver(stiffness, jacobian, band)
    if m <= DENSE_SIZE or count >= m - 1:
        mu, psi = _dense(factor, solve, symmetric)
    else:
        mu, psi = _arpack(factor, solve, symmetric, count)
    # μ = 0 (a direction K⁻¹ does not reach through the masses) is an infinite ω²: last.
    inverse_mu = np.divide(1.0, mu, out=np.full(mu.shape, np.inf, dtype=complex),
                           where=mu != 0.0)
    order = np.lexsort((inverse_mu.imag, inverse_mu.real))[:count]
    if not np.all(np.isfinite(inverse_mu[order])):
        raise ModesError(f"count = {count}: fewer modes have a finite frequency")
    values, psi = inverse_mu[order], psi[:, order]
    solved = solve(np.asarray(factor @ psi.real)) + (
        1j * solve(np.asarray(factor @ psi.imag)) if np.iscomplexobj(psi) else 0.0)
    modes = (solved * values[None, :]).T  # φ = ω² K⁻¹ L ψ, unit modal mass
    eigenvalues: np.ndarray = values.real if symmetric else values
    vectors: np.ndarray = modes.real if symmetric else modes
    for k in range(len(vectors)):  # the sign (or phase): largest component real, positive
        big = vectors[k, np.argmax(np.abs(vectors[k]))]
        vectors[k] *= np.conj(big) / abs(big) if big != 0 else 1.0
    return Vibration(eigenvalues, vectors, symmetric)


def _dense(factor: sp.csr_matrix, solve: Callable[[np.ndarray], np.ndarray],
           symmetric: bool) -> tuple[np.ndarray, np.ndarray]:
    """All eigenpairs of C = Lᵀ K⁻¹ L, dense."""
    dense = factor.toarray()
    c = dense.T @ solve(dense)
    if symmetric:
        c = 0.5 * (c + c.T)
        mu, psi = la.eigh(c)
        return mu.astype(complex), psi
    mu, psi = la.eig(c)
    return mu, psi / np.linalg.norm(psi, axis=0)


def _arpack(factor: sp.csr_matrix, solve: Callable[[np.ndarray], np.ndarray],
            symmetric: bool, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` eigenpairs of C = Lᵀ K⁻¹ L of largest magnitude, by ARPACK from a fixed
    start vector."""
    m = factor.shape[1]
    transposed = factor.T.tocsr()

    def apply(v: np.ndarray) -> np.ndarray:
        return transposed @ solve(factor @ np.asarray(v, dtype=float).ravel())

    operator = spla.LinearOperator((m, m), matvec=apply, dtype=float)
    start = np.random.default_rng(ARPACK_SEED).standard_normal(m)
    try:
        if symmetric:
            mu, psi = spla.eigsh(operator, k=count, which="LM", v0=start, maxiter=50 * m)
            return mu.astype(complex), psi
        mu, psi = spla.eigs(operator, k=count, which="LM", v0=start, maxiter=50 * m)
    except spla.ArpackNoConvergence as exc:
        raise ModesError(f"ARPACK did not converge on the {count} lowest modes ({exc}); ask "
                         "for fewer modes") from None
    return mu, psi / np.linalg.norm(psi, axis=0)
