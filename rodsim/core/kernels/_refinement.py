"""Compiled residual of a linear system in twice the working precision, for the iterative
refinement of the large models' Newton solves (``rodsim.solvers.linear.LinearSolver``).

r = b − A x for a CSC matrix A: every product a·x is split exactly into its rounded value and
its rounding error (TwoProduct: the error is fma(a, x, −a·x), exact; LLVM's fused
multiply-add, one instruction on a CPU that has it and a correctly rounded library call on
one that does not), and each row's sum is carried as an unevaluated pair (value, error) by Knuth's
TwoSum. The result is r rounded once to double, as accurate as if it had been computed in
about 106-bit arithmetic and rounded (Ogita, Rump & Oishi, "Accurate sum and dot product",
SIAM J. Sci. Comput. 26, 2005: the compensated dot product Dot2). A plain double residual
carries an error of eps·|A|·|x|, as large as r itself once A's condition number reaches
1/eps over the size of the correction: refinement with it does not converge.
Standalone: no other kernel calls it."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import numpy as np
from llvmlite import ir
from numba import njit
from numba.core import cgutils, types
from numba.extending import intrinsic


def _fused_multiply_add_typing(typing_context: Any, a: Any, b: Any, c: Any
                               ) -> tuple[Any, Callable[..., Any]]:
    """numba's typing and code of ``_fused_multiply_add``: LLVM's ``llvm.fma.f64``."""
    signature = types.float64(types.float64, types.float64, types.float64)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        double = ir.DoubleType()
        function = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(double, [double] * 3), "llvm.fma.f64")
        return builder.call(function, args)
    return signature, codegen


#: a·b + c rounded once, callable from compiled code.
_fused_multiply_add = cast(Callable[[float, float, float], float],
                           intrinsic(_fused_multiply_add_typing))


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
        for k in range(indptr[j], indptr[j + 1]):
            a = data[k]
            i = indices[k]
            product = a * xj                                 # TwoProduct(a, −x_j)
            product_error = _fused_multiply_add(a, xj, -product)
            total = out[i] + product                         # TwoSum(out_i, product)
            back = total - out[i]
            sum_error = (out[i] - (total - back)) + (product - back)
            out[i] = total
            error[i] += sum_error + product_error
    for i in range(out.shape[0]):
        out[i] += error[i]
