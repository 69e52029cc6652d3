"""CVODE's Newton matrix on the explicit form of a large rod's motion, solved in linear
time: the mass-scaled banded matrix factored by band LU as the preconditioner of SUNDIALS'
GMRES (docs/dynamics.md, "CVODE").

The explicit form (rodsim/solvers/physical/ode.py) is ẏ = f(y) with f = S⁻¹ h, where
S = diag(1 on x, M_r on v, I on ω) holds the consistent mass and the inertia and h the
kinematic rates and the forces. Its Jacobian J = S⁻¹ H (H = ∂h/∂y at the state, sparse and
banded in the band order of rodsim/solvers/physical/dae.py) is dense, since M_r⁻¹ couples
every node. The matrix of a BDF step's Newton iteration is I − γ J = S⁻¹ (S − γ H), so

    (I − γ J) z = r   ⟺   (S − γ H) z = S r,

a banded system: S − γ H is the Jacobian of the residual form (IDA's, at c_j = 1/γ, times γ)
with the explicit form's kinematic rows. Factored by LAPACK's band LU (gbtrf) and handed to
SUNDIALS' GMRES as a left preconditioner, with the product J v = S⁻¹ (H v) — one sparse
solve of M_r — taken from the same H, it is the exact inverse of the matrix GMRES works on:
GMRES converges in one iteration, the same modified Newton as a direct solve of I − γ J,
in work linear in the number of nodes (the dense factorisation is cubic).

``linear_solver`` picks the solver by the system's size alone, never by the clock, through
``DENSE_LIMIT``: up to it the dense solve of ode.py, unchanged (a small rod's run is bit for
bit what it was), above it this one. Measured on the steel rod at one period
(benchmarks/results/cvode-scaling-full.md), CPU per step dense/banded: 0.53/0.59 ms at
N = 11, 0.40/0.49 at N = 21 (the dense LU is small; GMRES's set-up and products cost
more), 1.02/0.51 at N = 41, 5.3/0.71 at N = 81, 52.5/0.84 at N = 161.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.linalg import lapack

from rodsim.solvers.failure import SolverFailure

__all__ = ["BandedNewton", "DENSE_LIMIT", "banded_newton_options", "linear_solver"]

#: Unknowns (positions, quaternions, velocities, body rates) up to which CVODE factors its
#: dense Jacobian (ode.py); above, the banded Newton matrix with GMRES. 400: N ≤ 31 nodes on
#: one rod (13 unknowns a free node) is dense (module docstring).
DENSE_LIMIT = 400


def linear_solver(size: int) -> str:
    """``"dense"`` or ``"band_gmres"`` for a system of ``size`` unknowns (module docstring)."""
    return "dense" if size <= DENSE_LIMIT else "band_gmres"


class BandedNewton:
    """S − γ H in band order (module docstring): ``setup`` takes H at a state, ``factor``
    factors S − γ H for CVODE's γ, ``solve`` is the preconditioner solve and ``times`` the
    product J v. ``ode`` is a ``PhysicalOde``; its ``scaled_jacobian`` gives (S, H) in
    natural order."""

    def __init__(self, ode: Any) -> None:
        self.ode = ode
        order = ode.dae.order
        self.order, self.place = order, ode.dae.place
        self.mass = ode.mass_matrix()[order][:, order].tocsr()
        self.h: sp.csr_matrix | None = None
        self.gamma = 0.0
        self._lu: tuple[np.ndarray, np.ndarray, int, int] | None = None
        #: Set-ups (H evaluated) and factorisations so far.
        self.setups = self.factorisations = 0

    def setup(self, t: float, y: np.ndarray) -> None:
        """H at (t, y) (band order)."""
        h = self.ode.scaled_jacobian(t, y[self.place])
        self.h = h[self.order][:, self.order].tocsr()
        self.setups += 1

    def factor(self, gamma: float) -> None:
        """Band LU of S − γ H."""
        assert self.h is not None
        matrix = (self.mass - gamma * self.h).tocoo()
        rows, cols, values = matrix.row, matrix.col, matrix.data
        size = matrix.shape[0]
        lower = int(max(0, np.max(rows - cols)))
        upper = int(max(0, np.max(cols - rows)))
        # LAPACK band storage with room for the pivots' fill: A[i, j] at [kl + ku + i − j, j]
        band = np.zeros((2 * lower + upper + 1, size))
        np.add.at(band, (lower + upper + rows - cols, cols), values)
        lu, pivots, info = lapack.dgbtrf(band, lower, upper, overwrite_ab=True)
        if info != 0:
            raise SolverFailure("the Newton matrix of a step is singular")
        self.gamma = gamma
        self._lu = lu, pivots, lower, upper
        self.factorisations += 1

    def solve(self, rhs: np.ndarray, out: np.ndarray) -> None:
        """out = (I − γ J)⁻¹ rhs = (S − γ H)⁻¹ S rhs."""
        assert self._lu is not None
        lu, pivots, lower, upper = self._lu
        solution, info = lapack.dgbtrs(lu, lower, upper, self.mass @ rhs, pivots)
        assert info == 0
        out[:] = solution

    def times(self, v: np.ndarray, out: np.ndarray) -> None:
        """out = J v = S⁻¹ (H v), H from the last set-up."""
        assert self.h is not None
        out[:] = self.ode.unscale((self.h @ v)[self.place])[self.order]


def banded_newton_options(newton: BandedNewton) -> dict[str, Any]:
    """scikit-sundae's CVODE options that make ``newton`` the left preconditioner of GMRES
    and its product J v the Jacobian's (module docstring); y in band order."""
    from sksundae.cvode import CVODEJacTimes, CVODEPrecond

    def psetup(t: float, y: np.ndarray, fy: np.ndarray, jok: bool, jnew: list[int],
               gamma: float) -> None:
        # H re-evaluated unless CVODE says the last one will do
        if not jok or newton.h is None:
            newton.setup(t, y)
            jnew[0] = 1
        else:
            jnew[0] = 0
        newton.factor(gamma)

    def psolve(t: float, y: np.ndarray, fy: np.ndarray, r: np.ndarray, z: np.ndarray,
               gamma: float, delta: float, lr: int) -> None:
        newton.solve(r, z)

    def jtimes(t: float, y: np.ndarray, fy: np.ndarray, v: np.ndarray,
               jv: np.ndarray) -> None:
        newton.times(v, jv)

    return {"precond": CVODEPrecond(psetup, psolve, side="left"),
            "jactimes": CVODEJacTimes(None, jtimes)}
