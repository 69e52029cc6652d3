"""Contact kernel of the tube (rodsim/core/obstacles/tube.py): the node's nearest centerline
point found by a warm-started Newton walk along the rod (each node starts from the previous
node's parameter; the first from the nearest knot), then φ = R(u*) − |p − c(u*)| and its
derivatives (the formulas in the obstacle's module docstring). The same numbers as the numpy
reference; the law, friction and scatter are shared (rodsim/core/kernels/_contact.py)."""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._contact import add_node, node_energy, workspace

MAX_ITERATIONS = 40


@njit(cache=True)
def _piece(starts: np.ndarray, k: int, u: float) -> int:
    last = starts.shape[0] - 1
    while k < last and u >= starts[k + 1]:
        k += 1
    while k > 0 and u < starts[k]:
        k -= 1
    return k


@njit(cache=True)
def _curve(coef: np.ndarray, t: float, out: np.ndarray) -> None:
    """c, c', c'', c''' of the piece's cubic at local t into out (4, 3)."""
    for m in range(3):
        a0, a1, a2, a3 = coef[0, m], coef[1, m], coef[2, m], coef[3, m]
        out[0, m] = a0 + t * (a1 + t * (a2 + t * a3))
        out[1, m] = a1 + t * (2.0 * a2 + 3.0 * t * a3)
        out[2, m] = 2.0 * a2 + 6.0 * t * a3
        out[3, m] = 6.0 * a3


@njit(cache=True)
def _project(p: np.ndarray, u: float, k: int, step: float, starts: np.ndarray,
             coef: np.ndarray, cc: np.ndarray) -> tuple[float, int]:
    last = starts.shape[0] - 1
    for _ in range(MAX_ITERATIONS + last):
        _curve(coef[k], u - starts[k], cc)
        speed2 = 0.0
        rc2 = 0.0
        rc1 = 0.0
        for m in range(3):
            r = p[m] - cc[0, m]
            speed2 += cc[1, m] * cc[1, m]
            rc2 += r * cc[2, m]
            rc1 += r * cc[1, m]
        a = speed2 - rc2
        if a < 0.1 * speed2:
            a = speed2
        newton = rc1 / a
        if u < starts[0]:  # straight extension: Newton's exact step, stopped at the spline
            du = min(newton, starts[0] - u)
        elif u > starts[last]:
            du = max(newton, starts[last] - u)
        else:
            du = min(max(newton, -step), step)
        u += du
        k = _piece(starts, k, u)
        # Converged when Newton's own step is negligible, not the step taken: one stopped
        # at the spline's end a round-off away (a node 3e-17 m behind a csv vessel's start)
        # is tiny though the point lies a knot further on (issue 37: a 1 mm false
        # penetration, 3e6 times the load, stopped a guidewire's insertion at 0.02 m).
        if abs(newton) <= 1e-14 * step:
            break
    return u, k


@njit(cache=True)
def _gap(p: np.ndarray, step: float, u: float, k: int, starts: np.ndarray,
         coef: np.ndarray, rcoef: np.ndarray, cc: np.ndarray, grad: np.ndarray,
         hess: np.ndarray) -> tuple[float, float, int]:
    """φ at p, with ∇φ into grad and ∇²φ into hess (every entry); (u*, piece) for the next
    node."""
    u, k = _project(p, u, k, step, starts, coef, cc)
    t = u - starts[k]
    _curve(coef[k], t, cc)
    rc = rcoef[k]
    radius = rc[0] + t * (rc[1] + t * (rc[2] + t * rc[3]))
    r1 = rc[1] + t * (2.0 * rc[2] + 3.0 * t * rc[3])
    r2 = 2.0 * rc[2] + 6.0 * t * rc[3]
    r = np.empty(3)
    d = 0.0
    speed2 = 0.0
    rc2 = 0.0
    c1c2 = 0.0
    rc3 = 0.0
    for m in range(3):
        r[m] = p[m] - cc[0, m]
        d += r[m] * r[m]
        speed2 += cc[1, m] * cc[1, m]
        rc2 += r[m] * cc[2, m]
        c1c2 += cc[1, m] * cc[2, m]
        rc3 += r[m] * cc[3, m]
    d = max(np.sqrt(d), 1e-30)
    a = speed2 - rc2
    a_u = 3.0 * c1c2 - rc3
    for i in range(3):
        e_i = r[i] / d
        grad[i] = r1 * cc[1, i] / a - e_i
        for j in range(3):
            e_j = r[j] / d
            outer = cc[1, i] * cc[1, j]
            hess_d = ((1.0 if i == j else 0.0) - e_i * e_j - outer / a) / d
            hess_u = ((cc[2, i] * cc[1, j] + cc[1, i] * cc[2, j]) / (a * a)
                      - a_u / (a * a * a) * outer)
            hess[i, j] = r2 * outer / (a * a) + r1 * hess_u - hess_d
    return radius - d, u, k


@njit(cache=True)
def _start(p: np.ndarray, starts: np.ndarray, coef: np.ndarray) -> tuple[float, int]:
    """The first node's start: the nearest spline knot (pieces 1..m start at the knots)."""
    best = 1e300
    k_best = 1
    for k in range(1, starts.shape[0] - 1):
        d = 0.0
        for m in range(3):
            d += (p[m] - coef[k, 0, m]) ** 2
        if d < best:
            best = d
            k_best = k
    return starts[k_best], k_best


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, step: float, starts: np.ndarray,
             coef: np.ndarray, rcoef: np.ndarray, radius: float, stiffness: float,
             delta: float, friction: float, slip: float, anchors: np.ndarray, scale: float,
             want_force: bool, force: np.ndarray, force_target: np.ndarray,
             want_jacobian: bool, jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    p, grad, hess, local, block = workspace()
    cc = np.empty((4, 3))
    for m in range(3):
        p[m] = x[dofs[0, m]]
    u, k = _start(p, starts, coef)
    for e in range(dofs.shape[0]):
        for m in range(3):
            p[m] = x[dofs[e, m]]
        phi, u, k = _gap(p, step, u, k, starts, coef, rcoef, cc, grad, hess)
        add_node(e, p, phi, grad, hess, radius, stiffness, delta, friction, slip, anchors,
                 scale, want_force, force, force_target, want_jacobian, jacobian,
                 jacobian_target, local, block)


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, step: float, starts: np.ndarray,
           coef: np.ndarray, rcoef: np.ndarray, radius: float, stiffness: float,
           delta: float, friction: float, slip: float, anchors: np.ndarray) -> float:
    """The normal penalty's energy; friction has none (the model never asks a frictional
    term for its energy: it is not conservative)."""
    p, grad, hess, _, _ = workspace()
    cc = np.empty((4, 3))
    for m in range(3):
        p[m] = x[dofs[0, m]]
    u, k = _start(p, starts, coef)
    total = 0.0
    for e in range(dofs.shape[0]):
        for m in range(3):
            p[m] = x[dofs[e, m]]
        phi, u, k = _gap(p, step, u, k, starts, coef, rcoef, cc, grad, hess)
        total += node_energy(phi, radius, delta)
    return stiffness * total
