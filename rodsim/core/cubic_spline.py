"""The not-a-knot cubic spline through samples, as ``scipy.interpolate.CubicSpline(x, y)``
computes it (the same operations in the same order, so the same numbers bit for bit), without
importing scipy.interpolate.

Importing scipy.interpolate imports scipy.optimize, scipy.special, scipy.fft and
scipy.spatial: ~0.17 s of CPU, a fifth of ``rodsim run tdcr-two-segment``, whose
discretisation estimate only interpolates a rod's shape (rodsim/app/discretisation.py;
docs/benchmarks.md, "Start-up"). The spline's slopes solve scipy's tridiagonal system
through the same ``scipy.linalg.solve_banded`` call (scipy.linalg is loaded with
scipy.sparse.linalg); its Hermite coefficients and the piecewise evaluation
(``scipy/interpolate/_ppoly.pyx``: ``find_interval``, then ``evaluate_poly1``'s sum
c3 + c2 s + c1 s² + c0 s³ with the powers made by successive products) are written out
in numpy. Fewer than four samples (scipy's special cases) are handed to scipy itself.
tests/test_cubic_spline.py compares both bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["cubic_spline"]


def cubic_spline(x: np.ndarray, y: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The not-a-knot cubic spline through the samples ``y`` (n, ...) at the strictly
    increasing ``x`` (n,), extrapolated past the ends by the end pieces: a function of the
    points to evaluate it at (m,) returning (m, ...). ``scipy.interpolate.CubicSpline(x,
    y)``'s numbers."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n = len(x)
    if n < 4 or x.ndim != 1 or y.shape[0] != n:
        from scipy.interpolate import CubicSpline  # scipy's special cases and its checks

        spline = CubicSpline(x, y)
        return lambda points: np.asarray(spline(points))
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError("the samples must be finite")
    dx = np.diff(x)
    if np.any(dx <= 0):
        raise ValueError("x must be strictly increasing")
    coefficients = _coefficients(x, y, dx)
    return lambda points: _evaluate(coefficients, x, points)


def _coefficients(x: np.ndarray, y: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """The pieces' coefficients (4, n − 1, ...), highest power first (scipy's
    ``CubicSpline.__init__`` for not-a-knot ends and n ≥ 4, then ``CubicHermiteSpline``)."""
    from scipy.linalg import solve_banded

    n = len(x)
    dxr = dx.reshape([dx.shape[0]] + [1] * (y.ndim - 1))
    slope = np.diff(y, axis=0) / dxr
    band = np.zeros((3, n))
    b = np.empty((n,) + y.shape[1:], dtype=y.dtype)
    band[1, 1:-1] = 2 * (dx[:-1] + dx[1:])
    band[0, 2:] = dx[:-1]
    band[-1, :-2] = dx[1:]
    b[1:-1] = 3 * (dxr[1:] * slope[:-1] + dxr[:-1] * slope[1:])
    band[1, 0] = dx[1]
    band[0, 1] = x[2] - x[0]
    d = x[2] - x[0]
    b[0] = ((dxr[0] + 2 * d) * dxr[1] * slope[0] + dxr[0] ** 2 * slope[1]) / d
    band[1, -1] = dx[-2]
    band[-1, -2] = x[-1] - x[-3]
    d = x[-1] - x[-3]
    b[-1] = (dxr[-1] ** 2 * slope[-2] + (2 * d + dxr[-1]) * dxr[-2] * slope[-1]) / d
    s = solve_banded((1, 1), band, b.reshape(n, -1), overwrite_ab=True, overwrite_b=True,
                     check_finite=False).reshape(b.shape)
    t = (s[:-1] + s[1:] - 2 * slope) / dxr
    return np.stack((t / dxr, (slope - s[:-1]) / dxr - t, s[:-1], y[:-1]))


def _evaluate(coefficients: np.ndarray, x: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The pieces at ``points``: each point in the piece x[i] <= p < x[i+1] (the last piece
    closed on the right; below x[0] the first, above x[-1] the last), then
    ((c3 + c2 s) + c1 (s s)) + c0 ((s s) s) with s = p − x[i]; NaN at a NaN point."""
    points = np.ascontiguousarray(np.asarray(points, dtype=np.float64).ravel())
    pieces = np.clip(np.searchsorted(x, points, side="right") - 1, 0, len(x) - 2)
    s = points - x[pieces]
    c = coefficients[:, pieces]
    s = s.reshape(s.shape + (1,) * (c.ndim - 2))
    z2 = s * s
    out = 0.0 + c[3]
    out = out + c[2] * s
    out = out + c[1] * z2
    out = out + c[0] * (z2 * s)
    out[np.isnan(points)] = np.nan
    return out
