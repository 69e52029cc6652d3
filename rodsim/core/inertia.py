"""The physical mass model of the rods: translational and rotary inertia (paper Eqs. 10–13).

This is the inertia of the catheter itself, for physical time (natural frequencies,
rodsim/core/vibration.py; docs/dynamics.md). It is kept apart from the pseudo-dynamics'
masses (``rodsim.core.model.Model.pseudo_time_masses``, the integrators' way to an
equilibrium), which are chosen for speed, not physics.

Translational inertia (Eqs. 10–11): the kinetic energy of the centerline as the paper
interpolates it, linearly between control points (§2.2), ½ ∫ ρA |ṙ(s)|² ds with
ṙ(s) = Σ_i N_i(s) ṙ_i (N_i the hat functions): the consistent mass M_ij = ∫ ρA N_i N_j ds,
tridiagonal per axis (ρA l (1/3, 1/6, 1/3) per segment of a uniform rod; with sections,
∫ ρA N_i N_j ds over each span), plus any point mass a term attaches (a hanging mass,
``Term.point_masses``). Its row sums are the
lumped node masses m_i = ∫ ρA N_i ds (``rodsim.core.rod.rod.Rod.node_masses``, which the
weight uses). Measured on a clamped–free steel rod (tests/test_modes.py): the lumped
diagonal puts the third bending frequency 1.4e-3 low at N = 81, the consistent mass 4.1e-4
low (both second order; the paper does not say which it used).

Rotary inertia (Eqs. 12–13): segment j turns as a rigid body with the body-frame inertia
I_j = diag(ρI, ρI, ρJ) l (ρI about the bending directors d1, d2, ρJ about the tangent d3;
with sections, ∫ ρI ds and ∫ ρJ ds over the segment). Eq. (13), q̇ = ½ Q(q) (0, ω), inverts
for a unit quaternion to ω = 2 Q(q)ᵀ q̇; in the discretisation's own matrices (Eqs. 4–5) the
body-frame components are

    ω_k = (2 / |q|²) (B_k q) · q̇,   k = 1, 2, 3,

the same form as the strains u_k of Eq. (3) with q̇ for q′ (and the same normalisation by
|q|², which makes ω independent of the quaternion's norm). The kinetic energy
½ Σ_k I_k ω_k² is then ½ q̇ᵀ M_q q̇ with the 4×4 block

    M_q = (4 / |q|⁴) Σ_k I_k (B_k q)(B_k q)ᵀ = G Gᵀ,   G = (2 / |q|²) [√I_k B_k q]_k (4×3).

The B_k q are orthogonal to q (B_k is skew) and to each other, so M_q has rank 3: the
direction q (the quaternion's norm) carries no mass. That is exact, not an approximation:
the norm is not a physical motion; the centerline penalty (Eq. 9) holds it, with a stiffness
and no inertia, and the eigenproblem condenses it out (rodsim/core/vibration.py).
tests/test_modes.py checks ω against a rotation of known rate.

The whole M is returned as its factor ``L`` (M = L Lᵀ on the free coordinates): one column
per free position coordinate (the banded Cholesky factor of each rod's tridiagonal mass on
its free nodes, per axis), three per free quaternion (the columns of G). Its number of
columns is the number of the system's physical degrees of freedom.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from rodsim.core.model import Model
from rodsim.core.rod.quaternion import B
from rodsim.core.rod.rod import Rod

__all__ = ["segment_inertia", "quaternion_mass_factor", "quaternion_mass",
           "angular_velocity", "segment_mass", "point_masses", "total_mass", "mass_factor"]


def segment_inertia(rod: Rod) -> np.ndarray:
    """Body-frame rotary inertia of every segment, (ρI l, ρI l, ρJ l) [kg·m²], shape
    (N − 1, 3): about d1 and d2 (bending) and about d3 (twist). With sections, ∫ ρI ds and
    ∫ ρJ ds over each segment (``rodsim.core.rod.sections``)."""
    length = rod.geometry.segment_length
    out = np.empty((rod.nodes - 1, 3))
    profile = rod.profile
    if profile is None:
        out[:, :2] = rod.density * rod.second_moment * length
        out[:, 2] = rod.density * rod.polar_moment * length
        return out
    left = np.arange(rod.nodes - 1) * length
    right = left + length
    out[:, 0] = out[:, 1] = profile.integral(profile.density * profile.second_moment,
                                             left, right)
    out[:, 2] = profile.integral(profile.density * profile.polar_moment, left, right)
    return out


def _velocity_rows(q: np.ndarray) -> np.ndarray:
    """(2 / |q|²) B_k q for k = 1, 2, 3, shape (..., 3, 4): ω_k = row_k · q̇."""
    rows = np.einsum("kab,...b->...ka", B, q)
    return (2.0 / np.sum(q * q, axis=-1))[..., None, None] * rows


def angular_velocity(q: np.ndarray, q_dot: np.ndarray) -> np.ndarray:
    """Body-frame angular velocity (ω_1, ω_2, ω_3) [rad/s] (components on d1, d2, d3) of
    quaternions ``q`` (..., 4) moving at ``q_dot`` (Eq. 13 inverted; module docstring)."""
    return np.einsum("...ka,...a->...k", _velocity_rows(q), q_dot)


def quaternion_mass_factor(q: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """G with M_q = G Gᵀ for quaternions ``q`` (n, 4) and body inertias ``inertia`` (n, 3):
    shape (n, 4, 3), column k = √I_k (2/|q|²) B_k q."""
    rows = _velocity_rows(q)  # (n, 3, 4)
    return np.transpose(rows, (0, 2, 1)) * np.sqrt(inertia)[:, None, :]


def quaternion_mass(q: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """The 4×4 rotary mass blocks M_q = (4/|q|⁴) Σ_k I_k (B_k q)(B_k q)ᵀ, shape (n, 4, 4)
    [kg·m² per quaternion unit²], rank 3 (q is its null vector)."""
    factor = quaternion_mass_factor(q, inertia)
    return factor @ np.transpose(factor, (0, 2, 1))


def segment_mass(rod: Rod) -> np.ndarray:
    """The consistent mass of every segment's two control points a, b,
    (∫ ρA N_a² ds, ∫ ρA N_a N_b ds, ∫ ρA N_b² ds) [kg], shape (N − 1, 3): ρA l (1/3, 1/6,
    1/3) on a uniform rod; with sections, each span's ρA over its part of the segment."""
    length = rod.geometry.segment_length
    profile = rod.profile
    if profile is None:
        return np.tile(rod.density * rod.area * length * np.array([1 / 3, 1 / 6, 1 / 3]),
                       (rod.nodes - 1, 1))
    left = np.arange(rod.nodes - 1) * length
    out = np.zeros((rod.nodes - 1, 3))
    for value, start, end in zip(profile.density * profile.area, profile.start, profile.end,
                                 strict=True):
        t0 = np.clip((start - left) / length, 0.0, 1.0)
        t1 = np.maximum(np.clip((end - left) / length, 0.0, 1.0), t0)
        # ∫ (1 − t)² dt, ∫ t (1 − t) dt, ∫ t² dt over [t0, t1], N_a = 1 − t, N_b = t
        cube = (t1**3 - t0**3) / 3.0
        square = (t1**2 - t0**2) / 2.0
        out[:, 0] += value * length * ((t1 - t0) - 2.0 * square + cube)
        out[:, 1] += value * length * (square - cube)
        out[:, 2] += value * length * cube
    return out


def point_masses(model: Model) -> np.ndarray:
    """The point masses the terms attach, on every coordinate of the full state [kg] (zero
    elsewhere)."""
    full = np.zeros(model.full_size)
    for term in model.terms:
        attached = term.point_masses()
        if attached is not None:
            index, masses = attached
            np.add.at(full, index, np.repeat(np.asarray(masses, float)[:, None], 3, axis=1))
    return full


def total_mass(model: Model) -> float:
    """The mass of every rod and point mass of the model [kg] (held nodes included)."""
    return float(sum(rod.node_masses().sum() for rod in model.rods.values())
                 + point_masses(model).sum() / 3.0)


def _position_factor(rod: Rod, free: np.ndarray, extra: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Entries (rows, local columns, values) and column count of the factor of one rod's
    translational mass on its free nodes (``free``: the free index of every position
    coordinate (N, 3), −1 if fixed; ``extra``: point masses (N, 3)): per axis, the
    tridiagonal consistent mass restricted to the free nodes, factored U ᵀ U by banded
    Cholesky, L = Uᵀ."""
    blocks = segment_mass(rod)
    diagonal = np.zeros(rod.nodes)
    diagonal[:-1] += blocks[:, 0]
    diagonal[1:] += blocks[:, 2]
    moving = np.flatnonzero(free[:, 0] >= 0)
    coupled = np.diff(moving) == 1  # neighbours both free: their coupling stays
    off = np.where(coupled, blocks[moving[:-1], 1], 0.0) if len(moving) > 1 else np.zeros(0)
    rows, cols, values = [], [], []
    count = len(moving)
    for axis in range(3):
        ab = np.zeros((2, count))
        ab[1] = diagonal[moving] + extra[moving, axis]
        ab[0, 1:] = off
        upper = la.cholesky_banded(ab)  # M = Uᵀ U, U upper bidiagonal
        # L = Uᵀ: L[i, i] = U[i, i], L[i + 1, i] = U[i, i + 1]
        index = free[moving, axis]
        columns = axis * count + np.arange(count)
        rows += [index, index[1:]]
        cols += [columns, columns[:-1]]
        values += [upper[1], upper[0, 1:]]
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(values), 3 * count


def mass_factor(model: Model, x: np.ndarray, rotary: bool = True) -> sp.csr_matrix:
    """L with M = L Lᵀ, the physical mass matrix on the free coordinates of ``model`` at the
    free state ``x`` (module docstring), shape (n, m): one column per free position
    coordinate and, with ``rotary``, three per free quaternion. ``rotary`` False leaves
    the rotary inertia out (an Euler–Bernoulli beam's inertia: every quaternion massless).
    """
    full = model.full(x)
    free_of = np.full(model.full_size, -1)
    free_of[model.free] = np.arange(model.n)
    attached = point_masses(model)
    rows: list[np.ndarray] = []
    values: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    columns = 0
    for rod in model.rods.values():
        position = rod.layout.position_index
        row, col, value, count = _position_factor(rod, free_of[position], attached[position])
        rows.append(row)
        cols.append(columns + col)
        values.append(value)
        columns += count
        if not rotary:
            continue
        index = rod.layout.quaternion_index
        free_q = free_of[index]
        moving = np.all(free_q >= 0, axis=1)
        if not np.any(moving):
            continue
        factor = quaternion_mass_factor(full[index[moving]], segment_inertia(rod)[moving])
        count = int(np.count_nonzero(moving))
        rows.append(np.repeat(free_q[moving], 3, axis=1).ravel())  # (n, 4) -> (n, 4·3)
        values.append(factor.ravel())
        cols.append((columns + 3 * np.arange(count)[:, None, None]
                     + np.arange(3)[None, None, :] + np.zeros((1, 4, 1), int)).ravel())
        columns += 3 * count
    return sp.csr_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(model.n, columns))
