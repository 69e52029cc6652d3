"""The physical coordinates of a model's motion: where each free coordinate sits, the
velocities, the mass and the quaternion kinematics (paper Eqs. 10–13; docs/dynamics.md).

The state is the model's free coordinates x (node positions r and segment quaternions q,
Eq. 18) and the physical velocities u = (ṙ, ω): every free position coordinate's velocity
and each free segment's body-frame angular velocity ω = (ω_1, ω_2, ω_3) on its directors
(d1, d2, d3). Eq. (13), q̇ = ½ Q(q) (0, ω), reads in the discretisation's matrices (Eq. 4)

    q̇ = ½ Σ_k ω_k B_k q,

so that ω_k = (2/|q|²) (B_k q) · q̇ (rodsim/core/inertia.py). B_k is skew, so q̇ ⊥ q: the
kinematics keep |q| = 1 and the quaternion's norm, which has no mass (its direction q is
the null vector of the rotary mass M_q), is no degree of freedom of the motion. A
generalised force F_q on a quaternion acts on the segment as the torque
τ_k = ½ (B_k q) · F_q (virtual work F_q · δq with δq = ½ Σ_k δθ_k B_k q); its part along q
(the centerline penalty's pull on the norm, Eq. 9) is the constraint's reaction and does no
work.

The mass is constant in these velocities: the consistent translational mass M_r
(``rodsim.core.inertia.mass_factor``, point masses included) and the body inertia
I = l diag(ρI, ρI, ρJ) of each segment (``rodsim.core.inertia.segment_inertia``); the
kinetic energy is T = ½ ṙᵀ M_r ṙ + ½ Σ_segments ωᵀ I ω.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from rodsim.core.inertia import mass_factor, segment_inertia
from rodsim.core.model import Model
from rodsim.core.rod.quaternion import B
from rodsim.solvers.physical.sparse_kernels import Csr

__all__ = ["PhysicalCoordinates", "velocity_rows", "cayley", "skew", "block_diagonal",
           "block_entries", "block_arrays", "placed", "placed_arrays", "cross_rows",
           "gyroscopic_jacobian"]


def velocity_rows(q: np.ndarray) -> np.ndarray:
    """B_k q for quaternions ``q`` (s, 4): shape (s, 3, 4), row k = B_k q."""
    return np.einsum("kab,sb->ska", B, q)


def cayley(q: np.ndarray, w: np.ndarray, h: float) -> np.ndarray:
    """The quaternions q₁ with q₁ − q = (h/2) Ω (q + q₁)/2, Ω = Σ_k w_k B_k: the implicit
    midpoint step of q̇ = ½ Ω q at the constant rate ``w`` (s, 3) over ``h``, the Cayley
    transform (I − hΩ/4)⁻¹ (I + hΩ/4) q, which keeps |q| exactly (Ω is skew). The B_k
    anticommute and square to −I, so Ω² = −|w|² I and (I − aΩ)⁻¹ = (I + aΩ)/(1 + a²|w|²)
    (a = h/4): q₁ = ((1 − a²|w|²) q + 2a Ω q)/(1 + a²|w|²), in closed form."""
    a = 0.25 * h
    squared = a * a * np.sum(w * w, axis=1)[:, None]
    turned = np.einsum("ska,sk->sa", velocity_rows(q), w)  # Ω q = Σ_k w_k B_k q
    return ((1.0 - squared) * q + 2.0 * a * turned) / (1.0 + squared)


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b row by row for (s, 3) arrays: numpy.cross's own products and differences,
    without its axis handling (the same numbers)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def skew(a: np.ndarray) -> np.ndarray:
    """[a]× for vectors ``a`` (s, 3): shape (s, 3, 3)."""
    out = np.zeros(a.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -a[..., 2], a[..., 1]
    out[..., 1, 0], out[..., 1, 2] = a[..., 2], -a[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -a[..., 1], a[..., 0]
    return out


def gyroscopic_jacobian(inertia: np.ndarray, w: np.ndarray) -> np.ndarray:
    """∂(ω × I ω)/∂ω = [ω]× I − [I ω]× per segment, for body inertias ``inertia`` and rates
    ``w`` (s, 3): shape (s, 3, 3)."""
    return skew(w) * inertia[:, None, :] - skew(inertia * w)


#: The canonical CSR structure (indices, indptr, the entries' order) of the placements met
#: so far, keyed by the placement: each step asks for the same few.
_STRUCTURES: dict[tuple[object, ...], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _structure(rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int]
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(indices, indptr, order) of the CSR matrix scipy builds from distinct (row, column)
    entries: sorted column indices per row (its ``sum_duplicates`` sorts them), and where
    each stored entry comes from among the entries. Found once per placement by building
    the matrix from the entries' own positions."""
    key = (shape, rows.tobytes(), cols.tobytes())
    known = _STRUCTURES.get(key)
    if known is None:
        if len(set(zip(rows.tolist(), cols.tolist(), strict=True))) != rows.size:
            raise ValueError("overlapping entries")  # placements here are disjoint
        place = sp.csr_matrix((np.arange(1.0, rows.size + 1.0), (rows, cols)), shape=shape)
        known = (place.indices, place.indptr, place.data.astype(np.intp) - 1)
        if len(_STRUCTURES) > 64:
            _STRUCTURES.clear()
        _STRUCTURES[key] = known
    return known


def placed_arrays(values: np.ndarray, rows: np.ndarray, cols: np.ndarray,
                  shape: tuple[int, int], prune: bool = False) -> Csr:
    """The CSR arrays of ``placed`` (no scipy matrix built: for the kernels of
    rodsim/solvers/physical/sparse_kernels.py)."""
    indices, indptr, order = _structure(rows.ravel(), cols.ravel(), shape)
    data = values.ravel()[order]
    if prune and not np.all(data):
        kept = data != 0.0
        indptr = np.concatenate([[0], np.cumsum(kept)]).astype(indptr.dtype)[indptr]
        indices, data = indices[kept], data[kept]
    return Csr(indptr, indices, data)


def placed(values: np.ndarray, rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int],
           prune: bool = False) -> sp.csr_matrix:
    """``sp.csr_matrix((values, (rows, cols)), shape=shape)`` for distinct entries, the same
    arrays entry for entry (explicit zeros kept), from a structure found once per
    placement; ``prune``: without the zero entries, as scipy's sum of two matrices with
    disjoint entries leaves them (its ``csr_plus_csr`` stores only nonzero results)."""
    indptr, indices, data = placed_arrays(values, rows, cols, shape, prune)
    out = sp.csr_matrix((data, indices, indptr), shape=shape)
    out.has_canonical_format = True
    return out


def block_entries(rows: np.ndarray, cols: np.ndarray, a: int, b: int
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The (row, column) of every entry of blocks (s, a, b) at row indices ``rows`` (s, a)
    and column indices ``cols`` (s, b), in the blocks' raveled order."""
    return (np.repeat(rows[:, :, None], b, axis=2).ravel(),
            np.repeat(cols[:, None, :], a, axis=1).ravel())


def block_diagonal(blocks: np.ndarray, rows: np.ndarray, cols: np.ndarray, shape: tuple[
        int, int]) -> sp.csr_matrix:
    """A sparse matrix of ``blocks`` (s, a, b) placed at row indices ``rows`` (s, a) and
    column indices ``cols`` (s, b), the blocks disjoint: the matrix
    ``sp.csr_matrix((blocks.ravel(), (r, c)))`` of their entries (``placed``)."""
    r, c = block_entries(rows, cols, *blocks.shape[1:])
    return placed(blocks, r, c, shape)


def block_arrays(blocks: np.ndarray, rows: np.ndarray, cols: np.ndarray, shape: tuple[
        int, int]) -> Csr:
    """The CSR arrays of ``block_diagonal`` (``placed_arrays``)."""
    r, c = block_entries(rows, cols, *blocks.shape[1:])
    return placed_arrays(blocks, r, c, shape)


@dataclass(frozen=True)
class PhysicalCoordinates:
    """Where the physical degrees of freedom sit among a model's free coordinates, and their
    mass.

    Attributes
    ----------
    positions
        Free index of every free position coordinate, shape (p,).
    quaternions
        Free indices of every free segment's quaternion, shape (s, 4).
    mass
        The translational mass M_r on ``positions`` [kg], sparse (p, p).
    inertia
        Body-frame inertia (I_1, I_2, I_3) of each free segment [kg·m²], shape (s, 3).
    """

    positions: np.ndarray
    quaternions: np.ndarray
    mass: sp.csr_matrix
    inertia: np.ndarray

    @classmethod
    def of(cls, model: Model, x: np.ndarray) -> PhysicalCoordinates:
        """The coordinates of ``model`` (ValueError when a quaternion is only partly held,
        or a free coordinate is neither a position nor a quaternion)."""
        free_of = np.full(model.full_size, -1)
        free_of[model.free] = np.arange(model.n)
        positions, quaternions, inertia = [], [], []
        for rod in model.rods.values():
            index = free_of[rod.layout.position_index].ravel()
            positions.append(index[index >= 0])
            q_index = free_of[rod.layout.quaternion_index]
            moving = np.all(q_index >= 0, axis=1)
            if np.any(np.any(q_index >= 0, axis=1) & ~moving):
                raise ValueError(f"rod {rod.name!r}: a quaternion is only partly held; "
                                 "physical time needs each segment free or held")
            quaternions.append(q_index[moving])
            inertia.append(segment_inertia(rod)[moving])
        p = np.concatenate(positions)
        q = np.concatenate(quaternions).reshape(-1, 4)
        if p.size + q.size != model.n:
            raise ValueError("a free coordinate is neither a position nor a quaternion")
        factor = mass_factor(model, model_state(model, x), rotary=False).tocsr()
        full = (factor @ factor.T).tocsr()
        return cls(p, q, full[p][:, p].tocsr(), np.concatenate(inertia).reshape(-1, 3))

    @property
    def size(self) -> int:
        """The number of physical degrees of freedom, p + 3 s."""
        return len(self.positions) + 3 * len(self.quaternions)

    def kinetic_energy(self, v: np.ndarray, w: np.ndarray) -> float:
        """T = ½ vᵀ M_r v + ½ Σ ωᵀ I ω [J] for node velocities ``v`` (p,) and body rates
        ``w`` (s, 3)."""
        return float(0.5 * v @ (self.mass @ v) + 0.5 * np.sum(self.inertia * w * w))

    def g_matrix(self, x: np.ndarray, n: int) -> sp.csr_matrix:
        """G (n × (p + 3 s)) at ``x`` (unit quaternions), ``n`` free coordinates: ẋ = G u
        (positions: the velocities; q̇ = ½ Σ_k ω_k B_k q), and Gᵀ f = (f_r, τ) with
        τ_k = ½ (B_k q) · f_q."""
        blocks = 0.5 * np.transpose(velocity_rows(x[self.quaternions]), (0, 2, 1))
        return self.tangent_map(blocks, 1.0, n)

    def tangent_map(self, blocks: np.ndarray, position: float, n: int) -> sp.csr_matrix:
        """An n × (p + 3 s) map from the physical velocities to the ``n`` free coordinates:
        ``position`` times the identity on the positions, the 4 × 3 ``blocks`` (s, 4, 3) on
        each segment's quaternion and angles (the sum of the two, as one placement:
        ``placed``, without its exact zeros)."""
        rows, cols = self._map_entries
        return placed(np.concatenate([np.full(len(self.positions), position),
                                      blocks.ravel()]), rows, cols, (n, self.size),
                      prune=True)

    def tangent_arrays(self, blocks: np.ndarray, position: float, n: int) -> Csr:
        """The CSR arrays of ``tangent_map`` (``placed_arrays``)."""
        rows, cols = self._map_entries
        return placed_arrays(np.concatenate([np.full(len(self.positions), position),
                                             blocks.ravel()]), rows, cols, (n, self.size),
                             prune=True)

    def g_arrays(self, x: np.ndarray, n: int) -> Csr:
        """The CSR arrays of ``g_matrix``."""
        blocks = 0.5 * np.transpose(velocity_rows(x[self.quaternions]), (0, 2, 1))
        return self.tangent_arrays(blocks, 1.0, n)

    @cached_property
    def _map_entries(self) -> tuple[np.ndarray, np.ndarray]:
        """The (row, column) of ``tangent_map``'s entries: the positions' identity, then
        the quaternions' 4 × 3 blocks (raveled)."""
        p, s = len(self.positions), len(self.quaternions)
        r, c = block_entries(self.quaternions, p + np.arange(3 * s).reshape(-1, 3), 4, 3)
        return np.concatenate([self.positions, r]), np.concatenate([np.arange(p), c])

    @cached_property
    def angle_columns(self) -> np.ndarray:
        """Each free segment's three angle columns among the physical degrees of freedom
        (after the p positions), shape (s, 3)."""
        return len(self.positions) + np.arange(3 * len(self.quaternions)).reshape(-1, 3)

    @cached_property
    def mass_entries(self) -> tuple[np.ndarray, np.ndarray]:
        """Where a step's Newton matrix places its masses: M_r's stored entries, then the
        3 × 3 rotation blocks on the angles (raveled)."""
        r, c = block_entries(self.angle_columns, self.angle_columns, 3, 3)
        return (np.concatenate([np.repeat(np.arange(len(self.positions)),
                                          np.diff(self.mass.indptr)), r]),
                np.concatenate([self.mass.indices, c]))

    def rates(self, x: np.ndarray, x_dot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The physical velocities (ṙ, ω) of a motion ``x_dot`` of the free coordinates at
        ``x`` (ω_k = (2/|q|²) (B_k q) · q̇)."""
        q = x[self.quaternions]
        rows = velocity_rows(q) * (2.0 / np.sum(q * q, axis=1))[:, None, None]
        return x_dot[self.positions].copy(), np.einsum("ska,sa->sk", rows,
                                                       x_dot[self.quaternions])


def model_state(model: Model, x: np.ndarray) -> np.ndarray:
    """The model's free state (offsets from its rest state, ``Model.full``) of ``x``, the
    free coordinates themselves — positions [m] and quaternions — in which physical time
    steps (a quaternion's Cayley update needs the quaternion, not its offset)."""
    return x - model.reference[model.free]


def physical_state(model: Model, state: np.ndarray) -> np.ndarray:
    """The free coordinates themselves of the model's free state ``state`` (offsets):
    the inverse of ``model_state``."""
    return state + model.reference[model.free]

