"""Compiled Arnoldi steps on K⁻¹ through a band LU (the stability verdict along a sequence
of steps, rodsim/core/stability_tracking.py): each step one back-solve with LAPACK's band
LU factors (dgbtrf's ``lu`` and ``pivots``, 0-based as scipy returns them) in dgbtrs's
order of operations, then classical Gram–Schmidt with one reorthogonalisation where the
vector lost more than 1 − 1/√2 of its length (ARPACK's criterion). The numpy steps of
rodsim/core/stability_tracking.py (``_numpy_steps``) are the reference
(tests/test_stability_tracking.py). Standalone: no other kernel calls them."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def band_lu_solve(lu: np.ndarray, pivots: np.ndarray, lower: int, upper: int,
                  b: np.ndarray) -> None:
    """Overwrite ``b`` with A⁻¹ b, A = P L U factored by dgbtrf (``lu``: (2 lower + upper
    + 1) × n, the diagonal of U in row lower + upper): dgbtrs's forward pass (the row
    interchanges and L's multipliers, column by column) and dtbsv's backward one."""
    n = b.shape[0]
    diagonal = lower + upper
    if lower > 0:
        for j in range(n - 1):
            count = min(lower, n - 1 - j)
            swap = pivots[j]
            if swap != j:
                b[swap], b[j] = b[j], b[swap]
            value = b[j]
            column = lu[diagonal + 1:diagonal + 1 + count, j]
            target = b[j + 1:j + 1 + count]
            for i in range(count):
                target[i] -= column[i] * value
    for j in range(n - 1, -1, -1):
        if b[j] != 0.0:
            b[j] /= lu[diagonal, j]
            value = b[j]
            top = max(0, j - diagonal)  # each b[i] takes one update from column j: any order
            column = lu[diagonal + top - j:diagonal, j]
            target = b[top:j]
            for i in range(j - top):
                target[i] -= value * column[i]


@njit(cache=True)
def _project_out(basis: np.ndarray, count: int, w: np.ndarray, dots: np.ndarray) -> None:
    """One classical Gram–Schmidt pass: ``dots[i]`` = basis[i] · w for the first ``count``
    rows, then w −= Σ dots[i] basis[i]."""
    n = basis.shape[1]
    for i in range(count):
        total = 0.0
        for k in range(n):
            total += basis[i, k] * w[k]
        dots[i] = total
    for i in range(count):
        for k in range(n):
            w[k] -= dots[i] * basis[i, k]


@njit(cache=True)
def arnoldi_steps(lu: np.ndarray, pivots: np.ndarray, lower: int, upper: int, sign: float,
                  basis: np.ndarray, hessenberg: np.ndarray, first: int, last: int) -> int:
    """Extend the Arnoldi factorisation of ``sign`` · A⁻¹ (rows of ``basis``: the
    orthonormal Krylov vectors; ``hessenberg``: its matrix) from dimension ``first`` to
    ``last``. Returns the dimension reached: ``last``, or less where a vector vanished or
    was not finite (the factorisation holds up to the value returned)."""
    n = basis.shape[1]
    w = np.empty(n)
    h = np.empty(last + 1)
    for j in range(first, last):
        for k in range(n):
            w[k] = basis[j, k]
        band_lu_solve(lu, pivots, lower, upper, w)
        before = 0.0
        for k in range(n):
            w[k] *= sign
            before += w[k] * w[k]
        _project_out(basis, j + 1, w, h)
        beta2 = 0.0
        for k in range(n):
            beta2 += w[k] * w[k]
        if beta2 < 0.5 * before:
            again = np.empty(j + 1)
            _project_out(basis, j + 1, w, again)
            for i in range(j + 1):
                h[i] += again[i]
            beta2 = 0.0
            for k in range(n):
                beta2 += w[k] * w[k]
        beta = np.sqrt(beta2)
        if not (beta > 0.0 and beta < np.inf):
            return j
        for i in range(j + 1):
            hessenberg[i, j] = h[i]
        hessenberg[j + 1, j] = beta
        for k in range(n):
            basis[j + 1, k] = w[k] / beta
    return last
