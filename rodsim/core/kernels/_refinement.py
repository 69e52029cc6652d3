"""Compiled residual of a linear system in twice the working precision, for the iterative
refinement of the large models' Newton solves (:class:`rodsim.solvers.linear.LinearSolver`).

r = b − A x for a CSC matrix A: every product a·x is split exactly into its rounded value and
its rounding error (Dekker's TwoProduct, with Veltkamp's splitting: no fused multiply-add
needed), and each row's sum is carried as an unevaluated pair (value, error) by Knuth's
TwoSum. The result is r rounded once to double, as accurate as if it had been computed in
about 106-bit arithmetic and rounded (Ogita, Rump & Oishi, "Accurate sum and dot product",
SIAM J. Sci. Comput. 26, 2005: the compensated dot product Dot2). A plain double residual
carries an error of eps·|A|·|x|, as large as r itself once A's condition number reaches
1/eps over the size of the correction: refinement with it does not converge.
Standalone: no other kernel calls it."""

from __future__ import annotations

import numpy as np
from numba import njit

#: Veltkamp's splitting constant for doubles: 2^27 + 1.
SPLITTER = 134217729.0


@njit(cache=True)
def compensated_residual(data: np.ndarray, indptr: np.ndarray, indices: np.ndarray,
                         x: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """Write b − A x into ``out``, A the CSC matrix (``data``, ``indices``, ``indptr``),
    computed with compensated products and sums (the module's docstring). ``out`` may not
    be ``x`` or ``b``."""
    n = x.shape[0]
    error = np.zeros(out.shape[0])
    for i in range(out.shape[0]):
        out[i] = b[i]
    for j in range(n):
        xj = -x[j]
        c = SPLITTER * xj
        x_high = c - (c - xj)
        x_low = xj - x_high
        for k in range(indptr[j], indptr[j + 1]):
            a = data[k]
            i = indices[k]
            product = a * xj                                 # TwoProduct(a, −x_j)
            c = SPLITTER * a
            a_high = c - (c - a)
            a_low = a - a_high
            product_error = (((a_high * x_high - product) + a_high * x_low)
                             + a_low * x_high) + a_low * x_low
            total = out[i] + product                         # TwoSum(out_i, product)
            back = total - out[i]
            sum_error = (out[i] - (total - back)) + (product - back)
            out[i] = total
            error[i] += sum_error + product_error
    for i in range(out.shape[0]):
        out[i] += error[i]
