"""The midpoint step's stiffness on its unknowns, Σ_points w (Gᵀ J P + the geometric blocks),
by a plan made once per Jacobian pattern (rodsim/solvers/physical/midpoint.py, ``_averaged``;
docs/dynamics.md, "What a step costs").

At a Gauss point of the step's path the force's derivative with respect to the step's
unknowns (r₁, ω_m) is Gᵀ J P: J = ∂F/∂x (the model's pattern, CSC), G the map from the
physical velocities to the free coordinates at the point (the identity on the positions,
a 4 × 3 block per segment's quaternion) and P the path's derivative (``node`` times the
identity on the positions, a 4 × 3 block per segment), plus the geometric 3 × 3 block on
each segment's angles. Each entry J_ab reaches the entries (i, j) with G_ai ≠ 0 and
P_bj ≠ 0: one for a position pair, three or nine where a quaternion is involved. Those
targets depend only on the pattern and the coordinates, so they are found once
(``StiffnessPlan.of``: where in the result's CSR arrays each product lands, and which
entries of G's and P's blocks it takes); each fresh Newton matrix then fills the values in
one compiled pass per Gauss point (``accumulate``), instead of two sparse products, a
transpose and two sums of scipy's kernels with their index work (round 17's profile: 0.7 ms
of a fresh matrix's 1.1 ms outside the model on tdcr-two-segment). The result's pattern is
the structural one (entries whose value happens to be zero are kept); its values are the
same sums in another order (round-off).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from rodsim.solvers.physical.coordinates import PhysicalCoordinates
from rodsim.solvers.physical.sparse_kernels import INDEX

__all__ = ["StiffnessPlan", "accumulate"]


@dataclass(frozen=True)
class StiffnessPlan:
    """Where each product J_ab G_ai P_bj lands (module docstring): for every product t,
    ``entry[t]`` (J's CSC data index), ``g_index[t]`` and ``p_index[t]`` (into the raveled
    (s, 4, 3) blocks of G and P; −1 for a position's identity) and ``slot[t]`` (the
    result's data index); ``geometric_slot`` (s · 9) for the raveled geometric blocks;
    the result's CSR ``indptr`` and ``indices`` (m × m). ``pattern`` holds the Jacobian
    pattern's arrays the plan was made for."""

    entry: np.ndarray
    g_index: np.ndarray
    p_index: np.ndarray
    slot: np.ndarray
    geometric_slot: np.ndarray
    indptr: np.ndarray
    indices: np.ndarray
    pattern: tuple[np.ndarray, np.ndarray]

    def fits(self, indptr: np.ndarray, indices: np.ndarray) -> bool:
        """Whether the plan was made for the Jacobian pattern (``indptr``, ``indices``)."""
        mine = self.pattern
        if mine[0] is indptr and mine[1] is indices:
            return True
        return bool(np.array_equal(mine[0], indptr) and np.array_equal(mine[1], indices))

    @classmethod
    def of(cls, c: PhysicalCoordinates, n: int, indptr: np.ndarray,
           indices: np.ndarray) -> StiffnessPlan:
        """The plan for coordinates ``c`` on ``n`` free coordinates and the CSC pattern
        (``indptr``, ``indices``) of J."""
        p, s = len(c.positions), len(c.quaternions)
        m = c.size
        owner = np.full(n, -1, dtype=np.int64)
        part = np.full(n, -1, dtype=np.int64)  # the quaternion component, −1 a position
        owner[c.positions] = np.arange(p)
        owner[c.quaternions.ravel()] = np.repeat(np.arange(s), 4)
        part[c.quaternions.ravel()] = np.tile(np.arange(4), s)
        col = np.repeat(np.arange(n), np.diff(indptr))  # b of each entry
        row = np.asarray(indices, dtype=np.int64)  # a of each entry
        keep = (owner[row] >= 0) & (owner[col] >= 0)
        entries = np.flatnonzero(keep)
        a, b = row[entries], col[entries]
        rows_each = np.where(part[a] < 0, 1, 3)
        cols_each = np.where(part[b] < 0, 1, 3)
        counts = rows_each * cols_each
        which = np.repeat(np.arange(len(entries)), counts)
        local = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
        ri, ci = local // cols_each[which], local % cols_each[which]
        a, b = a[which], b[which]
        quat_a, quat_b = part[a] >= 0, part[b] >= 0
        i = np.where(quat_a, p + 3 * owner[a] + ri, owner[a])
        j = np.where(quat_b, p + 3 * owner[b] + ci, owner[b])
        g_index = np.where(quat_a, 12 * owner[a] + 3 * part[a] + ri, -1)
        p_index = np.where(quat_b, 12 * owner[b] + 3 * part[b] + ci, -1)
        angles = c.angle_columns
        gi = np.repeat(angles[:, :, None], 3, axis=2).ravel()
        gj = np.repeat(angles[:, None, :], 3, axis=1).ravel()
        keys = np.concatenate([i * m + j, gi * m + gj])
        unique = np.unique(keys)
        slots = np.searchsorted(unique, keys)
        out_rows = unique // m
        return cls(entries[which].astype(np.int64), g_index.astype(np.int64),
                   p_index.astype(np.int64), slots[:len(i)].astype(np.int64),
                   slots[len(i):].astype(np.int64),
                   np.searchsorted(out_rows, np.arange(m + 1)).astype(INDEX),
                   (unique % m).astype(INDEX), (indptr, indices))


@njit(cache=True)
def accumulate(jacobian: np.ndarray, entry: np.ndarray, g_index: np.ndarray,
               p_index: np.ndarray, slot: np.ndarray, g_blocks: np.ndarray,
               g_position: float, p_blocks: np.ndarray, p_position: float,
               geometric_slot: np.ndarray, geometric: np.ndarray, weight: float,
               out: np.ndarray) -> None:
    """out[slot] += weight (G_ai J_ab P_bj) for every product of the plan and
    out[geometric_slot] += weight × the geometric blocks (raveled): ``g_blocks`` and
    ``p_blocks`` raveled (s, 4, 3), ``g_position`` and ``p_position`` their identities'
    factors on the positions."""
    for t in range(slot.shape[0]):
        g = g_position if g_index[t] < 0 else g_blocks[g_index[t]]
        p = p_position if p_index[t] < 0 else p_blocks[p_index[t]]
        out[slot[t]] += weight * (g * jacobian[entry[t]] * p)
    for u in range(geometric_slot.shape[0]):
        out[geometric_slot[u]] += weight * geometric[u]
