"""Compiled gradients of a string tendon's turning angles and their coupling into the
Jacobian of its span element (rodsim/core/kernels/tendon_string_span.py).

The turns' gradients are rodsim/core/turn_gradient.py's functions, compiled here as they
are written (each function's own code, its helpers replaced in its globals by their
compiled versions): one source for the numpy reference and the kernel. This module adds
the entry's frame with its derivatives (``entry_frame``) and the running sums of
``rodsim.core.terms._string_span.turn_coupling`` (``turn_coupling``).
"""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit

from rodsim.core import turn_gradient as _reference
from rodsim.core.kernels.tendon_string_path import entry_quaternion
from rodsim.core.turn_gradient import WINDOW

#: The reference's functions, compiled in the order each one's helpers need.
_ORDER = ("_cross", "_dot", "angle_gradient", "extrapolated", "unit_back", "_ramp",
          "_weight", "_entry", "_split", "turn_gradients")


def _compiled() -> dict[str, Any]:
    """Each function of ``_ORDER`` compiled with the compiled versions of the ones before
    it (and the reference's constants) in its globals."""
    namespace: dict[str, Any] = dict(vars(_reference))
    for name in _ORDER:
        function: Callable[..., Any] = getattr(_reference, name)
        copy = types.FunctionType(function.__code__, namespace, name,
                                  function.__defaults__, function.__closure__)
        copy.__qualname__ = f"compiled_{name}"
        namespace[name] = njit(cache=True)(copy)
    return namespace


_COMPILED = _compiled()
turn_gradients = _COMPILED["turn_gradients"]


@njit(cache=True)
def entry_frame(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
                entry_forms: np.ndarray, entry_slope: np.ndarray, axis: np.ndarray,
                tangent: np.ndarray, jacobian: np.ndarray) -> None:
    """d3 and t_in at the entry point into ``axis`` and ``tangent`` (as ``_tensions``
    computes them) and ∂d3/∂x, ∂t_in/∂x on chord 0's coordinates into ``jacobian``
    (2, 3, 28; zero where the entry's frame is held): d_k[m] = qᵀ A_km q / n,
    ∂d_k[m]/∂q = 2 (A_km q − d_k[m] q)/n, t_in = a/|a|, a = d3 + ρ′_y d1 + ρ′_z d2."""
    w0, w1 = weights[0, 2], weights[0, 3]
    q = np.empty(4)
    n = entry_quaternion(x, dofs, weights, constant, q)
    d = np.empty((3, 3))
    dq = np.empty((3, 3, 4))
    for k in range(3):
        for m in range(3):
            value = 0.0
            for i in range(4):
                row = 0.0
                for j in range(4):
                    row += entry_forms[k, m, i, j] * q[j]
                dq[k, m, i] = row
                value += q[i] * row
            d[k, m] = value / n
            for i in range(4):
                dq[k, m, i] = 2.0 * (dq[k, m, i] - d[k, m] * q[i]) / n
    raw = np.empty(3)
    for m in range(3):
        axis[m] = d[2, m]
        raw[m] = d[2, m] + entry_slope[0] * d[0, m] + entry_slope[1] * d[1, m]
    size = np.sqrt(raw[0] * raw[0] + raw[1] * raw[1] + raw[2] * raw[2])
    for m in range(3):
        tangent[m] = raw[m] / size
    jacobian[:] = 0.0
    if w0 == 0.0 and w1 == 0.0:
        return
    for i in range(4):
        along = 0.0
        d_raw = np.empty(3)
        for m in range(3):
            d_raw[m] = dq[2, m, i] + entry_slope[0] * dq[0, m, i] + entry_slope[1] * dq[1, m, i]
            along += tangent[m] * d_raw[m]
        for m in range(3):
            d_tangent = (d_raw[m] - tangent[m] * along) / size
            jacobian[0, m, 6 + i] = w0 * dq[2, m, i]
            jacobian[0, m, 10 + i] = w1 * dq[2, m, i]
            jacobian[1, m, 6 + i] = w0 * d_tangent
            jacobian[1, m, 10 + i] = w1 * d_tangent


@njit(cache=True)
def turn_coupling(slide: np.ndarray, mu_in: np.ndarray, mu_out: np.ndarray,
                  near: np.ndarray, entry: np.ndarray, u: np.ndarray, jd: np.ndarray,
                  length: np.ndarray, entry_jacobian: np.ndarray, chord_local: np.ndarray,
                  out: np.ndarray) -> None:
    """out (m, m) += Σ_e f_e ⊗ σ_e Σ_{j≤e} μ_j ∂θ_j/∂x, f_e = −Jd_eᵀ u_e
    (``rodsim.core.terms._string_span.turn_coupling``, whose arguments these are, with the
    chords' Jd (E, 3, 28)): the running sums of each side in one pass, O(E m)."""
    chords = slide.shape[0]
    m = out.shape[0]
    running_in = np.zeros(m)
    running_out = np.zeros(m)
    turn = np.zeros(m)
    moves = np.empty((chords, 3, 28))
    for i in range(chords):
        for a in range(28):
            along = u[i, 0] * jd[i, 0, a] + u[i, 1] * jd[i, 1, a] + u[i, 2] * jd[i, 2, a]
            for k in range(3):
                moves[i, k, a] = (jd[i, k, a] - u[i, k] * along) / length[i]
    for e in range(chords):
        turn[:] = 0.0
        for r in range(WINDOW):
            i = e - 3 + r
            if i < 0 or i >= chords:
                continue
            g0, g1, g2 = near[e, r, 0], near[e, r, 1], near[e, r, 2]
            if g0 == 0.0 and g1 == 0.0 and g2 == 0.0:
                continue
            for a in range(28):
                turn[chord_local[i, a]] += (g0 * moves[i, 0, a] + g1 * moves[i, 1, a]
                                            + g2 * moves[i, 2, a])
        if e == 0:
            for a in range(28):
                value = 0.0
                for k in range(3):
                    value += (entry[0, k] * entry_jacobian[0, k, a]
                              + entry[1, k] * entry_jacobian[1, k, a])
                turn[chord_local[0, a]] += value
        for b in range(m):
            running_in[b] += mu_in[e] * turn[b]
            running_out[b] += mu_out[e] * turn[b]
        sigma = slide[e]
        if sigma == 0.0:
            continue
        running = running_in if sigma < 0.0 else running_out
        for a in range(28):
            f = -(jd[e, 0, a] * u[e, 0] + jd[e, 1, a] * u[e, 1] + jd[e, 2, a] * u[e, 2])
            if f == 0.0:
                continue
            row = chord_local[e, a]
            for b in range(m):
                out[row, b] += sigma * f * running[b]
