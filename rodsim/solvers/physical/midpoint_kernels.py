"""Compiled kernels of the midpoint step's Newton iteration (rodsim/solvers/physical/midpoint.py;
docs/dynamics.md, "What a step costs").

An iteration of the midpoint step, beyond the model's force at the two Gauss points, is a
few dozen numpy operations on arrays of a few hundred entries: the Cayley transform and
the midpoint quaternion, each Gauss point's state on the step's path, the torque's
projection of the generalised force, and the residual. Each costs far more in numpy's
call overhead than in arithmetic (round 17's profile: about 0.2 ms an iteration against
0.13 ms for the two force evaluations on tdcr-two-segment). These kernels do the same
arithmetic, term for term in the order the numpy expressions wrote it, in a handful of
compiled calls:

- ``turned``: q₁ = Cayley(h ω_m) q₀ in closed form (rodsim/solvers/physical/coordinates.py,
  ``cayley``), q_m = (q₀ + q₁)/2, |q_m| and the rows B_k q_m;
- ``path_state``: the model's state at a point s of the path (r₀ + s Δr,
  normalise(q₀ + s Δq)) with the unit quaternions and their norms;
- ``add_force``: the point's generalised force (f_r, τ) with τ_k = ½ a_k · (I − q̂q̂ᵀ) f_q / |q|,
  a_k = B_k q_m, times the point's weight, added to the sums;
- ``residual``: the step's residual ((2/h) M_r (v_m − v₀) − f̄_r,
  (2/h) I (ω_m − ω₀) + ω_m × I ω_m − τ̄);
- ``cayley_derivative`` and ``derivative_blocks``, at an iterate that makes a fresh Newton
  matrix: ∂q₁/∂ω_m and, at each Gauss point, the 4 × 3 blocks of G and P and the
  geometric blocks of the averaged force's derivative (rodsim/solvers/physical/midpoint.py,
  ``MidpointStep._averaged``). These sum the same products as the numpy expressions they
  replaced (round 21) in loop order, not numpy's: the Newton matrix moved by round-off,
  and a trajectory by up to 3e-14 m over a few hundred steps.

B_k q (rodsim/core/rod/quaternion.py's B, entries 0 and ±1) is written out as the signed
components of q that numpy's product picks.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["turned", "path_state", "add_force", "residual", "cayley_derivative",
           "derivative_blocks"]


@njit(cache=True, inline="always")
def _rows(q: np.ndarray, s: int, out: np.ndarray) -> None:
    """out[k, a] = (B_k q_s)_a (coordinates.velocity_rows for one segment)."""
    q0, q1, q2, q3 = q[s, 0], q[s, 1], q[s, 2], q[s, 3]
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = q3, q2, -q1, -q0
    out[1, 0], out[1, 1], out[1, 2], out[1, 3] = -q2, q3, q0, -q1
    out[2, 0], out[2, 1], out[2, 2], out[2, 3] = q1, -q0, q3, -q2


@njit(cache=True)
def turned(q0: np.ndarray, w: np.ndarray, h: float, q1: np.ndarray, qm: np.ndarray,
           norm: np.ndarray, rows: np.ndarray) -> None:
    """q₁ = ((1 − a²|w|²) q₀ + 2a Ω q₀)/(1 + a²|w|²), a = h/4, Ω q₀ = Σ_k w_k B_k q₀; the
    midpoint q_m = ½ (q₀ + q₁), its norm and rows[s, k] = B_k q_m, for quaternions ``q0``
    (s, 4) and rates ``w`` (s, 3)."""
    a = 0.25 * h
    local = np.empty((3, 4))
    for s in range(q0.shape[0]):
        squared = a * a * (w[s, 0] * w[s, 0] + w[s, 1] * w[s, 1] + w[s, 2] * w[s, 2])
        _rows(q0, s, local)
        for b in range(4):
            turn = local[0, b] * w[s, 0] + local[1, b] * w[s, 1] + local[2, b] * w[s, 2]
            q1[s, b] = ((1.0 - squared) * q0[s, b] + 2.0 * a * turn) / (1.0 + squared)
            qm[s, b] = 0.5 * (q0[s, b] + q1[s, b])
        norm[s] = np.sqrt(qm[s, 0] * qm[s, 0] + qm[s, 1] * qm[s, 1] + qm[s, 2] * qm[s, 2]
                          + qm[s, 3] * qm[s, 3])
        _rows(qm, s, rows[s])


@njit(cache=True)
def path_state(x0: np.ndarray, reference: np.ndarray, positions: np.ndarray,
               quaternions: np.ndarray, r0: np.ndarray, r1: np.ndarray, q0: np.ndarray,
               q1: np.ndarray, node: float, state: np.ndarray, unit: np.ndarray,
               norm: np.ndarray) -> None:
    """The model's state (free coordinates minus ``reference``) at the path's point
    ``node``: x₀ with positions r₀ + node (r₁ − r₀) and quaternions q̂ = q/|q|,
    q = q₀ + node (q₁ − q₀); ``unit`` and ``norm`` get q̂ and |q|."""
    for i in range(x0.shape[0]):
        state[i] = x0[i] - reference[i]
    for i in range(positions.shape[0]):
        j = positions[i]
        state[j] = (r0[i] + node * (r1[i] - r0[i])) - reference[j]
    q = np.empty(4)
    for s in range(quaternions.shape[0]):
        for b in range(4):
            q[b] = q0[s, b] + node * (q1[s, b] - q0[s, b])
        size = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        norm[s] = size
        for b in range(4):
            unit[s, b] = q[b] / size
            j = quaternions[s, b]
            state[j] = unit[s, b] - reference[j]


@njit(cache=True, inline="always")
def _across(f: np.ndarray, quaternions: np.ndarray, unit: np.ndarray, s: int,
            across: np.ndarray) -> float:
    """across = f_q − q̂ (q̂ · f_q) for segment ``s`` (f_q = f[quaternions[s]], q̂ =
    ``unit``[s]): the part of its quaternion force that turns it; returns q̂ · f_q."""
    pull = 0.0
    for b in range(4):
        pull += unit[s, b] * f[quaternions[s, b]]
    for b in range(4):
        across[b] = f[quaternions[s, b]] - unit[s, b] * pull
    return pull


@njit(cache=True)
def add_force(f: np.ndarray, positions: np.ndarray, quaternions: np.ndarray,
              unit: np.ndarray, norm: np.ndarray, rows: np.ndarray, weight: float,
              f_r: np.ndarray, tau: np.ndarray) -> None:
    """f_r += weight f[positions]; τ_k += weight ½ a_k · (f_q − q̂ (q̂ · f_q)) / |q| with
    a_k = ``rows``[s, k] (module docstring)."""
    for i in range(positions.shape[0]):
        f_r[i] += weight * f[positions[i]]
    across = np.empty(4)
    half = weight * 0.5
    for s in range(quaternions.shape[0]):
        _across(f, quaternions, unit, s, across)
        for k in range(3):
            moment = 0.0
            for b in range(4):
                moment += rows[s, k, b] * across[b]
            tau[s, k] += half * moment / norm[s]


@njit(cache=True)
def residual(indptr: np.ndarray, indices: np.ndarray, mass: np.ndarray, r0: np.ndarray,
             r1: np.ndarray, v0: np.ndarray, inertia: np.ndarray, w: np.ndarray,
             w0: np.ndarray, h: float, f_r: np.ndarray, tau: np.ndarray,
             out: np.ndarray) -> None:
    """The midpoint step's residual (module docstring) into ``out`` (p + 3 s): M_r by its
    CSR arrays, v_m = (r₁ − r₀)/h."""
    p = r0.shape[0]
    change = np.empty(p)
    for i in range(p):
        change[i] = (r1[i] - r0[i]) / h - v0[i]
    factor = 2.0 / h
    for i in range(p):
        total = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            total += mass[jj] * change[indices[jj]]
        out[i] = factor * total - f_r[i]
    for s in range(w.shape[0]):
        i0, i1, i2 = inertia[s, 0] * w[s, 0], inertia[s, 1] * w[s, 1], inertia[s, 2] * w[s, 2]
        cross = (w[s, 1] * i2 - w[s, 2] * i1, w[s, 2] * i0 - w[s, 0] * i2,
                 w[s, 0] * i1 - w[s, 1] * i0)
        for k in range(3):
            out[p + 3 * s + k] = (factor * inertia[s, k] * (w[s, k] - w0[s, k]) + cross[k]
                                  - tau[s, k])


@njit(cache=True)
def cayley_derivative(rows: np.ndarray, w: np.ndarray, h: float, out: np.ndarray) -> None:
    """∂q₁/∂ω_m = ((h/2) Aᵀ + (h/4) Ω (h/2) Aᵀ)/(1 + (h/4)² |ω_m|²) into ``out`` (s, 4, 3),
    A = ``rows``[s] (the rows B_k q_m, (s, 3, 4)), Ω = Σ_k w_k B_k: MidpointStep's
    closed form of (I − hΩ/4)⁻¹ (h/2) Aᵀ."""
    a = 0.25 * h
    half = 0.5 * h
    omega = np.empty((4, 4))
    for s in range(w.shape[0]):
        _omega(w, s, omega)
        scale = 1.0 + a * a * (w[s, 0] * w[s, 0] + w[s, 1] * w[s, 1] + w[s, 2] * w[s, 2])
        for b in range(4):
            for k in range(3):
                turn = 0.0
                for c in range(4):
                    turn += omega[b, c] * (half * rows[s, k, c])
                out[s, b, k] = (half * rows[s, k, b] + a * turn) / scale


@njit(cache=True, inline="always")
def _omega(w: np.ndarray, s: int, out: np.ndarray) -> None:
    """out = Σ_k w[s, k] B_k (rodsim/core/rod/quaternion.py's B written out)."""
    w0, w1, w2 = w[s, 0], w[s, 1], w[s, 2]
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = 0.0, w2, -w1, w0
    out[1, 0], out[1, 1], out[1, 2], out[1, 3] = -w2, 0.0, w0, w1
    out[2, 0], out[2, 1], out[2, 2], out[2, 3] = w1, -w0, 0.0, w2
    out[3, 0], out[3, 1], out[3, 2], out[3, 3] = -w0, -w1, -w2, 0.0


@njit(cache=True)
def derivative_blocks(f: np.ndarray, quaternions: np.ndarray, unit: np.ndarray,
                      norm: np.ndarray, rows: np.ndarray, dq1: np.ndarray, node: float,
                      g_blocks: np.ndarray, p_blocks: np.ndarray,
                      geometric: np.ndarray) -> None:
    """One Gauss point's blocks of the averaged force's derivative (MidpointStep._averaged):
    with q̂ = ``unit``[s], |q| = ``norm``[s], a_k = ``rows``[s, k], P = (I − q̂q̂ᵀ)/|q|,
    f_q = f[quaternions[s]] and D = ``dq1``[s] (∂q₁/∂ω_m):

        g_blocks[s] = ½ P Aᵀ,   p_blocks[s] = P (s D)   (s = ``node``),
        geometric[s]_kl = ½ (B_kᵀ P f · ½ D_l + t_k · s D_l),
        t_k = (−(a_k · q̂) f_q − (q̂ · f_q) a_k) (I − q̂q̂ᵀ)/|q|² − (a_k · P f |q|) q̂/|q|²,

    the torque's change through a_k (q_m moves by ½ D) and through q̂ and |q| (the path's
    point moves by s D) at fixed force."""
    across = np.empty(4)
    project = np.empty((4, 4))
    turned_row = np.empty(4)
    through = np.empty(4)
    for s in range(unit.shape[0]):
        nu = norm[s]
        pull = _across(f, quaternions, unit, s, across)
        for b in range(4):
            for c in range(4):
                identity = 1.0 if b == c else 0.0
                project[b, c] = identity - unit[s, b] * unit[s, c]
        for b in range(4):
            for k in range(3):
                g = 0.0
                p = 0.0
                for c in range(4):
                    g += project[b, c] * rows[s, k, c]
                    p += project[b, c] * dq1[s, c, k]
                g_blocks[s, b, k] = 0.5 * g / nu
                p_blocks[s, b, k] = node * p / nu
        for k in range(3):
            along = 0.0
            moment = 0.0
            for a in range(4):
                along += rows[s, k, a] * unit[s, a]
                moment += rows[s, k, a] * across[a]
            _transposed_b(k, across, turned_row)
            for c in range(4):
                total = 0.0
                for b in range(4):
                    total += (along * f[quaternions[s, b]] + pull * rows[s, k, b]) * project[b, c]
                through[c] = (-total - moment * unit[s, c]) / (nu * nu)
            for m in range(3):
                first = 0.0
                second = 0.0
                for a in range(4):
                    first += turned_row[a] / nu * (0.5 * dq1[s, a, m])
                    second += through[a] * (node * dq1[s, a, m])
                geometric[s, k, m] = 0.5 * (first + second)


@njit(cache=True, inline="always")
def _transposed_b(k: int, v: np.ndarray, out: np.ndarray) -> None:
    """out = B_kᵀ v (rodsim/core/rod/quaternion.py's B written out)."""
    if k == 0:
        out[0], out[1], out[2], out[3] = -v[3], -v[2], v[1], v[0]
    elif k == 1:
        out[0], out[1], out[2], out[3] = v[2], -v[3], -v[0], v[1]
    else:
        out[0], out[1], out[2], out[3] = -v[1], v[0], -v[3], v[2]
