"""scipy's sparse operations on CSR arrays by its own compiled kernels
(``scipy.sparse._sparsetools``), for the physical-time steps' Newton iterations
(docs/dynamics.md, "What a step costs").

At a rod's sizes a scipy operator (a product, a sum, a transpose) costs several times its
arithmetic in format checks and index-type choices, and a step's iteration chains a dozen
of them. These functions run the kernel each operator runs, on the arrays it would hand
it, so a chain of them gives scipy's own arrays entry for entry and bit for bit: the same
products summed in the same order, the same exact zeros dropped, the same storage order
(tests/test_tangent_damping.py, tests/test_physical_assembly.py). A matrix is its arrays
``Csr`` (indptr, indices, data); a CSC matrix is the CSR arrays of its transpose, as
scipy itself reads it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse import _sparsetools as kernels

__all__ = ["INDEX", "Csr", "arrays", "transpose", "plus", "minus", "product", "scaled",
           "congruent", "csr_of", "matvec"]

#: The index type of every array handed to the kernels (scipy's own at these sizes).
INDEX = np.int32
#: y += A x for a CSR A: ``matvec(rows, cols, indptr, indices, data, x, y)``, the kernel of
#: scipy's ``A @ x`` (which hands it y = zeros).
matvec = kernels.csr_matvec


class Csr(NamedTuple):
    """A sparse matrix's CSR arrays: row pointers, column indices, values."""

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray


def arrays(matrix: sp.csr_matrix | sp.csc_matrix | Csr) -> Csr:
    """The stored arrays of ``matrix`` (of its transpose, read as CSR, for a CSC one), their
    indices as ``INDEX``."""
    return Csr(matrix.indptr.astype(INDEX, copy=False),
               matrix.indices.astype(INDEX, copy=False), matrix.data)


def transpose(rows: int, cols: int, a: Csr) -> Csr:
    """aᵀ of a ``rows`` × ``cols`` a (``csr_tocsc``: scipy's ``tocsc`` and a CSC matrix's
    ``tocsr``)."""
    indptr = np.empty(cols + 1, dtype=INDEX)
    indices = np.empty(len(a.indices), dtype=INDEX)
    data = np.empty(len(a.data))
    kernels.csr_tocsc(rows, cols, a.indptr, a.indices, a.data, indptr, indices, data)
    return Csr(indptr, indices, data)


def _binary(kernel: Callable[..., None], rows: int, cols: int, a: Csr, b: Csr) -> Csr:
    """A binary operation's kernel (``csr_plus_csr``, ``csr_minus_csr``) on a and b."""
    size = len(a.indices) + len(b.indices)
    indptr = np.empty(rows + 1, dtype=INDEX)
    indices = np.empty(size, dtype=INDEX)
    data = np.empty(size)
    kernel(rows, cols, a.indptr, a.indices, a.data, b.indptr, b.indices, b.data, indptr,
           indices, data)
    nnz = int(indptr[-1])
    return Csr(indptr, indices[:nnz], data[:nnz])


def plus(rows: int, cols: int, a: Csr, b: Csr) -> Csr:
    """a + b (``csr_plus_csr``, exact zeros dropped: scipy's sum)."""
    return _binary(kernels.csr_plus_csr, rows, cols, a, b)


def minus(rows: int, cols: int, a: Csr, b: Csr) -> Csr:
    """a − b (``csr_minus_csr``, exact zeros dropped: scipy's difference)."""
    return _binary(kernels.csr_minus_csr, rows, cols, a, b)


def product(rows: int, cols: int, a: Csr, b: Csr) -> Csr:
    """a @ b for a with ``rows`` rows and b with ``cols`` columns (``csr_matmat``, exact
    zeros dropped: scipy's product)."""
    size = kernels.csr_matmat_maxnnz(rows, cols, a.indptr, a.indices, b.indptr, b.indices)
    indptr = np.empty(rows + 1, dtype=INDEX)
    indices = np.empty(size, dtype=INDEX)
    data = np.empty(size)
    kernels.csr_matmat(rows, cols, a.indptr, a.indices, a.data, b.indptr, b.indices, b.data,
                       indptr, indices, data)
    nnz = int(indptr[-1])
    return Csr(indptr, indices[:nnz], data[:nnz])


def scaled(a: Csr, factor: float) -> Csr:
    """factor × a (scipy's product with a scalar: the values times it)."""
    return Csr(a.indptr, a.indices, a.data * factor)


def csr_of(a: Csr, shape: tuple[int, int], sorted_indices: bool = False) -> sp.csr_matrix:
    """The scipy CSR matrix of the arrays ``a``; ``sorted_indices``: say so, as scipy's
    ``tocsr`` of a CSC matrix does."""
    out = sp.csr_matrix((a.data, a.indices, a.indptr), shape=shape)
    if sorted_indices:
        out.has_sorted_indices = True
    return out


def congruent(n: int, m: int, left: Csr, middle: Csr, right: Csr) -> Csr:
    """``left.T @ M @ right`` for n × m CSR ``left`` and ``right`` (their arrays) and n × n M
    given by ``middle``, the CSR arrays of Mᵀ (a CSC M's own arrays), as scipy takes the
    two products: the result's CSC arrays (m × m)."""
    # leftᵀ is left's arrays read by columns: the CSC arrays of leftᵀ M are the CSR arrays
    # of Mᵀ left, and the product with ``right`` (converted to CSC) likewise
    first = product(n, m, arrays(middle), arrays(left))
    return product(m, m, transpose(n, m, arrays(right)), first)
