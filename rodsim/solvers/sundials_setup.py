"""Setting up a SUNDIALS solver for CVODE and IDA: scikit-sundae solvers started with
rodsim's analytic Jacobian (``started``), the Jacobian written into SUNDIALS' arrays
(``jacobian_writer``), the band-LU preconditioner of GMRES (``BandPreconditioner``),
and SUNDIALS' own failure text captured into rodsim's diagnostics. The run loop is
``rodsim.solvers.sundials``."""

from __future__ import annotations

import contextlib
import io
import warnings
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from rodsim.solvers.failure import SolverFailure

__all__ = ["BandPreconditioner", "jacobian_writer", "started", "StartFailure",
           "captured_sundials_messages"]


class BandPreconditioner:
    """The Newton matrix of a SUNDIALS step, A = A₀ + c A₁ (CVODE: I − γ J, c = γ; IDA:
    ∂R/∂y + c_j ∂R/∂y′), held in its CSC pattern, factored by rodsim's band LU
    (``rodsim.solvers.linear.LinearSolver``, band storage only) and handed to SUNDIALS'
    GMRES as its preconditioner, with the product A v for the Krylov iterations. With the
    factorisation of the very matrix GMRES works on, it converges in one iteration: the same
    modified Newton as a direct band solve, without scikit-sundae's dense (n × n) template.

    ``update`` takes the two parts from the integrator's analytic Jacobian (once per
    SUNDIALS set-up), ``factor`` factors A for the current c, ``solve`` and
    ``product`` are the preconditioner solve and A v."""

    def __init__(self, pattern: Any, rows: np.ndarray, cols: np.ndarray,
                 band: tuple[int, int]) -> None:
        import scipy.sparse as sp

        from rodsim.solvers.linear import LinearSolver

        self._sp = sp
        self.pattern = pattern
        self.linear = LinearSolver(pattern, rows, cols, band, symmetric=False)
        self.parts: tuple[np.ndarray, np.ndarray] | None = None
        self.matrices: tuple[Any, Any] | None = None
        self.c = 0.0
        self._solve: Callable[[np.ndarray], np.ndarray] | None = None
        self._matrix: np.ndarray | None = None

    def update(self, constant: np.ndarray, per_c: np.ndarray) -> None:
        self.parts = constant, per_c
        n = self.pattern.shape[0]
        self.matrices = tuple(self._sp.csc_matrix((data, self.pattern.indices,
                                                   self.pattern.indptr), shape=(n, n))
                              for data in self.parts)

    def factor(self, c: float) -> None:
        assert self.parts is not None
        self.c = c
        # A₀ + c A₁ into the array of the last factorisation's matrix, factored in the band
        # array the solver keeps (LinearSolver.factorized): the last factorisation, which
        # used it, is dropped here. On a large model fresh arrays of this size cost more
        # than the factorisation (docs/benchmark-history.md, "Large N").
        self._solve = None
        constant, per_c = self.parts
        matrix = self._matrix
        if matrix is None or matrix.shape != per_c.shape:
            matrix = np.empty_like(per_c)
        np.multiply(per_c, c, out=matrix)
        matrix += constant
        self._matrix = matrix
        self._solve = self.linear.factorized(matrix, keep=True)
        if self._solve is None:
            raise SolverFailure("the Newton matrix of a step is singular")

    def solve(self, rhs: np.ndarray, out: np.ndarray) -> None:
        assert self._solve is not None
        out[:] = self._solve(rhs)

    def product(self, v: np.ndarray, out: np.ndarray, c: float) -> None:
        assert self.matrices is not None
        out[:] = self.matrices[0] @ v + c * (self.matrices[1] @ v)


def jacobian_writer(solver_kind: str, rows: np.ndarray,
                    cols: np.ndarray) -> Callable[[np.ndarray, np.ndarray], None]:
    """``write(jj, data)``: put Jacobian values given in CSC pattern order into the array
    SUNDIALS hands a ``jacfn`` — for the band solver a full (n, n) array (only the band is
    read), for the sparse solver the CSC data itself."""
    if solver_kind == "band":
        def write(jj: np.ndarray, data: np.ndarray) -> None:
            jj[rows, cols] = data
    else:
        def write(jj: np.ndarray, data: np.ndarray) -> None:
            jj[:] = data
    return write


class StartFailure(SolverFailure):
    """A SUNDIALS solver that could not be set up (``started``); ``detail`` is what
    SUNDIALS said, for a caller that names the place itself (a restart mid-run)."""

    def __init__(self, where: str, detail: str) -> None:
        super().__init__(f"{where}: {detail}")
        self.detail = detail


def started(name: str, solver_class: type, function: Callable[..., None],
            jacfn: Callable[..., None] | None, t: float, *initial: np.ndarray,
            **options: Any) -> Any:
    """A scikit-sundae solver (``CVODE`` or ``IDA``, called ``name`` in diagnostics) with our
    analytic ``jacfn``, initialised at ``t`` from ``initial`` (y, or y and y′). Its warning
    that its own sparse finite-difference Jacobian goes unused is expected and silenced.
    A set-up failure —
    scikit-sundae raises RuntimeError for some (e.g. a failed consistent-initial-condition
    solve, IDACalcIC) and reports others as an unsuccessful ``init_step`` — is a
    ``SolverFailure`` carrying SUNDIALS' own text."""
    where = f"{name} could not start at t = {t:.4g} s"
    with captured_sundials_messages() as printed:
        try:
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", "Custom sparse Jacobian", UserWarning)
                solver = solver_class(function, jacfn=jacfn, **options)
            initialised = solver.init_step(t, *initial)
        except RuntimeError as exc:
            raise StartFailure(where, str(exc)) from None
    if not initialised.success:
        raise StartFailure(where, f"{initialised.message} "
                           + " ".join(printed.getvalue().split()))
    return solver


@contextlib.contextmanager
def captured_sundials_messages() -> Iterator[io.StringIO]:
    """Capture what SUNDIALS reports on a failure: scikit-sundae's error handler prints it
    to stdout, where it would land in the middle of ``rodsim run``'s summary; rodsim puts it
    in its own diagnostic instead."""
    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        yield buffer
