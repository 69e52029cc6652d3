"""The paper's analytical model, Eqs. (21)-(23), by quadrature, with Eq. (22) corrected.

With phi the downward slope angle and phi0 its tip value, the first integral of
EI phi'' = -F cos(phi) with phi'(L) = 0 is EI phi'^2 / 2 = F (sin(phi0) - sin(phi)), so

    ds = sqrt(EI / (2F)) dphi / sqrt(sin(phi0) - sin(phi)).

Integrating ds over [0, phi0] gives Eq. (21), int_0^phi0 dphi / sqrt(...) = 2 sqrt(alpha)
with alpha = F L^2 / (2 EI). dy = sin(phi) ds gives Eq. (23) (downward deflection). With
dx = cos(phi) ds and v = sin(phi), dv = cos(phi) dphi:

    x(phi) = sqrt(EI/(2F)) int_0^sin(phi) dv / sqrt(sin(phi0) - v)
           = sqrt(2EI/F) (sqrt(sin(phi0)) - sqrt(sin(phi0) - sin(phi))).   (corrected Eq. 22)

The paper prints sqrt(sin(phi0)) - sqrt(sin(phi)), which is x(phi0) at the clamp and 0 at
the tip (docs/design.md, erratum 9); ``paper_model_as_printed`` keeps it to show the erratum.

The integrands of (21) and (23) have a 1/sqrt singularity at phi = phi0. The substitution
sin(phi0) - sin(phi) = w^2 removes it, since 1 - (sin(phi0) - w^2)^2 = (eps + w^2)(1 + sin(phi))
with eps = 1 - sin(phi0); a second one, w = sqrt(eps) sinh(t), removes the peak of width
sqrt(eps) that the first leaves at w = 0 when phi0 -> 90 deg. Then

    dphi / sqrt(sin(phi0) - sin(phi)) = -2 dt / sqrt(1 + sin(phi)),  sin(phi) = sin(phi0) - w^2,

a smooth integrand on t in [0, asinh(sqrt(sin(phi0) / eps))] that ``scipy.integrate.quad``
integrates to ~1e-14 relative accuracy for any load.
"""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

from rodsim.core.analytic.elastica import (
    _SMALLEST_BETA,
    ElasticaShape,
    load_parameter,
    validate_cantilever,
)

_QUAD_OPTIONS = {"epsabs": 0.0, "epsrel": 1e-13, "limit": 200}


class _TipAngle:
    """Tip angle phi0 with sin(phi0) and eps = 1 - sin(phi0) computed without cancellation."""

    def __init__(self, phi0: float, beta: float) -> None:
        self.phi0 = phi0  # beta = pi/2 - phi0, the unknown when phi0 is near 90 deg
        self.sin_phi0 = math.sin(phi0) if phi0 <= beta else math.cos(beta)
        self.eps = 2.0 * math.sin(0.5 * beta) ** 2

    def w_squared(self, t: float) -> float:
        return self.eps * math.sinh(t) ** 2

    def w_of_phi(self, phi: np.ndarray) -> np.ndarray:
        """w = sqrt(sin(phi0) - sin(phi)), from 2 cos((phi0 + phi)/2) sin((phi0 - phi)/2)."""
        w2 = 2.0 * np.cos(0.5 * (self.phi0 + phi)) * np.sin(0.5 * (self.phi0 - phi))
        return np.sqrt(np.maximum(w2, 0.0))

    def t_of_phi(self, phi: np.ndarray) -> np.ndarray:
        """t = asinh(w / sqrt(eps)), the integration variable of Eqs. (21) and (23)."""
        return np.arcsinh(self.w_of_phi(phi) / math.sqrt(self.eps))

    def arc_integrand(self, t: float) -> float:
        """2 / sqrt(1 + sin(phi)): the integrand of Eq. (21) in the variable t."""
        return 2.0 / math.sqrt(1.0 + self.sin_phi0 - self.w_squared(t))

    def drop_integrand(self, t: float) -> float:
        """2 sin(phi) / sqrt(1 + sin(phi)): the integrand of Eq. (23) in the variable t."""
        sin_phi = self.sin_phi0 - self.w_squared(t)
        return 2.0 * sin_phi / math.sqrt(1.0 + sin_phi)

    def span_integral(self) -> float:
        """Left-hand integral of Eq. (21), int_0^phi0 dphi / sqrt(sin(phi0) - sin(phi))."""
        t_clamp = math.asinh(math.sqrt(self.sin_phi0 / self.eps))
        return quad(self.arc_integrand, 0.0, t_clamp, **_QUAD_OPTIONS)[0]


def _solve_tip_angle(alpha: float) -> _TipAngle:
    """Root of Eq. (21) in phi0 (phi0 <= pi/4) or in beta = pi/2 - phi0 (phi0 > pi/4)."""
    target = 2.0 * math.sqrt(alpha)
    quarter = 0.25 * math.pi

    def by_phi0(phi0: float) -> float:
        return _TipAngle(phi0, 0.5 * math.pi - phi0).span_integral() - target

    def by_beta(beta: float) -> float:
        return _TipAngle(0.5 * math.pi - beta, beta).span_integral() - target

    if alpha == 0.0:
        return _TipAngle(0.0, 0.5 * math.pi)
    if by_phi0(quarter) >= 0.0:
        phi0 = brentq(by_phi0, 0.0, quarter, xtol=1e-300, maxiter=500)
        return _TipAngle(phi0, 0.5 * math.pi - phi0)
    # As phi0 -> 90 deg the integral ~ sqrt(2) (ln(8 / beta) - asinh(1)): bracket beta from it.
    beta_lo = min(quarter, 8.0 * math.exp(-math.asinh(1.0) - math.sqrt(2.0 * alpha)))
    while beta_lo < _SMALLEST_BETA or by_beta(beta_lo) < 0.0:
        if beta_lo < _SMALLEST_BETA:
            raise ValueError(f"load parameter alpha = {alpha:.6g} is too large to resolve phi0")
        beta_lo *= 0.25
    beta = brentq(by_beta, beta_lo, quarter, xtol=1e-300, maxiter=500)
    return _TipAngle(0.5 * math.pi - beta, beta)


def tip_angle_from_load(alpha: float) -> float:
    """Solve Eq. (21) for the tip angle phi0 given the load parameter alpha.

    The paper tabulates alpha(phi0) and looks phi0 up; here Brent's method finds the root of
    int_0^phi0 dphi / sqrt(sin(phi0) - sin(phi)) - 2 sqrt(alpha) to machine precision.

    Parameters
    ----------
    alpha : float
        Load parameter alpha = F L^2 / (2 EI) >= 0 [-].

    Returns
    -------
    float
        Tip angle phi0 in [0, pi/2) [rad], positive downward.

    Raises
    ------
    ValueError
        If alpha is negative, NaN or infinite.
    """
    alpha = float(alpha)
    if not math.isfinite(alpha) or alpha < 0.0:
        raise ValueError(f"alpha must be finite and >= 0, got {alpha}")
    return _solve_tip_angle(alpha).phi0


def _sample(
    force: float, EI: float, length: float, n: int
) -> tuple[_TipAngle, np.ndarray, np.ndarray, np.ndarray, float]:
    """Tip angle, phi samples, s(phi) and the downward deflection of Eq. (23), all at n points."""
    if isinstance(n, bool) or int(n) != n or n < 2:
        raise ValueError(f"n must be an integer >= 2, got {n}")
    n = int(n)
    force, EI, length = validate_cantilever(force, EI, length)
    alpha = load_parameter(force, EI, length)
    tip = _solve_tip_angle(alpha)
    phi = np.linspace(0.0, tip.phi0, n)
    if force == 0.0:
        return tip, phi, np.linspace(0.0, length, n), np.zeros(n), 0.0
    half_scale = math.sqrt(EI / (2.0 * force))
    t = tip.t_of_phi(phi)  # decreasing from t(0) at the clamp to 0 at the tip
    segments = list(pairwise(t))
    ds = np.array([quad(tip.arc_integrand, b, a, **_QUAD_OPTIONS)[0] for a, b in segments])
    dy = np.array([quad(tip.drop_integrand, b, a, **_QUAD_OPTIONS)[0] for a, b in segments])
    s = half_scale * np.concatenate(([0.0], np.cumsum(ds)))
    drop = half_scale * np.concatenate(([0.0], np.cumsum(dy)))
    return tip, phi, s, drop, math.sqrt(2.0 * EI / force)


def paper_model(force: float, EI: float, length: float, n: int = 201) -> ElasticaShape:
    """The paper's analytical model, Eqs. (21)-(23), with Eq. (22) corrected.

    phi0 is the root of Eq. (21) (``tip_angle_from_load``); the shape is sampled at n
    points uniform in phi in [0, phi0]; s(phi) = sqrt(EI/(2F)) int_0^phi dphi' /
    sqrt(sin(phi0) - sin(phi')) and Eq. (23) are integrated with ``quad`` after the
    substitutions of the module docstring, and x follows the corrected Eq. (22),

        x(phi) = sqrt(2EI/F) (sqrt(sin(phi0)) - sqrt(sin(phi0) - sin(phi))).

    The result can be compared point by point with ``exact_elastica`` at the same s.

    Parameters
    ----------
    force : float
        Tip load F >= 0 [N], acting along -y.
    EI : float
        Bending stiffness [N m^2].
    length : float
        Rod length L [m].
    n : int, optional
        Number of samples (>= 2).

    Returns
    -------
    ElasticaShape
        World coordinates (y <= 0), ``s`` from the arc-length integral (s[-1] = L to
        quadrature accuracy), and the tip angle phi0 [rad].

    Raises
    ------
    ValueError
        For negative, NaN or infinite inputs, non-positive EI or L, or n < 2.
    """
    tip, phi, s, drop, scale = _sample(force, EI, length, n)
    if scale == 0.0:
        return ElasticaShape(s=s, x=s.copy(), y=-drop, tip_angle=0.0)
    # sqrt(sin phi0) - w = sin(phi) / (sqrt(sin phi0) + w): no cancellation near the clamp
    x = scale * np.sin(phi) / (math.sqrt(tip.sin_phi0) + tip.w_of_phi(phi))
    return ElasticaShape(s=s, x=x, y=-drop, tip_angle=tip.phi0)


def paper_model_as_printed(force: float, EI: float, length: float, n: int = 201) -> ElasticaShape:
    """The analytical model with Eq. (22) exactly as printed (wrong; for the erratum only).

    x(phi) = sqrt(2EI/F) (sqrt(sin(phi0)) - sqrt(sin(phi))) equals the tip's x at the clamp
    (phi = 0) and 0 at the tip, so the curve runs backwards in x while its span and Eq. (23)'s
    tip deflection are right. Kept so that tests and docs/analytic.md can show the error.

    Parameters
    ----------
    force, EI, length, n
        As for ``paper_model``.

    Returns
    -------
    ElasticaShape
        Same ``s``, ``y`` and tip angle as ``paper_model``; ``x`` from the printed Eq. (22).
    """
    tip, phi, s, drop, scale = _sample(force, EI, length, n)
    if scale == 0.0:
        return ElasticaShape(s=s, x=s.copy(), y=-drop, tip_angle=0.0)
    x = scale * (math.sqrt(tip.sin_phi0) - np.sqrt(np.sin(phi)))
    return ElasticaShape(s=s, x=x, y=-drop, tip_angle=tip.phi0)
