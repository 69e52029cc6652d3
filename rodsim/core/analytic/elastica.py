"""Exact inextensible elastica of a cantilever under a dead tip load, by elliptic integrals.

Conventions: the rod is clamped at the origin and points along +x when unloaded; the tip
load F > 0 [N] acts along -y (fixed direction). phi(s) is the downward slope angle,
s in [0, L] is the arc length, and positions are returned in world coordinates (y <= 0).

Moment balance about a point of the centreline gives EI phi'(s) = F (x(L) - x(s)), hence

    EI phi'' = -F cos(phi),   phi(0) = 0,   phi'(L) = 0,

the same problem the paper's analytical model, Eqs. (21)-(23), solves by quadrature. The
substitution 1 + sin(phi) = 2 k^2 sin^2(psi), k^2 = (1 + sin(phi0)) / 2, maps the clamp to
sin(psi1) = 1 / (k sqrt(2)) and the tip to psi = pi/2, and turns the first integral
EI phi'^2 / 2 = F (sin(phi0) - sin(phi)) into

    ds = sqrt(EI/F) dpsi / sqrt(1 - k^2 sin^2(psi)),
    L sqrt(F/EI) = K(k) - F(psi1, k)                      (Eq. 21 in elliptic form),
    x = 2 k sqrt(EI/F) (cos(psi1) - cos(psi)),            (corrected Eq. 22)
    -y = sqrt(EI/F) [F(psi, k) - 2 E(psi, k)] from psi1 to psi      (Eq. 23).

At a given s, psi = am(F(psi1, k) + s sqrt(F/EI), k) is the Jacobi amplitude. scipy's
elliptic functions take the parameter m = k^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipeinc, ellipj, ellipkinc, ellipkm1

DEFAULT_SAMPLES = 201
"""Number of arc-length samples on [0, L] when ``s`` is not given."""

_SMALLEST_BETA = 1e-150
"""Smallest pi/2 - phi0 [rad] that is resolved (alpha up to ~6e4); 1 - k^2 underflows below."""


@dataclass(frozen=True, eq=False)
class ElasticaShape:
    """A planar rod centreline sampled along its rest arc length.

    Attributes
    ----------
    s : numpy.ndarray
        Rest arc length of the samples [m].
    x, y : numpy.ndarray
        World coordinates of the centreline at ``s`` [m]; y <= 0 for a downward bend.
    tip_angle : float
        Rotation of the tip tangent [rad], positive downward (the paper's phi0).
    """

    s: np.ndarray
    x: np.ndarray
    y: np.ndarray
    tip_angle: float

    _array_fields: ClassVar[tuple[str, ...]] = ("s", "x", "y")

    def __post_init__(self) -> None:
        arrays = {}
        for name in self._array_fields:
            value = np.array(getattr(self, name), dtype=float)
            if value.ndim != 1:
                raise ValueError(f"{name} must be one-dimensional, got shape {value.shape}")
            value.setflags(write=False)
            arrays[name] = value
        if len({value.shape for value in arrays.values()}) != 1:
            raise ValueError(f"{', '.join(self._array_fields)} must have the same length")
        for name, value in arrays.items():
            object.__setattr__(self, name, value)
        object.__setattr__(self, "tip_angle", float(self.tip_angle))

    @property
    def tip(self) -> np.ndarray:
        """Position (x, y) of the last sample [m]: the tip when ``s`` ends at L."""
        return np.array([self.x[-1], self.y[-1]])


def _finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    return value


def _positive(name: str, value: float) -> float:
    value = _finite(name, value)
    if value <= 0.0:
        raise ValueError(f"{name} must be > 0, got {value}")
    return value


def validate_cantilever(force: float, EI: float, length: float) -> tuple[float, float, float]:
    """Check and convert the inputs shared by the cantilever references.

    Parameters
    ----------
    force : float
        Tip load magnitude F >= 0 [N] (acting along -y).
    EI : float
        Bending stiffness > 0 [N m^2].
    length : float
        Rod length L > 0 [m].

    Returns
    -------
    tuple of float
        ``(force, EI, length)`` as floats.

    Raises
    ------
    ValueError
        If any input is NaN or infinite, the force is negative, or EI or L is not positive.
    """
    force = _finite("force", force)
    if force < 0.0:
        raise ValueError(f"force must be >= 0 (it acts along -y), got {force}")
    return force, _positive("EI", EI), _positive("length", length)


def arc_length_samples(s: np.ndarray | None, length: float) -> np.ndarray:
    """Return the requested arc-length samples, or ``DEFAULT_SAMPLES`` points on [0, L].

    Raises
    ------
    ValueError
        If ``s`` is not a finite one-dimensional array inside [0, L] (samples within 1e-12 L
        outside it are clipped onto it).
    """
    if s is None:
        return np.linspace(0.0, length, DEFAULT_SAMPLES)
    s = np.array(s, dtype=float)
    if s.ndim != 1 or s.size == 0:
        raise ValueError("s must be a non-empty one-dimensional array")
    if not np.all(np.isfinite(s)):
        raise ValueError("s must be finite")
    slack = 1e-12 * length  # so that s from a quadrature (s[-1] = L + rounding) is accepted
    if s.min() < -slack or s.max() > length + slack:
        raise ValueError(f"s must lie in [0, L] = [0, {length}]")
    return np.clip(s, 0.0, length)


def load_parameter(force: float, EI: float, length: float) -> float:
    """Dimensionless load parameter alpha = F L^2 / (2 EI) of Eq. (21).

    The paper prints alpha = F L^2 / (2 E L); the denominator is 2 E I (docs/design.md, erratum 2).

    Parameters
    ----------
    force : float
        Tip load F >= 0 [N].
    EI : float
        Bending stiffness [N m^2].
    length : float
        Rod length L [m].

    Returns
    -------
    float
        alpha [-].
    """
    force, EI, length = validate_cantilever(force, EI, length)
    return force * length**2 / (2.0 * EI)


@dataclass(frozen=True)
class _Modulus:
    """Tip angle phi0 and its complement beta = pi/2 - phi0, each computed accurately."""

    phi0: float
    beta: float

    @property
    def sin_phi0(self) -> float:
        return math.sin(self.phi0) if self.phi0 <= self.beta else math.cos(self.beta)

    @property
    def m1(self) -> float:
        """Complementary parameter 1 - k^2 = (1 - sin(phi0)) / 2 = sin^2(beta / 2)."""
        return math.sin(0.5 * self.beta) ** 2

    @property
    def psi1(self) -> float:
        """Amplitude at the clamp: tan(psi1) = 1 / sqrt(sin(phi0))."""
        return math.atan2(1.0, math.sqrt(self.sin_phi0))

    def span_integral(self) -> float:
        """K(k) - F(psi1, k) = L sqrt(F/EI), without cancellation at either end.

        F(psi1) + F(chi1) = K when tan(psi1) tan(chi1) = 1/k', so K - F(psi1) = F(chi1)
        with tan(chi1) = sqrt(sin(phi0) / m1). The smaller incomplete integral is evaluated.
        """
        m1 = self.m1
        psi1 = self.psi1
        chi1 = math.atan2(math.sqrt(self.sin_phi0), math.sqrt(m1))
        if chi1 <= psi1:
            return float(ellipkinc(chi1, 1.0 - m1))
        return float(ellipkm1(m1) - ellipkinc(psi1, 1.0 - m1))


def _solve_modulus(alpha: float) -> _Modulus:
    """Solve K(k) - F(psi1, k) = sqrt(2 alpha) (Eq. 21) for the tip angle, to machine precision.

    The unknown is phi0 when phi0 <= pi/4 (small loads) and beta = pi/2 - phi0 otherwise, so
    that sin(phi0) and 1 - k^2 keep full relative precision near 0 deg and near 90 deg.
    """
    target = math.sqrt(2.0 * alpha)
    quarter = 0.25 * math.pi

    def by_phi0(phi0: float) -> float:
        return _Modulus(phi0, 0.5 * math.pi - phi0).span_integral() - target

    def by_beta(beta: float) -> float:
        return _Modulus(0.5 * math.pi - beta, beta).span_integral() - target

    if by_phi0(quarter) >= 0.0:
        phi0 = brentq(by_phi0, 0.0, quarter, xtol=1e-300, maxiter=500)
        return _Modulus(phi0, 0.5 * math.pi - phi0)
    # K(k) ~ ln(4 / k') as k' -> 0 and F(pi/4, 1) = asinh(1): an estimate of beta to bracket.
    beta_lo = min(quarter, 8.0 * math.exp(-math.asinh(1.0) - target))
    while beta_lo < _SMALLEST_BETA or by_beta(beta_lo) < 0.0:
        if beta_lo < _SMALLEST_BETA:
            raise ValueError(f"load parameter alpha = {alpha:.6g} is too large to resolve phi0")
        beta_lo *= 0.25
    beta = brentq(by_beta, beta_lo, quarter, xtol=1e-300, maxiter=500)
    return _Modulus(0.5 * math.pi - beta, beta)


def exact_elastica(
    force: float, EI: float, length: float, s: np.ndarray | None = None
) -> ElasticaShape:
    """Exact shape of the inextensible cantilever elastica under a dead tip load.

    Solves Eq. (21) in its elliptic-integral form L sqrt(F/EI) = K(k) - F(psi1, k) for the
    modulus with Brent's method, then evaluates Eqs. (22) (corrected) and (23) in closed
    form at each arc length through the Jacobi amplitude. See the module docstring.

    Parameters
    ----------
    force : float
        Tip load F >= 0 [N], acting along -y.
    EI : float
        Bending stiffness [N m^2].
    length : float
        Rod length L [m].
    s : array_like, optional
        Arc lengths in [0, L] at which to evaluate the shape [m]. Default: 201 points
        uniformly spaced on [0, L].

    Returns
    -------
    ElasticaShape
        World coordinates (y <= 0) and the tip angle phi0 [rad]. ``force == 0`` gives the
        straight rod.

    Raises
    ------
    ValueError
        For negative, NaN or infinite inputs, non-positive EI or L, ``s`` outside [0, L], or
        alpha > ~6e4 (phi0 closer than 1e-150 rad to 90 deg).

    Notes
    -----
    Agrees with ``rodsim.core.analytic.paper_model`` (independent quadrature) to ~1e-13 L
    for alpha <= 50. For alpha ~ 100-300 (phi0 within 1e-5 rad of 90 deg) the agreement
    degrades to ~3e-10 L near the tip: scipy's ``ellipj`` and ``ellipeinc`` take m = k^2,
    which cannot carry 1 - m ~ 1e-12...1e-20 to full relative precision.
    """
    force, EI, length = validate_cantilever(force, EI, length)
    s = arc_length_samples(s, length)
    if force == 0.0:
        return ElasticaShape(s=s, x=s.copy(), y=np.zeros_like(s), tip_angle=0.0)
    alpha = load_parameter(force, EI, length)
    modulus = _solve_modulus(alpha)
    m = 1.0 - modulus.m1
    scale = length / math.sqrt(2.0 * alpha)  # sqrt(EI / F)
    sin_phi0 = modulus.sin_phi0
    psi1 = modulus.psi1
    u1 = float(ellipkinc(psi1, m))
    u = u1 + s / scale
    _, cn, _, psi = ellipj(u, m)
    cos_psi1 = math.sqrt(sin_phi0 / (1.0 + sin_phi0))
    x = 2.0 * math.sqrt(m) * scale * (cos_psi1 - cn)
    drop = scale * ((u - u1) - 2.0 * (ellipeinc(psi, m) - ellipeinc(psi1, m)))
    return ElasticaShape(s=s, x=x, y=-drop, tip_angle=modulus.phi0)
