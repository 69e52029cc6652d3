"""Assemble a scene's rods and terms into F(x), its sparse Jacobian J(x) and the pattern.

The *full* state holds every coordinate of every rod (Eqs. 18 and 30); the clamps fix some
of them. Integrators only see the *free* coordinates ``x``: ``Model.force(x)`` and
``Model.jacobian(x)`` return the generalised force F(x) = −∂E/∂x (plus non-conservative
penalty forces) and ∂F/∂x on those. The sparsity pattern is the union of the terms'
element blocks, fixed when the model is built; the Jacobian values are scattered into it
with precomputed index maps, so one evaluation is a handful of vectorised numpy calls.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee

from rodsim.rod.layout import RodLayout
from rodsim.rod.rod import Rod
from rodsim.scene import Scene
from rodsim.sparsity import csc_pattern
from rodsim.tendon import Tendon, tendon_origin
from rodsim.terms import Term, registered_terms

__all__ = ["Model", "Band"]


@dataclass(frozen=True)
class Band:
    """Lower and upper bandwidth of the Jacobian of the free coordinates."""

    lower: int
    upper: int


class Model:
    """The discretised rod system of one scene.

    Parameters
    ----------
    scene
        A validated scene; only the terms it lists are built.
    """

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        tendons = scene.data["tendons"]
        self.rods: dict[str, Rod] = {}
        offset = 0
        # Catheters first, so a tendon's base can be placed in its catheter's lumen.
        for name in sorted(scene.data["rods"], key=lambda n: n in tendons):
            params = scene.data["rods"][name]
            layout = RodLayout(params["nodes"], offset)
            origin = (tendon_origin(self.rods[tendons[name]["catheter"]], tendons[name])
                      if name in tendons else np.asarray(params["origin"], dtype=float))
            self.rods[name] = Rod(name, params, layout, origin)
            offset += layout.size
        self.rods = {name: self.rods[name] for name in scene.data["rods"]}
        self.full_size = offset
        catalogue = registered_terms()
        self.terms: list[Term] = []
        for rod in self.rods.values():
            for term_name in rod.params["terms"]:
                self.terms.append(catalogue[term_name](rod, rod.params[term_name]))
        #: The scene's tendons (lumen geometry shared by their coupling terms).
        self.tendons = {name: Tendon.of(name, self.rods, table)
                        for name, table in tendons.items()}
        for name, table in tendons.items():
            for term_name in table["terms"]:
                self.terms.append(catalogue[term_name](self.tendons[name], table[term_name]))

        self.rest_full = np.zeros(self.full_size)
        fixed = []
        for rod in self.rods.values():
            self.rest_full[rod.layout.position_index] = rod.rest_positions()
            self.rest_full[rod.layout.quaternion_index] = rod.rest_quaternions()
            fixed.append(rod.fixed_index())
        is_free = np.ones(self.full_size, dtype=bool)
        is_free[np.concatenate(fixed)] = False
        #: Full-state index of every free coordinate, in the integrators' order.
        self.free = np.flatnonzero(is_free)
        self.n = len(self.free)
        #: Incremented whenever the Jacobian pattern changes (see :meth:`update_registration`).
        self.pattern_version = 0
        self._build_maps()
        if len(self.rods) > 1:
            self._order_for_band()
        self._build_scales()

    # ------------------------------------------------------------------ setup
    def _build_maps(self) -> None:
        self._free_of = np.full(self.full_size, self.n)  # fixed -> dump slot n
        self._free_of[self.free] = np.arange(self.n)
        self._build_force_scatter()
        self._build_pattern()

    def _order_for_band(self) -> None:
        """Reorder the free coordinates (reverse Cuthill–McKee) when that narrows the band.

        Coupled rods concatenated as in Eq. (30) give a wide band (a tendon point couples to
        catheter coordinates far away in the vector); interleaving them keeps the system
        banded. The order is fixed once, from the pattern at rest.
        """
        order = reverse_cuthill_mckee(self.pattern, symmetric_mode=True)
        offsets = self.pattern_rows - self.pattern_cols
        current = max(offsets.max(), -offsets.min())
        inverse = np.empty_like(order)
        inverse[order] = np.arange(self.n)
        new_offsets = inverse[self.pattern_rows] - inverse[self.pattern_cols]
        if max(new_offsets.max(), -new_offsets.min()) < current:
            self.free = self.free[order]
            self._build_maps()

    def update_registration(self, x: np.ndarray, exact: bool = False) -> bool:
        """Let dynamic terms (tendon registration, §4.1) update their state from ``x``
        (``exact``: without hysteresis, as at equilibrium; see :meth:`settle_registration`).

        Returns True when a registration changed: the element coordinates, and so the
        Jacobian pattern, changed; the maps are then rebuilt and :attr:`pattern_version`
        incremented so integrators can rebuild what they derived from the pattern. The order
        of the free coordinates never changes.
        """
        full = self.full(x)
        changed = False
        for term in self.terms:
            if term.dynamic:
                changed |= term.update_registration(full, exact)
        if changed:
            self._registration_changed()
        return changed

    def _registration_changed(self) -> None:
        self._build_maps()
        self.pattern_version += 1

    @property
    def conservative(self) -> bool:
        """True when every term is −∇ of its energy (F = −∇E: the Jacobian is symmetric and
        Newton may line-search on the energy)."""
        return all(term.conservative for term in self.terms)

    @property
    def has_registration(self) -> bool:
        """True when some term registers its elements to the state (a tendon's lumen)."""
        return any(term.dynamic for term in self.terms)

    def settle_registration(self, x: np.ndarray) -> bool:
        """At an equilibrium ``x``: re-register without hysteresis; True if a parent changed,
        in which case ``x`` is no equilibrium of the model's own registration rule and the
        integrator must go on from it."""
        return self.update_registration(x, exact=True)

    def reset_registration(self) -> None:
        """Return dynamic terms to the rest state's registration (every solve starts here, so
        reusing a model does not carry the last run's registration into the next)."""
        changed = False
        for term in self.terms:
            if term.dynamic:
                changed |= term.reset_registration()
        if changed:
            self._registration_changed()

    def _build_force_scatter(self) -> None:
        self._loads = [t for t in self.terms if t.is_load]
        self._force_targets = np.concatenate([self._free_of[t.dofs.ravel()]
                                              for t in self.terms])

    def _build_pattern(self) -> None:
        n = self.n
        self._jac_terms = [t for t in self.terms if t.has_jacobian]
        # The diagonal is always in the pattern; entries on fixed coordinates are dropped.
        diagonal = np.arange(n)
        rows, cols = self._element_entries(term.dofs for term in self._jac_terms)
        keep = (rows < n) & (cols < n)
        pattern = csc_pattern(np.concatenate([diagonal, rows[keep]]),
                              np.concatenate([diagonal, cols[keep]]), n)
        #: Jacobian sparsity pattern of the free coordinates (CSC, ones where J may be ≠ 0).
        self.pattern = pattern.matrix
        self.pattern_rows, self.pattern_cols = pattern.rows, pattern.cols
        self.nnz = pattern.nnz
        # Where each term's element entry lands in the CSC data (nnz: a dump slot for
        # entries on fixed coordinates).
        self._jac_targets = np.full(len(rows), self.nnz)
        self._jac_targets[keep] = pattern.target[n:]
        self.band = Band(*pattern.band)

    def _element_entries(self, dof_sets) -> tuple[np.ndarray, np.ndarray]:
        """(row, column) free indices of every entry of the element blocks ``dof_sets``
        (fixed coordinates map to n)."""
        rows, cols = [np.zeros(0, dtype=int)], [np.zeros(0, dtype=int)]
        for dofs in dof_sets:
            k = dofs.shape[1]
            free = self._free_of[dofs]
            rows.append(np.repeat(free, k, axis=1).ravel())
            cols.append(np.tile(free, (1, k)).ravel())
        return np.concatenate(rows), np.concatenate(cols)

    def _build_scales(self) -> None:
        x0 = self.x0
        full = self.full(x0)
        load = 0.0
        for term in self._loads:
            load += float(np.sum(np.linalg.norm(term.element_forces(full), axis=1)))
        rods = list(self.rods.values())
        fallback = max(r.bending_stiffness / r.length**2 for r in rods)
        #: Force scale F_ref [N]: total external load, or max EI/L² for an unloaded scene.
        self.force_scale = load if load > 0 else fallback
        #: Length scale L_ref [m]: the longest rod.
        self.length_scale = max(r.length for r in rods)
        is_quat = np.zeros(self.full_size, dtype=bool)
        for rod in rods:
            is_quat[rod.layout.quaternion_index] = True
        self.is_quaternion = is_quat[self.free]
        #: Per-coordinate weights of :meth:`residual`: 1/F_ref, or 1/(F_ref L_ref) for
        #: quaternion coordinates.
        self.residual_weight = np.where(
            self.is_quaternion, 1.0 / (self.force_scale * self.length_scale),
            1.0 / self.force_scale)
        # Round-off floor of the residual: F_i carries an absolute error of about
        # eps |K_ii| |x_i| (stiff springs between coordinates of size ~L). The floor is set
        # with a margin (32 eps) so that it is reliably attainable: residual noise measured at
        # converged states is 5–20× below it; Newton iterations asked to go lower only stall.
        magnitude = np.where(self.is_quaternion, 1.0, self.length_scale)
        stiffness = np.abs(self.jacobian(x0).diagonal())
        #: Smallest scaled residual the model reliably reaches in double precision.
        self.residual_floor = float(32.0 * np.finfo(float).eps
                                    * np.max(stiffness * magnitude * self.residual_weight))

    # ------------------------------------------------------------- state maps
    @property
    def x0(self) -> np.ndarray:
        """The undeformed rest state (free coordinates): every simulation starts here."""
        return self.rest_full[self.free].copy()

    def full(self, x: np.ndarray) -> np.ndarray:
        """Full state (fixed coordinates included) from the free coordinates."""
        out = self.rest_full.copy()
        out[self.free] = x
        return out

    def positions(self, x: np.ndarray, rod: str) -> np.ndarray:
        """Control points of one rod, shape (N, 3) [m]."""
        return self.full(x)[self.rods[rod].layout.position_index]

    def quaternions(self, x: np.ndarray, rod: str) -> np.ndarray:
        """Segment quaternions of one rod, shape (N − 1, 4)."""
        return self.full(x)[self.rods[rod].layout.quaternion_index]

    def masses(self) -> np.ndarray:
        """Diagonal mass matrix M of the free coordinates (Eq. 17) [kg or kg·m²]."""
        full = np.zeros(self.full_size)
        for rod in self.rods.values():
            full[rod.layout.position_index] = rod.node_masses()[:, None]
            full[rod.layout.quaternion_index] = rod.quaternion_masses()[:, None]
        return full[self.free]

    # ------------------------------------------------------------ evaluation
    def energy(self, x: np.ndarray, load: float = 1.0) -> float:
        """Total potential energy [J] (raises if a term is not conservative)."""
        full = self.full(x)
        total = 0.0
        for term in self.terms:
            value = term.energy(full)
            if value is None:
                raise ValueError(f"term {term.name!r} is not conservative: no energy")
            total += load * value if term.is_load else value
        return total

    def force(self, x: np.ndarray, load: float = 1.0) -> np.ndarray:
        """Generalised force F(x) on the free coordinates; loads are scaled by ``load``."""
        full = self.full(x)
        weights = []
        for term in self.terms:
            values = term.element_forces(full).ravel()
            weights.append(load * values if term.is_load and load != 1.0 else values)
        return np.bincount(self._force_targets, weights=np.concatenate(weights),
                           minlength=self.n + 1)[:-1]

    def jacobian_data(self, x: np.ndarray, load: float = 1.0) -> np.ndarray:
        """∂F/∂x as the data array of a CSC matrix with the pattern :attr:`pattern`."""
        full = self.full(x)
        values = []
        for term in self._jac_terms:
            block = term.element_jacobians(full).ravel()
            values.append(load * block if term.is_load and load != 1.0 else block)
        if not values:
            return np.zeros(self.nnz)
        return np.bincount(self._jac_targets, weights=np.concatenate(values),
                           minlength=self.nnz + 1)[:-1]

    def jacobian(self, x: np.ndarray, load: float = 1.0) -> sp.csc_matrix:
        """∂F/∂x as a sparse CSC matrix (n × n)."""
        return self.pattern_matrix(self.jacobian_data(x, load))

    def pattern_matrix(self, data: np.ndarray) -> sp.csc_matrix:
        """A CSC matrix with :attr:`pattern`'s structure and the given data."""
        return sp.csc_matrix((data, self.pattern.indices, self.pattern.indptr),
                             shape=(self.n, self.n))

    def residual(self, force: np.ndarray) -> float:
        """Scaled residual max_i |F_i| w_i: forces / F_ref, quaternion forces / (F_ref L_ref)."""
        return float(np.max(np.abs(force) * self.residual_weight))

    def term(self, name: str) -> Term:
        """The first built term with this name (KeyError if the scene does not use it)."""
        for term in self.terms:
            if term.name == name:
                return term
        raise KeyError(name)
