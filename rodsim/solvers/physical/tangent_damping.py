"""The damping on the physical velocities, D_t = Gᵀ D G, as a step's Newton iterations need
it at every iterate (rodsim/solvers/physical/midpoint.py, semi_implicit_euler.py;
docs/dynamics.md, "What a step costs").

D (rodsim/core/damping.py, ``Damping.matrix``) is assembled from the elastic terms' material
stiffness blocks, symmetrised and added to the drag; G (``PhysicalCoordinates.g_matrix``) maps
the physical velocities to the free coordinates. Built with scipy's operators that is a
dozen sparse matrices per iterate, each paying scipy's format checks and index-type
choices, several times the arithmetic at a rod's sizes. ``TangentDamping`` runs the same
compiled kernels of scipy on the same arrays (rodsim/solvers/physical/sparse_kernels.py), in
the same order — the coordinate-to-row conversion, the sort and sum of duplicates, the transposes,
the sums (which drop exact zeros) and the two products — and builds one matrix at the end:
the same arrays, entry for entry and bit for bit, as
``(g.T @ damping.matrix(x) @ g).tocsr()`` (tests/test_tangent_damping.py).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import _sparsetools as kernels

from rodsim.core.damping import Damping
from rodsim.solvers.physical.sparse_kernels import (
    INDEX,
    Csr,
    arrays,
    congruent,
    csr_of,
    plus,
    scaled,
    transpose,
)

__all__ = ["TangentDamping"]


class TangentDamping:
    """D_t = Gᵀ D(x) G of one model's ``Damping`` (module docstring), its entries' places
    found once."""

    def __init__(self, damping: Damping) -> None:
        self.damping = damping
        model = damping.model
        self._n = model.n
        rows, cols = [], []
        for term, _, _ in damping.elastic:
            dofs = term.dofs
            k = dofs.shape[1]
            rows.append(np.repeat(dofs, k, axis=1).ravel())
            cols.append(np.tile(dofs, (1, k)).ravel())
        free_of = np.full(model.full_size, -1)
        free_of[model.free] = np.arange(model.n)
        i = free_of[np.concatenate(rows)] if rows else np.zeros(0, dtype=int)
        j = free_of[np.concatenate(cols)] if cols else np.zeros(0, dtype=int)
        #: The material stiffness entries on free coordinates, and their (row, column).
        self._keep = (i >= 0) & (j >= 0)
        self._rows = i[self._keep].astype(INDEX)
        self._cols = j[self._keep].astype(INDEX)
        self._drag = arrays(damping.drag)

    def _material(self, x: np.ndarray) -> Csr:
        """The CSR arrays of ``Damping.matrix``'s ``_assemble`` (coordinates to rows, the
        duplicates sorted, when not sorted already, and summed)."""
        d = self.damping
        state = x - d.model.reference[d.model.free]  # the model's offsets
        full, offsets = d.model.full(state), d.model.offsets(state)
        values = []
        for term, tau, weights in d.elastic:
            at = offsets if term.offsets else full
            blocks = (term.material_stiffness(at) if weights is None
                      else term.material_stiffness(at, weights))
            values.append(tau * blocks.ravel())
        v = np.concatenate(values)[self._keep]
        n = self._n
        indptr = np.empty(n + 1, dtype=INDEX)
        indices = np.empty(len(v), dtype=INDEX)
        data = np.empty(len(v))
        kernels.coo_tocsr(n, n, len(v), self._rows, self._cols, v, indptr, indices, data)
        if not kernels.csr_has_sorted_indices(n, indptr, indices):
            kernels.csr_sort_indices(n, indptr, indices, data)
        kernels.csr_sum_duplicates(n, n, indptr, indices, data)
        nnz = int(indptr[-1])
        return Csr(indptr, indices[:nnz], data[:nnz])

    def matrix(self, x: np.ndarray, g: Csr, m: int) -> sp.csr_matrix:
        """(gᵀ D(x) g).tocsr() at ``x`` (the free coordinates themselves) for the map G,
        n × ``m``, given by its CSR arrays ``g`` — scipy's arrays, bit for bit (module
        docstring)."""
        n = self._n
        if self.damping.elastic:
            material = self._material(x)
            both = plus(n, n, material, transpose(n, n, material))
            d = plus(n, n, scaled(both, 0.5), self._drag)
        else:
            d = self._drag
        # the CSC arrays of gᵀ D g; their transpose is its ``tocsr``
        both = congruent(n, m, g, transpose(n, n, d), g)
        return csr_of(transpose(m, m, both), (m, m), sorted_indices=True)
