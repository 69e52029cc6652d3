"""An independent reference for the natural frequencies of a straight clamped–free beam
(tests/test_modes.py): Timoshenko's equations with rotary inertia ρI, shear stiffness k_s
(the centerline penalty K_P plays κGA; ``inf`` gives Euler–Bernoulli), a constant axial
tension T acting along the centerline (a dead tip force along the axis) and a tip mass m_t.

Harmonic motion w(s) e^{iωt}, ψ(s) e^{iωt} (ψ the section's rotation) with
V = k_s (w′ − ψ) + T w′ (the transverse force) and M = EI ψ′ obeys the constant-coefficient
system y′ = A(ω) y, y = (w, ψ, V, M):

    w′ = ψ + (V − T ψ)/(k_s + T),   ψ′ = M/EI,
    V′ = −ρA ω² w,                  M′ = −ρI ω² ψ − (V − T w′),

clamped at s = 0 (w = ψ = 0), free at s = L (M = 0, V = m_t ω² w). So y(L) = exp(A L) y(0)
exactly; a natural frequency is a root of the 2×2 determinant of the free-end conditions on
the two clamped-end solutions, bracketed on a grid and refined by brentq to 1e-14 relative.
Nothing here is shared with rodsim.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq


def _system(omega: float, EI: float, rhoA: float, rhoI: float, shear: float,
            tension: float) -> np.ndarray:
    compliance = 0.0 if math.isinf(shear) else 1.0 / (shear + tension)
    w2 = omega * omega
    a = np.zeros((4, 4))
    # w' = ψ (1 − T c) + c V
    a[0, 1], a[0, 2] = 1.0 - tension * compliance, compliance
    a[1, 3] = 1.0 / EI
    a[2, 0] = -rhoA * w2
    # M' = −ρI ω² ψ − V + T w'
    a[3, 1] = -rhoI * w2 + tension * a[0, 1]
    a[3, 2] = -1.0 + tension * a[0, 2]
    return a


def _determinant(omega: float, length: float, tip_mass: float, **beam: float) -> float:
    return _tip_determinant(expm(_system(omega, **beam) * length), omega, tip_mass)


def _tip_determinant(transfer: np.ndarray, omega: float, tip_mass: float) -> float:
    tip = transfer[:, 2:]  # the solutions starting from (0, 0, 1, 0) and (0, 0, 0, 1)
    conditions = np.array([tip[3], tip[2] - tip_mass * omega**2 * tip[0]])
    scale = np.abs(tip).max()
    return float(np.linalg.det(conditions)) / scale**2


def clamped_free_frequencies(count: int, *, length: float, EI: float, rhoA: float,
                             rhoI: float = 0.0, shear: float = math.inf,
                             tension: float = 0.0, tip_mass: float = 0.0) -> np.ndarray:
    """The ``count`` lowest bending frequencies [Hz] of the clamped–free beam (module
    docstring)."""
    first = (1.875 / length) ** 2 * math.sqrt(EI / rhoA)  # the Euler–Bernoulli ω₁ scale
    grid = np.linspace(1e-3 * first, first * (2.0 * count + 4.0) ** 2, 400 * count + 400)
    found: list[float] = []
    previous = _determinant(grid[0], length, tip_mass, EI=EI, rhoA=rhoA, rhoI=rhoI,
                            shear=shear, tension=tension)
    for low, high in zip(grid[:-1], grid[1:], strict=True):
        value = _determinant(high, length, tip_mass, EI=EI, rhoA=rhoA, rhoI=rhoI,
                             shear=shear, tension=tension)
        if previous * value < 0.0:
            found.append(brentq(
                lambda w: _determinant(w, length, tip_mass, EI=EI, rhoA=rhoA, rhoI=rhoI,
                                       shear=shear, tension=tension),
                low, high, xtol=1e-300, rtol=1e-14, maxiter=200))
            if len(found) == count:
                break
        previous = value
    assert len(found) == count, "reference: roots not bracketed"
    return np.array(found) / (2.0 * math.pi)


def spans_frequencies(count: int, spans: list[dict[str, float]], *, first: float,
                      tension: float = 0.0, tip_mass: float = 0.0) -> np.ndarray:
    """The same for a piecewise-uniform beam: ``spans`` from the clamp to the tip, each
    ``{"length", "EI", "rhoA", "rhoI", "shear"}``; y(L) is the product of the spans'
    exact transfer matrices (w, ψ, V, M are continuous across a junction). ``first``: a
    scale of the first angular frequency [rad/s] for the bracketing grid."""
    def determinant(omega: float) -> float:
        transfer = np.eye(4)
        for span in spans:
            beam = {key: span[key] for key in ("EI", "rhoA", "rhoI", "shear")}
            transfer = expm(_system(omega, tension=tension, **beam) * span["length"]) @ transfer
        return _tip_determinant(transfer, omega, tip_mass)

    grid = np.linspace(1e-3 * first, first * (2.0 * count + 4.0) ** 2, 400 * count + 400)
    found: list[float] = []
    previous = determinant(grid[0])
    for low, high in zip(grid[:-1], grid[1:], strict=True):
        value = determinant(high)
        if previous * value < 0.0:
            found.append(brentq(determinant, low, high, xtol=1e-300, rtol=1e-14, maxiter=200))
            if len(found) == count:
                break
        previous = value
    assert len(found) == count, "reference: roots not bracketed"
    return np.array(found) / (2.0 * math.pi)
