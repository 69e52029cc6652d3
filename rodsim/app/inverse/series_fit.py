"""Fitting scene parameters to a measured series along a ramp (``rodsim.fit_series``): the
friction coefficient μ of a tendon from a pull–release cycle (issue 34; docs/tendon.md,
"Friction").

`rodsim.fit` matches one equilibrium; friction's state depends on the path, so μ shows only
in a series: the tip positions measured at every value of a ramp (up and back down: the
hysteresis loop). Each evaluation of the misfit is one ``rodsim.track`` of the ramp with the
trial parameters, cold from the ramp's first value (a cold step assumes the tendon pulled in
from slack, as the measurement must have started), and the residual is the tracked tips
minus the measured ones, every step and axis. The parameters p minimise Σ |tip_k(p) − d_k|²
(scipy.optimize.least_squares, trust-region reflective within each parameter's schema
range, forward differences with a relative step of 1e-4: a track has no sensitivities).

Standard errors: the Gauss–Newton covariance σ² (JᵀJ)⁻¹ at the solution, σ² = RSS/(m − p),
m = steps × d with d the dimension (1–3) of the affine span of the measured tips (a planar
loop: d = 2; the axis it never leaves carries no information).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from rodsim.app.inverse.continuation import EquilibriumFailure
from rodsim.app.inverse.parameter_keys import numeric_keys
from rodsim.app.inverse.track import Track, track
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.solvers import DEFAULT_INTEGRATOR
from rodsim.solvers.base import Progress

__all__ = ["SeriesFit", "fit_series"]

#: Relative forward-difference step of the misfit's Jacobian (scaled parameters).
DIFFERENCE_STEP = 1e-4


@dataclass
class SeriesFit:
    """The fitted ``values`` {key: value}, their ``standard_errors``, the residual RMS [m]
    per tip coordinate, the ``track`` at the fitted values, the misfit ``evaluations`` of
    the least squares and the distinct ``tracks`` solved (its finite differences
    included)."""

    values: dict[str, float]
    standard_errors: dict[str, float]
    rms: float
    track: Track
    evaluations: int
    tracks: int


def _span_dimension(points: np.ndarray) -> int:
    """Dimension of the affine span of ``points`` (n, 3), relative tolerance 1e-9."""
    centred = points - points.mean(axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    return int(np.sum(singular > 1e-9 * max(float(singular[0]), 1e-300)))


def fit_series(scene: Scene, ramps: Mapping[str, Sequence[float] | np.ndarray],
               tips: np.ndarray, params: Sequence[str], *, rod: str | None = None,
               integrator: str = DEFAULT_INTEGRATOR,
               progress: Progress | None = None) -> SeriesFit:
    """Fit the scene values ``params`` (dotted keys, e.g.
    ``tendons.a.tendon_string.friction``) so that ``rodsim.track(scene, ramps)`` puts the tip
    of ``rod`` (default: the first) at the measured ``tips`` (steps, 3) [m] (module
    docstring). The scene's own values start the search. SceneError for bad keys or a
    series whose length is not the ramp's; EquilibriumFailure when the track fails at the
    start."""
    from scipy.optimize import least_squares

    keys = numeric_keys(scene, params)
    measured = np.asarray(tips, dtype=float)
    steps = len(next(iter(ramps.values())))
    if measured.shape != (steps, 3):
        raise SceneError(f"tips: expected ({steps}, 3) positions, one per ramp value; got "
                         f"shape {measured.shape}")
    start = np.array([key.value(scene) for key in keys])
    scale = np.where(start != 0.0, np.abs(start), 1.0)
    low = np.array([key.bounds()[0] for key in keys]) / scale
    high = np.array([key.bounds()[1] for key in keys]) / scale
    length = max(rod_.length for rod_ in scene.rods.values())
    tracks: dict[bytes, Track] = {}

    def tracked(p: np.ndarray) -> Track:
        key = p.tobytes()
        if key not in tracks:
            values = {k.name: float(v) for k, v in zip(keys, p * scale, strict=True)}
            tracks[key] = track(scene.with_values(values), ramps, integrator)
            if progress is not None:
                path = tracks[key]
                misfit = (float(np.sqrt(np.mean((path.tips(rod) - measured) ** 2)))
                          if path.success else float("nan"))
                progress(None, f"fit: track {len(tracks)}, residual RMS {misfit:.3g} m")
        return tracks[key]

    def residuals(p: np.ndarray) -> np.ndarray:
        path = tracked(p)
        if not path.success:  # no equilibrium there: a large residual, the region shrinks
            return np.full(measured.size, 10.0 * length)
        return (path.tips(rod) - measured).ravel()

    if not tracked(start / scale).success:
        raise EquilibriumFailure(f"the track at the scene's values failed: "
                                 f"{tracked(start / scale).message}")
    solution = least_squares(residuals, start / scale, bounds=(low, high), method="trf",
                             diff_step=DIFFERENCE_STEP, x_scale=1.0)
    best = tracked(solution.x)
    freedom = steps * _span_dimension(measured) - len(keys)
    if freedom <= 0:
        raise SceneError(f"{steps} tips fit {len(keys)} parameters with no residual degree "
                         "of freedom left")
    rss = float(solution.fun @ solution.fun)
    jac = solution.jac * (1.0 / scale)[None, :]
    covariance = rss / freedom * np.linalg.pinv(jac.T @ jac)
    fitted = solution.x * scale
    return SeriesFit({k.name: float(v) for k, v in zip(keys, fitted, strict=True)},
                     {k.name: float(np.sqrt(covariance[i, i])) for i, k in enumerate(keys)},
                     float(np.sqrt(rss / solution.fun.size)), best, int(solution.nfev),
                     len(tracks))
