"""Extensible, unshearable (Kirchhoff) planar elastica under a constant tip force.

Unknowns: the tangent angle theta(s) (from +x, counter-clockwise positive) and the
centreline r(s), s in [0, L] the rest arc length. With no distributed load the internal force
(exerted on [0, s] by (s, L]) is constant, n = F = (Fx, Fy). Linear constitutive laws

    n . t = EA (lambda - 1),   m = EI theta',   t = (cos theta, sin theta),

give the stretch lambda = 1 + (F . t) / EA and r' = lambda t. The moment balance
m' + (r' x n)_z = 0 then reads

    EI theta'' = -lambda (t x F)_z = -lambda (Fy cos theta - Fx sin theta),

with theta(0) = 0, r(0) = 0 (clamp) and theta'(L) = 0 (no tip moment). For F = (0, -F) and
EA = inf this is the paper's EI phi'' = -F cos(phi) with phi = -theta (Eqs. 21-23).
Integrating m' = -(r' x F)_z over [0, L] gives the global equilibrium used as a check:

    EI theta'(0) = m(0) = (r(L) x F)_z.

The theta equation does not involve r. On the primary branch (the one connected to the
unloaded rod) theta is monotone between 0 and its tip value theta_L, which lies strictly
between 0 and the force direction theta_F = atan2(Fy, Fx). The problem is therefore solved by
shooting from the tip: theta(L) = theta_L, theta'(L) = 0, integrated towards the clamp with
DOP853 (rtol 1e-13) until theta = 0. The rest length S(theta_L) this takes runs from 0
(theta_L = 0) to infinity (theta_L -> theta_F, the rod aligned with the force), so
S(theta_L) = L is bracketed; Brent's method solves it for delta = theta_F - theta_L, which
keeps full relative precision when the rod nearly aligns with the force. The shape is then
integrated from the tip to the clamp, the stable direction when the rod hangs along the force.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from rodsim.core.analytic.elastica import ElasticaShape, _positive, arc_length_samples

_RTOL = 1e-13
_ATOL = 1e-14


@dataclass(frozen=True, eq=False)
class ExtensibleShape(ElasticaShape):
    """An ``ElasticaShape`` that also carries the tangent angle and the curvature.

    Attributes
    ----------
    theta : numpy.ndarray
        Tangent angle from +x, counter-clockwise positive [rad].
    curvature : numpy.ndarray
        theta'(s) per unit rest length [1/m]; the bending moment is EI * curvature [N m].
    """

    theta: np.ndarray
    curvature: np.ndarray

    _array_fields: ClassVar[tuple[str, ...]] = ("s", "x", "y", "theta", "curvature")


@dataclass(frozen=True)
class _Load:
    """Dimensionless tip load: f = F L^2 / EI and e = F / EA (zero for EA = inf)."""

    fx: float
    fy: float
    ex: float
    ey: float

    def rhs(self, _: float, z: np.ndarray) -> list[float]:
        """d/dsigma of (theta, kappa, X, Y); sigma = s/L, kappa = L theta', (X, Y) = r/L."""
        c, s = math.cos(z[0]), math.sin(z[0])
        stretch = 1.0 + self.ex * c + self.ey * s
        return [z[1], -stretch * (self.fy * c - self.fx * s), stretch * c, stretch * s]

    def clamp_miss(self, theta_tip: float) -> float:
        """S(theta_L)/L - 1, from the tip (theta_L, kappa = 0) integrated back to theta = 0.

        If theta reaches 0 at sigma_0 >= 0 the miss is -sigma_0; otherwise it is
        theta(0) / theta'(0) (in sigma units), which continues it linearly through the root.
        """

        def reaches_clamp_angle(_: float, z: np.ndarray) -> float:
            return z[0]

        reaches_clamp_angle.terminal = True  # type: ignore[attr-defined]
        sol = solve_ivp(
            lambda t, z: self.rhs(t, z)[:2],
            (1.0, 0.0),
            [theta_tip, 0.0],
            method="DOP853",
            rtol=_RTOL,
            atol=_ATOL,
            events=reaches_clamp_angle,
        )
        if not sol.success:
            raise RuntimeError(f"integration of the extensible elastica failed: {sol.message}")
        if sol.t_events[0].size:
            return -float(sol.t_events[0][0])
        return float(sol.y[0, -1] / sol.y[1, -1])


def _solve_tip_angle(load: _Load) -> float:
    """theta_L on the branch connected to the unloaded rod (0 when Fy = 0: straight rod)."""
    if load.fy == 0.0:
        return 0.0
    theta_force = math.atan2(load.fy, load.fx)
    sign = math.copysign(1.0, theta_force)

    def miss(delta: float) -> float:
        return load.clamp_miss(theta_force - sign * delta)

    span = abs(theta_force)
    delta_lo = 1e-3 * span
    while miss(delta_lo) <= 0.0:
        delta_lo *= 1e-3
        if delta_lo < 1e-14 * span:
            raise ValueError("tip force too large: the rod aligns with it to machine precision")
    delta = brentq(miss, delta_lo, span, xtol=1e-300, maxiter=500)
    return theta_force - sign * delta


def extensible_elastica(
    force_xy: ArrayLike,
    EI: float,
    EA: float,
    length: float,
    s: np.ndarray | None = None,
) -> ExtensibleShape:
    """Extensible, unshearable planar elastica of a cantilever under a dead tip force.

    Solves EI theta'' = -lambda (Fy cos theta - Fx sin theta), r' = lambda t, lambda =
    1 + (F . t) / EA, theta(0) = 0, theta'(L) = 0, r(0) = 0 by shooting (see the module
    docstring) to ~1e-12 relative accuracy. For F = (0, -F) and EA = inf it is the exact
    elastica of ``rodsim.core.analytic.exact_elastica`` and the paper's Eqs. (21)-(23).

    Parameters
    ----------
    force_xy : array_like, shape (2,)
        Constant tip force (Fx, Fy) [N] in world coordinates (gravity-like loads: Fy < 0).
    EI : float
        Bending stiffness [N m^2].
    EA : float
        Axial stiffness [N]; ``numpy.inf`` gives the inextensible rod.
    length : float
        Rest length L [m].
    s : array_like, optional
        Rest arc lengths in [0, L] at which to return the shape [m]. Default: 201 points
        uniformly spaced on [0, L].

    Returns
    -------
    ExtensibleShape
        World coordinates, tangent angle, curvature theta' [1/m], and
        ``tip_angle = -theta(L)`` [rad] (positive downward, as for the other references).

    Raises
    ------
    ValueError
        If the force is not two finite numbers, EI, EA or L is not positive or is NaN,
        ``s`` lies outside [0, L], |F| >= EA (the stretch would not stay positive), or the
        load is so large that the tip aligns with it to machine precision.
    RuntimeError
        If the ODE integrator fails.

    Notes
    -----
    A purely axial force (Fy = 0) gives the straight rod, stretched by lambda = 1 + Fx/EA;
    under compression that is the primary branch even beyond the buckling load.
    """
    force = np.array(force_xy, dtype=float)
    if force.shape != (2,) or not np.all(np.isfinite(force)):
        raise ValueError(f"force_xy must be two finite numbers (Fx, Fy), got {force_xy!r}")
    EI, length = _positive("EI", EI), _positive("length", length)
    EA = float(EA)
    if math.isnan(EA) or EA <= 0.0:
        raise ValueError(f"EA must be > 0 (numpy.inf for an inextensible rod), got {EA}")
    s = arc_length_samples(s, length)
    if float(np.hypot(*force)) >= EA:
        raise ValueError("the tip force must be smaller than EA (the stretch must stay > 0)")
    f = force * length**2 / EI
    e = force / EA
    load = _Load(float(f[0]), float(f[1]), float(e[0]), float(e[1]))
    theta_tip = _solve_tip_angle(load)

    # integrate from the tip to the clamp, through every requested sample and sigma = 0
    sigma = np.unique(np.append(s / length, 0.0))[::-1]
    sol = solve_ivp(
        load.rhs,
        (1.0, 0.0),
        [theta_tip, 0.0, 0.0, 0.0],
        method="DOP853",
        rtol=_RTOL,
        atol=_ATOL,
        t_eval=sigma,
    )
    if not sol.success:
        raise RuntimeError(f"integration of the extensible elastica failed: {sol.message}")
    theta, kappa, x, y = sol.y[:, sigma.size - 1 - np.searchsorted(sigma[::-1], s / length)]
    x0, y0 = sol.y[2, -1], sol.y[3, -1]
    return ExtensibleShape(
        s=s,
        x=length * (x - x0),
        y=length * (y - y0),
        tip_angle=-theta_tip,
        theta=theta,
        curvature=kappa / length,
    )
