"""Fitting scene parameters to a measured shape (``rodsim fit``).

Data: measured points of one rod's centerline (CSV with header ``x,y,z`` in metres, and
optionally ``s``, the rest arc length [m] of each point), any number and spacing. Each point
is matched to the model centerline (the polyline through the control points):

- without ``s``, to the nearest point on the polyline (segment j, fraction t); the
  residual P(j, t) − d is then normal to the segment, and its Jacobian is projected on the
  segment's normal plane (the envelope theorem: moving along the curve changes the
  distance only to second order);
- with ``s``, to the polyline point at that rest arc length (interpolated between nodes).

The matches are renewed at every evaluation. The parameters p minimise Σ |P_i(p) − d_i|²
(scipy.optimize.least_squares, trust-region reflective, within each parameter's schema
range); each evaluation is an equilibrium warm-started from the previous one
(rodsim/app/inverse/continuation.py), and the Jacobian comes from the sensitivities
(rodsim/app/inverse/sensitivity.py), ∂P(j, t)/∂p = (1 − t) ∂r_j/∂p + t ∂r_{j+1}/∂p. The
parameters are scaled by their initial values. A trial step to values whose equilibrium
cannot be solved gets a residual of ten rod lengths per component, so the trust region
rejects it and shrinks. A trust region that shrinks to nothing on such refusals ends
least_squares with "xtol satisfied" wherever it is; so a fit whose last ``STALLED``
trial values had no equilibrium is checked: if a Gauss–Newton step in the parameters not
held at a bound would remove more than ``NOT_A_MINIMUM`` of the squared residual
(linear prediction; ≈ 0 at a minimum), the fit stopped short of a minimum and raises
``rodsim.app.inverse.continuation.EquilibriumFailure`` saying how many trial values
had no equilibrium.

Standard errors: the Gauss–Newton covariance σ² (JᵀJ)⁻¹ at the solution, σ² = RSS/(m − p),
where m counts the residual components that carry information: with nearest-point
matching one per dimension of the data's span minus the one along the curve, i.e.
m = points × (d − 1), with ``s`` m = points × d, d = the dimension (1–3) of the affine span
of the data and the fitted centerline (planar data and a planar model: d = 2). A parameter
whose standard error exceeds ``MAX_RELATIVE_ERROR`` times its value is *undetermined*
(``Fit.undetermined``; a singular Fisher matrix JᵀJ is refused above): ``rodsim fit`` exits
1 saying so (a pitch of 1000 m on a 0.16 m catheter was "999.9 ± 2e6 m", a success).

Refused (``FitError``): fewer points than parameters, no residual degrees of freedom
left, data farther than ``MAX_REACH`` rod lengths from the rod's origin (no shape of the
rod comes near them: the message guesses the cause, typically millimetres read as metres),
and parameters that do not influence the shape (a zero column of J) or that cannot be told
apart from it (J's columns, scaled, have a condition number above 1e10).

The fitted state is the equilibrium the optimiser measured at the values found (the warm
continuation's), never a cold re-solve that could land on another branch; it carries its
stability verdict (``Fit.result.stability``). The residual RMS is reported in metres and
relative to the rod's length; a fit whose RMS is not finite raises
``rodsim.app.inverse.continuation.EquilibriumFailure``.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rodsim.app.inverse.continuation import EquilibriumFailure, ScaledEquilibria
from rodsim.app.inverse.measured_points import (
    FitError,
    Points,
    check_plausible,
    match,
    read_points,
    span_dimension,
)
from rodsim.app.inverse.parameter_keys import NumericKey, numeric_keys
from rodsim.app.inverse.path_record import record_path
from rodsim.core.scene import Scene
from rodsim.io.cf_layout import variable_name
from rodsim.io.provenance import history
from rodsim.io.run_dataset import run_dataset
from rodsim.solvers import DEFAULT_INTEGRATOR, integrator_named
from rodsim.solvers.base import Progress
from rodsim.solvers.result import Result

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Points", "Fit", "FitError", "read_points", "fit", "match", "MAX_CONDITION",
           "MAX_RELATIVE_ERROR"]

#: Largest σ / |value| of a determined parameter (above: its 2σ interval reaches zero).
MAX_RELATIVE_ERROR = 0.5

#: Largest condition number of the scaled Jacobian before the parameters are declared not
#: identifiable from the data.
MAX_CONDITION = 1e10
#: A parameter whose relative change of 1 moves the matched points by less than this times
#: the rod's length (RMS) does not influence the shape.
NO_INFLUENCE = 1e-9
#: Share of the squared residual a Gauss–Newton step from the fit's end point may still
#: promise to remove: 0 at a minimum (JᵀR = 0); the equilibria's own round-off promises at
#: most about (parameters / residual components), a stalled trust region nearly all of it.
NOT_A_MINIMUM = 0.5
#: The last this many trial values all without an equilibrium: the trust region shrank on
#: refusals, not on a converged shape.
STALLED = 3
@dataclass
class Fit:
    """A finished fit: the fitted parameters with standard errors, the residual RMS [m],
    evaluations, wall time, and the fitted scene's equilibrium (``result``)."""

    keys: list[NumericKey]
    initial: np.ndarray
    values: np.ndarray
    errors: np.ndarray
    covariance: np.ndarray
    residual_rms: float
    degrees_of_freedom: int
    evaluations: int
    jacobians: int
    wall_time: float
    message: str
    points: Points
    matched: np.ndarray
    rod: str
    result: Result
    #: The values of every equilibrium of the continuation, (evaluations, keys): the
    #: history of the fitted state's tendon friction (rodsim/app/inverse/path_record.py).
    path: np.ndarray | None = None

    @property
    def residual_rms_relative(self) -> float:
        """The residual RMS divided by the fitted rod's length."""
        return self.residual_rms / self.result.scene.rods[self.rod].length

    @property
    def undetermined(self) -> list[str]:
        """The parameters the data do not determine: a relative standard error above
        ``MAX_RELATIVE_ERROR``, or not finite."""
        return [k.name for k, v, e in zip(self.keys, self.values, self.errors, strict=True)
                if not (math.isfinite(e) and e <= MAX_RELATIVE_ERROR * abs(v))]

    @property
    def undetermined_text(self) -> str:
        """One line naming each undetermined parameter with its value and error."""
        parts = [f"{k.name} = {v:.6g} ± {e:.2g} {k.unit} (relative standard error "
                 f"{e / abs(v) if v else math.inf:.2g})" for k, v, e in
                 zip(self.keys, self.values, self.errors, strict=True)
                 if k.name in self.undetermined]
        return (", ".join(parts) + f": above {MAX_RELATIVE_ERROR:g}, the data do not "
                "determine it; fit fewer parameters, add data where the shape depends on it, "
                "or start nearer the answer (--set KEY=VALUE)")

    @property
    def stable(self) -> bool:
        """Whether the fitted equilibrium is not unstable (stable or neutral,
        rodsim/core/stability.py)."""
        return self.result.stability is None or not self.result.stability.unstable

    def __repr__(self) -> str:
        from rodsim.app.inverse.summaries import summary

        return summary(self, html=False)

    def _repr_html_(self) -> str:
        from rodsim.app.inverse.summaries import summary

        return summary(self, html=True)

    def to_xarray(self) -> xr.Dataset:
        """The fit archive: the run archive of the fitted scene (``rodsim rerun`` re-solves
        it) with the data, their matches, and per parameter its fitted value, initial value
        and standard error as scalar variables (docs/inverse.md)."""
        ds = run_dataset(self.result)
        ds["data_position"] = (("point", "axis"), self.points.xyz,
                               {"units": "m", "long_name": "measured point"})
        ds["matched_position"] = (("point", "axis"), self.matched,
                                  {"units": "m", "long_name": "matching point on the fitted "
                                   f"centerline of rod {self.rod!r}"})
        if self.points.s is not None:
            ds["data_s"] = ("point", self.points.s,
                            {"units": "m", "long_name": "rest arc length of the measured point"})
        for key, initial, value, error in zip(self.keys, self.initial, self.values,
                                              self.errors, strict=True):
            name = variable_name(key.name)  # no dots (CF); the key is an attribute
            ds[name] = ((), value, {"units": key.unit, "long_name": f"fitted {key.name}",
                                    "scene_key": key.name})
            ds[f"{name}_initial"] = ((), initial, {"units": key.unit, "scene_key": key.name,
                                                   "long_name": f"initial {key.name}"})
            ds[f"{name}_standard_error"] = ((), error, {
                "units": key.unit, "scene_key": key.name,
                "long_name": f"standard error of the fitted {key.name} "
                "(Gauss-Newton covariance)"})
        if self.path is not None:
            record_path(ds, self.keys, self.path, "fit")
        if self.undetermined:  # not a result: the data do not determine these
            ds.attrs["undetermined"] = ", ".join(self.undetermined)
        ds.attrs.update({
            "title": f"rodsim fit of {len(self.keys)} value(s) of scene "
                     f"{self.result.scene.name!r} to {len(self.points.xyz)} points",
            "kind": "fit",
            "history": history(f"rodsim.fit(scene {self.result.scene.name!r}, "
                               f"{len(self.points.xyz)} points, parameters "
                               f"{', '.join(k.name for k in self.keys)})",
                               ds.attrs["date_created"]),
            "fit_parameters": json.dumps([k.name for k in self.keys]),
            "fit_rod": self.rod,
            "residual_rms": self.residual_rms,
            "residual_rms_relative": self.residual_rms_relative,
            "degrees_of_freedom": self.degrees_of_freedom,
            "fit_evaluations": self.evaluations,
            "fit_jacobians": self.jacobians,
            "fit_wall_time": self.wall_time,
            "fit_message": self.message,
        })
        return ds


def _gauss_newton_gain(jacobian: np.ndarray, residual: np.ndarray, free: np.ndarray
                       ) -> float:
    """The share of |R|² that one Gauss–Newton step in the ``free`` parameters would remove
    by the linear prediction, R + J δ with δ = argmin |R + J δ|: 0 at a minimum."""
    total = float(residual @ residual)
    if total == 0.0 or not np.any(free):
        return 0.0
    columns = jacobian[:, free]
    step = np.linalg.lstsq(columns, -residual, rcond=None)[0]
    after = residual + columns @ step
    return 1.0 - float(after @ after) / total


def _check_identifiable(jacobian: np.ndarray, keys: Sequence[NumericKey], length: float
                        ) -> None:
    """FitError for a parameter that does not move the matched points (a relative change of
    1 moves them by less than ``NO_INFLUENCE`` × the rod's ``length``, in RMS), or for
    parameters that cannot be told apart (scaled Jacobian nearly rank deficient)."""
    norms = np.linalg.norm(jacobian, axis=0)
    points = jacobian.shape[0] // 3
    for key, norm in zip(keys, norms, strict=True):
        if not norm > NO_INFLUENCE * length * math.sqrt(points):
            raise FitError(f"{key.name} does not influence the shape (its column of the "
                           "Jacobian is zero, a singular Jacobian): it cannot be fitted")
    if len(keys) > 1:
        condition = np.linalg.cond(jacobian / norms)
        if not condition < MAX_CONDITION:
            raise FitError("the parameters " + ", ".join(k.name for k in keys) + " cannot be "
                           f"told apart from the shape (singular Jacobian, condition number "
                           f"{condition:.3g}): fit fewer of them")


def fit(scene: Scene, points: Points, params: Sequence[str], *, rod: str | None = None,
        max_evaluations: int = 100, progress: Progress | None = None,
        integrator: str = DEFAULT_INTEGRATOR) -> Fit:
    """Fit the numeric scene values ``params`` (keys as for ``--set``) to the measured
    ``points`` of ``rod`` (default: the first rod), starting from the scene's values
    (module docstring); ``progress`` is called after each equilibrium with a status line;
    ``integrator`` (a registered name) solves every equilibrium.
    Raises SceneError for bad keys, FitError for bad data or
    unidentifiable parameters, EquilibriumFailure when an equilibrium cannot be solved."""
    from scipy.optimize import least_squares

    started = time.perf_counter()
    if not isinstance(scene, Scene):
        raise FitError(f"fit needs a Scene (rodsim.load_scene), got {type(scene).__name__}")
    if not isinstance(points, Points):
        raise FitError(f"fit needs Points (rodsim.app.inverse.fit.read_points or Points(xyz)),"
                       f" got {type(points).__name__}")
    xyz = np.asarray(points.xyz)
    if xyz.ndim != 2 or xyz.shape[1:] != (3,) or xyz.dtype.kind not in "fiu" or not np.all(
            np.isfinite(xyz)):
        raise FitError("Points.xyz must be an (m, 3) array of finite numbers [m]")
    if (not isinstance(params, (list, tuple)) or not params
            or not all(isinstance(key, str) for key in params)):
        raise FitError("params must be a non-empty list of scene keys (e.g. "
                       "['youngs_modulus'])")
    keys = numeric_keys(scene, list(params))
    rod = rod or next(iter(scene.rods))
    if not isinstance(rod, str) or rod not in scene.rods:
        raise FitError(f"rod {rod!r}: no such rod; rods: {', '.join(scene.rods)}")
    count = len(points.xyz)
    if count == 0:
        raise FitError("no data points: Points.xyz is empty")
    if points.s is not None and (np.shape(points.s) != (count,) or not np.all(
            np.isfinite(points.s))):
        raise FitError(f"Points.s must be None or ({count},) finite rest arc lengths [m], one "
                       "per point")
    length = scene.rods[rod].length
    if points.s is not None and (points.s.min() < 0.0 or points.s.max() > length):
        raise FitError(f"data column s spans {points.s.min():.6g} to {points.s.max():.6g} m, "
                       f"outside the rest arc length of rod {rod!r}, 0 to {length:g} m")
    if count < len(keys):
        raise FitError(f"{count} data points for {len(keys)} parameters: need at least as "
                       "many points as parameters")
    check_plausible(points, scene, rod)
    problem, lower, upper = ScaledEquilibria.at_scene_values(scene, keys, rod,
                                                             integrator_named(integrator).name)
    initial, scale = problem.values.copy(), problem.scale
    s_nodes = problem.continuation.model.rods[rod].geometry.node_s

    def matched(nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        j, t, interior = match(nodes, s_nodes, points)
        return (1 - t)[:, None] * nodes[j] + t[:, None] * nodes[j + 1], j, t, interior

    far = np.full(points.xyz.size, 10.0 * scene.rods[rod].length)

    refused: list[bool] = []  # per trial: its values had no equilibrium

    def residuals(u: np.ndarray) -> np.ndarray:
        # A step to values without a solvable equilibrium gets a residual far beyond any
        # shape's, so that the trust region rejects it and shrinks.
        refused.append(not problem.reached(u))
        if refused[-1]:
            return far
        gap = (matched(problem.nodes())[0] - points.xyz).ravel()
        if progress is not None:
            progress(None, f"fit: equilibrium {problem.evaluations}, residual RMS "
                     f"{np.sqrt(np.mean(gap.reshape(-1, 3) ** 2) * 3):.3g} m")
        return gap

    def jacobian(u: np.ndarray) -> np.ndarray:
        problem.at(u)
        nodes = problem.nodes()
        _, j, t, interior = matched(nodes)
        derivative = problem.node_sensitivity()                     # (P, N, 3)
        rows = (1 - t)[None, :, None] * derivative[:, j] + t[None, :, None] * derivative[:, j + 1]
        tangent = nodes[j + 1] - nodes[j]
        tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
        along = np.einsum("pmc,mc->pm", rows, tangent) * interior
        rows = rows - along[:, :, None] * tangent[None]
        return rows.transpose(1, 2, 0).reshape(-1, len(keys))

    _check_identifiable(jacobian(problem.start), keys, length)
    solution = least_squares(residuals, problem.start, jac=jacobian,
                             bounds=(lower, upper), x_scale=1.0, xtol=1e-12, ftol=1e-15,
                             gtol=1e-15, max_nfev=max_evaluations, method="trf")
    problem.at(solution.x)  # the equilibrium the optimiser measured (no cold re-solve)
    values = problem.values_of(solution.x)
    final = problem.result("fit")
    nodes = problem.nodes()
    fitted_points, *_ = matched(nodes)
    residual = (fitted_points - points.xyz).ravel()
    scaled = jacobian(solution.x)
    span = span_dimension(np.concatenate([points.xyz, nodes]))
    freedom = count * (span if points.s is not None else max(span - 1, 1))
    if freedom <= len(keys):
        raise FitError(f"{count} points give {freedom} residual degrees of freedom for "
                       f"{len(keys)} parameters: add points to estimate the errors")
    sigma2 = float(residual @ residual) / (freedom - len(keys))
    _check_identifiable(scaled, keys, length)
    gain = _gauss_newton_gain(scaled, residual, solution.active_mask == 0)
    if refused[-STALLED:] == [True] * STALLED and gain > NOT_A_MINIMUM:
        raise EquilibriumFailure(
            f"the fit stopped short of a minimum ({solution.message}): a Gauss-Newton step "
            f"from there would still remove {100 * gain:.0f} % of the squared residual; "
            f"{problem.failures} trial values had no equilibrium (last: "
            f"{problem.last_failure or 'none'}); start nearer the answer (--set KEY=VALUE)")
    covariance = sigma2 * np.linalg.inv(scaled.T @ scaled) * np.outer(scale, scale)
    rms = float(np.sqrt(np.mean(np.sum((fitted_points - points.xyz) ** 2, axis=1))))
    if not math.isfinite(rms):
        raise EquilibriumFailure(f"the fit's residual RMS is {rms} (not a finite distance): "
                                 "no fit")
    return Fit(keys, initial, values, np.sqrt(np.diag(covariance)), covariance, rms,
               freedom, problem.evaluations, problem.jacobians, time.perf_counter() - started,
               str(solution.message), points, fitted_points, rod, final,
               np.array(problem.path))
