"""Inverse kinematics: actuation values that put a rod's tip at a target (``rodsim reach``).

The unknowns are numeric scene values (typically the tensions of n tendons,
``tendons.<t>.tendon_actuation.force``), scaled by their starting values; the residual is
tip(p) − target (3 components), its Jacobian the tip rows of the sensitivities
(rodsim/app/inverse/sensitivity.py). scipy.optimize.least_squares (trust-region reflective)
keeps every value inside its schema range — tensions ≥ 0 — and each evaluation is an
equilibrium warm-started from the last (rodsim/app/inverse/continuation.py); a trial step to
values whose equilibrium cannot be solved (a tendon pulled so hard that the catheter folds)
gets a residual of ten rod lengths, so the trust region rejects it and shrinks. With more
actuators than the three tip coordinates (four tendons) the tensions that reach a target
are not unique: the answer is the solution the trust region reaches from the starting
values.

A target is reached when the final tip is within ``tolerance`` [m] of it; otherwise the
target is out of reach and the answer is the closest tip found (a local minimum of the
distance within the bounds), which the failure message reports.

An ``orientation`` target (the tip frame: directors d1, d2, d3 of the rod's last segment as
the rows of a rotation matrix) adds six residuals L (d_k − d_k*) for k = 1, 3 (they vanish
exactly when the frames agree, and are smooth, unlike an angle), with the Jacobian
L ∂d_k/∂q · dq/dp from the quaternion sensitivities. The pose is reached when, besides the
distance, the angle between the frames is within ``tolerance`` / L [rad].
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rodsim.app.inverse.continuation import EquilibriumFailure, ScaledEquilibria
from rodsim.app.inverse.parameter_keys import NumericKey, numeric_keys, scene_with
from rodsim.core.rod.quaternion import director, director_gradient, directors
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.io.provenance import history
from rodsim.io.run_dataset import run_dataset
from rodsim.solvers.result import Result

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Reach", "reach", "tip_frame", "frame_angle", "DEFAULT_TOLERANCE"]

#: Distance [m] below which the target counts as reached.
DEFAULT_TOLERANCE = 1e-6


@dataclass
class Reach:
    """The actuation found for a target: values, the tip reached and its distance [m] to
    the target, whether that is within ``tolerance``, the cost, and the equilibrium at the
    values found (``result``)."""

    keys: list[NumericKey]
    initial: np.ndarray
    values: np.ndarray
    target: np.ndarray
    tip: np.ndarray
    distance: float
    tolerance: float
    success: bool
    message: str
    evaluations: int
    jacobians: int
    wall_time: float
    rod: str
    result: Result
    #: The orientation target (rows d1, d2, d3) and the angle [rad] of the tip frame
    #: reached from it; None without an orientation target.
    orientation: np.ndarray | None = None
    angle: float | None = None

    def to_xarray(self) -> xr.Dataset:
        """The reach archive: the run archive of the scene with the values found, the
        target and the tip reached, and each actuation value as a scalar variable."""
        ds = run_dataset(self.result)
        ds["target"] = ("axis", self.target, {"units": "m", "long_name": "tip target"})
        ds["tip_reached"] = ("axis", self.tip, {"units": "m", "long_name": f"tip of rod "
                                                f"{self.rod!r} at the values found"})
        if self.orientation is not None:
            ds.attrs["orientation_target"] = json.dumps(self.orientation.tolist())
            ds.attrs["orientation_angle"] = float(self.angle)
        for key, initial, value in zip(self.keys, self.initial, self.values, strict=True):
            ds[key.name] = ((), value, {"units": key.unit, "long_name": f"{key.name} found"})
            ds[f"{key.name}.initial"] = ((), initial, {"units": key.unit, "long_name":
                                                       f"starting value of {key.name}"})
        ds.attrs.update({
            "title": f"rodsim reach of scene {self.result.scene.name!r} (tip of "
                     f"{self.rod!r})",
            "kind": "reach",
            "history": history(f"rodsim.reach(scene {self.result.scene.name!r}, actuate "
                               f"{', '.join(k.name for k in self.keys)})",
                               ds.attrs["date_created"]),
            "reach_parameters": json.dumps([k.name for k in self.keys]),
            "reach_rod": self.rod,
            "distance": self.distance,
            "reach_tolerance": self.tolerance,
            "reached": int(self.success),
            "reach_message": self.message,
            "reach_evaluations": self.evaluations,
            "reach_jacobians": self.jacobians,
            "reach_wall_time": self.wall_time,
        })
        return ds


def tip_frame(result: Result, rod: str) -> np.ndarray:
    """Directors d1, d2, d3 (rows) of the last segment of ``rod``: the tip's frame."""
    q = result.rods[rod].quaternions[-1]
    return directors(q / np.linalg.norm(q))


def frame_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle [rad] of the rotation between two frames (rows: directors)."""
    cosine = (np.trace(a @ b.T) - 1.0) / 2.0
    return float(np.arccos(np.clip(cosine, -1.0, 1.0)))


def _unit_director(q: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Director d_{k+1} of the unit quaternion q / |q| (Eq. 2 scales d_k by |q|²) and its
    gradient with respect to q, (3,) and (3, 4)."""
    norm2 = float(q @ q)
    d = director(q, k)
    return d / norm2, director_gradient(q, k) / norm2 - 2.0 * np.outer(d, q) / norm2**2


def _checked_orientation(orientation: Sequence[Sequence[float]]) -> np.ndarray:
    frame = np.asarray(orientation, dtype=float)
    if frame.shape != (3, 3) or not np.all(np.isfinite(frame)):
        raise SceneError("the orientation target needs three finite directors d1, d2, d3 "
                         "(a 3 x 3 matrix, rows)")
    if (np.max(np.abs(frame @ frame.T - np.eye(3))) > 1e-6
            or np.linalg.det(frame) < 0.0):
        raise SceneError("the orientation target is not a rotation: d1, d2, d3 must be "
                         "orthonormal and right-handed (to 1e-6)")
    return frame


def reach(scene: Scene, tip: Sequence[float], actuate: Sequence[str], *,
          rod: str | None = None, tolerance: float = DEFAULT_TOLERANCE,
          max_evaluations: int = 200,
          orientation: Sequence[Sequence[float]] | None = None) -> Reach:
    """Values of the scene keys ``actuate`` that put the tip of ``rod`` (default: the first
    rod) at ``tip`` [m], and, if given, its frame at ``orientation`` (rows d1, d2, d3 of
    the last segment), from the scene's values (module docstring). ``Reach.success`` is
    False when the target is out of reach. Raises SceneError for bad keys or a bad target,
    EquilibriumFailure when an equilibrium on the way cannot be solved."""
    from scipy.optimize import least_squares

    from rodsim.app.api import solve

    started = time.perf_counter()
    target = np.asarray(tip, dtype=float)
    if target.shape != (3,) or not np.all(np.isfinite(target)):
        raise SceneError("the tip target needs three finite coordinates X,Y,Z [m]")
    if not tolerance > 0:
        raise SceneError(f"tolerance {tolerance!r}: must be a distance > 0 [m]")
    frame = None if orientation is None else _checked_orientation(orientation)
    keys = numeric_keys(scene, actuate)
    rod = rod or next(iter(scene.rods))
    if rod not in scene.rods:
        raise SceneError(f"rod {rod!r}: no such rod; rods: {', '.join(scene.rods)}")
    problem, lower, upper = ScaledEquilibria.at_scene_values(scene, keys, rod)
    initial = problem.values.copy()
    length = scene.rods[rod].length

    far = np.full(3 if frame is None else 9, 10.0 * length)

    def residuals(u: np.ndarray) -> np.ndarray:
        # A step to values without a solvable equilibrium gets a residual far beyond any
        # tip's, so that the trust region rejects it and shrinks.
        if not problem.reached(u):
            return far
        position = problem.nodes()[-1] - target
        if frame is None:
            return position
        q = problem.tip_quaternion()
        return np.concatenate([position, *(length * (_unit_director(q, k)[0] - frame[k])
                                           for k in (0, 2))])

    def jacobian(u: np.ndarray) -> np.ndarray:
        problem.at(u)
        position, quaternion = problem.tip_sensitivity()
        if frame is None:
            return position.T
        q = problem.tip_quaternion()
        rows = [length * _unit_director(q, k)[1] @ quaternion.T for k in (0, 2)]
        return np.vstack([position.T, *rows])

    solution = least_squares(residuals, problem.start, jac=jacobian,
                             bounds=(lower, upper), xtol=1e-12, ftol=1e-15, gtol=1e-15,
                             max_nfev=max_evaluations, method="trf")
    values = problem.values_of(solution.x)
    final = solve(scene_with(scene, keys, values), "static")
    if not final.success:
        raise EquilibriumFailure(f"no equilibrium at the values found: {final.message}")
    reached = final.tip(rod)
    distance = float(np.linalg.norm(reached - target))
    success = distance <= tolerance
    angle, turned = None, ""
    if frame is not None:
        angle = frame_angle(tip_frame(final, rod), frame)
        success = success and angle <= tolerance / length
        turned = f" and {angle:.3g} rad from the orientation (tolerance " \
                 f"{tolerance / length:.3g} rad)"
    described = ", ".join(f"{k.name} = {v:.6g} {k.unit}" for k, v in zip(keys, values,
                                                                          strict=True))
    where = ", ".join(f"{c:.6g}" for c in reached)
    message = (f"reached within {distance:.3g} m{turned} with {described}" if success else
               f"target out of reach: the closest tip found is ({where}) m, {distance:.3g} m "
               f"from the target (tolerance {tolerance:.3g} m){turned}, with {described}")
    return Reach(keys, initial, values, target, reached, distance, tolerance, success,
                 message, problem.evaluations, problem.jacobians,
                 time.perf_counter() - started, rod, final, frame, angle)
