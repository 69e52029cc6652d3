"""Physical damping of the rods in physical time: Kelvin–Voigt material damping and a linear
viscous drag (issue 33, item 1; docs/dynamics.md).

This is the damping of the catheter itself, for ``rodsim.simulate``. It is kept apart from
the pseudo-dynamics' damping (rodsim/solvers/pseudo_dynamics.py, the integrators' way to an
equilibrium), which is chosen for speed, not physics.

A rod's ``[rods.<rod>.damping]`` table holds

- ``retardation_time`` τ [s]: Kelvin–Voigt material damping. Each strain's stress gets a
  viscous part η ε̇ with η = τ × that strain's stiffness (stretch E_s A, bending E I,
  twist G J; not the centerline penalty's shear, a constraint: docs/dynamics.md). Summed
  over the rod's elastic terms (``stretch``, ``bend_twist``: paper Eqs. 6–8), the damping
  force is f_D = −τ K_mat(x) ẋ with K_mat = Σ_e (∂ε_e/∂x)ᵀ C_e (∂ε_e/∂x) the material part of the
  elastic terms' stiffness at the state (``rodsim.core.terms.base.Term.
  material_stiffness``): a viscous stress τ C ε̇ on each strain. The n-th mode of a uniform
  rod then decays with the damping ratio ζ_n = τ ω_n / 2 (tests/test_simulate.py measures
  it).
- ``retardation_time_stretch``, ``_shear``, ``_bending``, ``_twist`` [s]: a retardation
  time per strain kind instead (each term's ``strain_kinds``): η_k = τ_k × that strain's
  stiffness, D = Σ_k τ_k K_mat,k(x) with K_mat,k the material stiffness of kind k alone
  (``Term.material_stiffness`` with weights). An omitted one follows ``retardation_time``;
  shear (the centerline penalty of Eq. 9, K_P l (∂w/∂x)ᵀ(∂w/∂x) for its mismatch w) is
  0 unless given, as without these keys. A mode made of one strain kind then decays with
  ζ = τ_k ω / 2 (tests/test_strain_damping.py).
- ``drag`` c [N·s/m²]: a force −c ṙ(s) per unit length on the centerline (a catheter in a
  still fluid), distributed with the centerline's hat functions: f_D = −c C ṙ with
  C_ij = ∫ N_i N_j ds (l (1/3, 1/6, 1/3) per segment, the consistent mass with ρA = 1).

K_mat is positive semi-definite at every state: it holds the strain rates' stiffness only,
not the geometric part of the elastic Jacobian (the stress times the strains' second
derivatives), which at a stressed state would make a viscosity feed energy in (an earlier
version clipped each element block's negative eigenvalues instead: the positive geometric
part left in made the damping grow with the amplitude, ζ₁ +1.5 % from a 0.1 N release of
the steel rod and +7.5 % from 0.5 N). The dissipated power ẋᵀ D ẋ ≥ 0 is accumulated and
reported by the integrator (rodsim/solvers/physical/trajectory.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp

from rodsim.core.damping_options import DampingOptions

if TYPE_CHECKING:
    from rodsim.core.model import Model

__all__ = ["rod_damping", "Damping"]

def rod_damping(model: Model, rod: str) -> DampingOptions:
    """The damping of rod ``rod`` of ``model``'s scene (zeros without a table)."""
    table = model.scene.data["rods"][rod].get("damping")
    return DampingOptions.of(table) if table else DampingOptions()


class Damping:
    """The damping matrix D(x) (free coordinates) of a model's rods: f_D = −D(x) ẋ."""

    def __init__(self, model: Model) -> None:
        self.model = model
        free_of = np.full(model.full_size, -1)
        free_of[model.free] = np.arange(model.n)
        self._free_of = free_of
        #: (term, τ, weights) of every rod term with a material strain whose τ is > 0:
        #: one τ for all its strain kinds (weights None), or τ = 1 and each kind's own
        #: retardation time as the weights (``Term.material_stiffness``).
        self.elastic: list[tuple[Any, float, np.ndarray | None]] = []
        rows: list[np.ndarray] = []
        cols: list[np.ndarray] = []
        values: list[np.ndarray] = []
        for (owner, name, _), term in zip(model.term_keys, model.terms, strict=True):
            if owner != "rods" or not term.strain_kinds:
                continue
            options = rod_damping(model, name)
            times = np.array([options.retardation(kind) for kind in term.strain_kinds])
            if np.all(times == times[0]):
                if times[0] > 0.0:
                    self.elastic.append((term, float(times[0]), None))
            elif np.any(times > 0.0):
                self.elastic.append((term, 1.0, times))
        for name, rod in model.rods.items():
            c = rod_damping(model, name).drag
            if c <= 0.0:
                continue
            length = rod.geometry.segment_length
            index = rod.layout.position_index  # (N, 3)
            for a, b, share in ((0, 0, 1 / 3), (1, 1, 1 / 3), (0, 1, 1 / 6), (1, 0, 1 / 6)):
                i = index[a:len(index) - 1 + a].ravel()
                j = index[b:len(index) - 1 + b].ravel()
                rows.append(i)
                cols.append(j)
                values.append(np.full(i.size, c * length * share))
        self.drag = self._assemble(rows, cols, values)
        size = model.full_size
        #: The drag on every coordinate, held ones included (``full_matrices``).
        self.drag_full = (sp.csr_matrix((np.concatenate(values), (np.concatenate(rows),
                                                                  np.concatenate(cols))),
                                        shape=(size, size)) if rows
                          else sp.csr_matrix((size, size)))

    @property
    def active(self) -> bool:
        """Whether any rod is damped."""
        return bool(self.elastic) or self.drag.nnz > 0

    def _assemble(self, rows: list[np.ndarray], cols: list[np.ndarray],
                  values: list[np.ndarray]) -> sp.csr_matrix:
        """A sparse matrix on the free coordinates from full-state entries (held ones
        dropped)."""
        n = self.model.n
        if not rows:
            return sp.csr_matrix((n, n))
        i = self._free_of[np.concatenate(rows)]
        j = self._free_of[np.concatenate(cols)]
        v = np.concatenate(values)
        keep = (i >= 0) & (j >= 0)
        return sp.csr_matrix((v[keep], (i[keep], j[keep])), shape=(n, n))

    def _material_entries(self, x: np.ndarray
                          ) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
        """The elastic terms' material stiffness entries at ``x`` (the free coordinates
        themselves), times their τ: (rows, columns, values), full-state indices."""
        state = x - self.model.reference[self.model.free]  # the model's offsets
        full, offsets = self.model.full(state), self.model.offsets(state)
        rows, cols, values = [], [], []
        for term, tau, weights in self.elastic:
            # the material stiffness, a term on offsets (Term.offsets) evaluated at them
            state = offsets if term.offsets else full
            blocks = (term.material_stiffness(state) if weights is None
                      else term.material_stiffness(state, weights))
            dofs = term.dofs
            k = dofs.shape[1]
            rows.append(np.repeat(dofs, k, axis=1).ravel())
            cols.append(np.tile(dofs, (1, k)).ravel())
            values.append(tau * blocks.ravel())
        return rows, cols, values

    def matrix(self, x: np.ndarray) -> sp.csr_matrix:
        """D(x) = Σ_rods Σ_k τ_k K_mat,k(x) + c C on the free coordinates at ``x``, the free
        coordinates themselves (positions and quaternions, not the model's offsets)
        [N·s/m and the quaternions' units]; symmetric."""
        if not self.elastic:
            return self.drag
        material = self._assemble(*self._material_entries(x))
        return (material + material.T) * 0.5 + self.drag

    def full_matrices(self, x: np.ndarray) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """The Kelvin–Voigt part Σ_k τ_k K_mat,k(x) and the drag c C on every coordinate of
        the full state, held ones included (a moving support's damping,
        rodsim/solvers/physical/moving_supports.py), at ``x`` (free coordinates
        themselves); both symmetric."""
        size = self.model.full_size
        drag = self.drag_full
        if not self.elastic:
            return sp.csr_matrix((size, size)), drag
        rows, cols, values = self._material_entries(x)
        material = sp.csr_matrix((np.concatenate(values),
                                  (np.concatenate(rows), np.concatenate(cols))),
                                 shape=(size, size))
        return ((material + material.T) * 0.5).tocsr(), drag
