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

The answer is the equilibrium the optimiser measured at the values found (the warm
continuation's), never a cold re-solve of those values, which can land on another branch
(a folded rod far from the target). It carries its stability verdict: a target met only at
an unstable equilibrium (a rod compressed past buckling) is not reached —
``success`` False, ``unstable`` True, the message says so.

Where the tip does not move with an actuation value at the start (its sensitivity is zero,
as a tendon at zero tension can be), that value starts at ``NUDGE`` of its scale inside
its range instead, so the trust region sees a direction.

An ``orientation`` target (the tip frame: directors d1, d2, d3 of the rod's last segment as
the rows of a rotation matrix) adds six residuals L (d_k − d_k*) for k = 1, 3 (they vanish
exactly when the frames agree, and are smooth, unlike an angle), with the Jacobian
L ∂d_k/∂q · dq/dp from the quaternion sensitivities. The pose is reached when, besides the
distance, the angle between the frames is within ``tolerance`` / L [rad].
"""

from __future__ import annotations

import json
import math
import numbers
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.app.inverse.continuation import ScaledEquilibria
from rodsim.app.inverse.parameter_keys import NumericKey, numeric_keys
from rodsim.app.inverse.path_record import record_path
from rodsim.core.rod.quaternion import director, director_gradient, directors
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.io.cf_layout import variable_name
from rodsim.io.provenance import history
from rodsim.io.run_dataset import run_dataset
from rodsim.solvers import DEFAULT_INTEGRATOR, integrator_named
from rodsim.solvers.base import Progress
from rodsim.solvers.result import Result

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Reach", "reach", "tip_frame", "frame_angle", "DEFAULT_TOLERANCE"]

#: Distance [m] below which the target counts as reached.
DEFAULT_TOLERANCE = 1e-6
#: Targets farther than this many rod lengths from the rod's origin are refused.
MAX_REACH = 10.0
#: Scaled step from the start of an actuation value the tip is insensitive to.
NUDGE = 1e-2
#: A tip sensitivity (m per unit of scaled value) below this × the rod's length is zero.
NO_SENSITIVITY = 1e-12


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
    unstable: bool = False
    #: The orientation target (rows d1, d2, d3) and the angle [rad] of the tip frame
    #: reached from it; None without an orientation target.
    orientation: np.ndarray | None = None
    angle: float | None = None
    #: With tendon friction: the values moved but no tendon's termination tension did (the
    #: actuation stayed inside the backlash dead zone; docs/tendon.md, "Friction").
    dead_zone: bool = False
    #: The values of every equilibrium of the continuation, (evaluations, keys): the
    #: history of the final state's tendon friction (rodsim/app/inverse/path_record.py).
    path: np.ndarray | None = None

    def __repr__(self) -> str:
        from rodsim.app.inverse.summaries import summary

        return summary(self, html=False)

    def _repr_html_(self) -> str:
        from rodsim.app.inverse.summaries import summary

        return summary(self, html=True)

    def to_xarray(self) -> xr.Dataset:
        """The reach archive: the run archive of the scene with the values found, the
        target and the tip reached, and each actuation value as a scalar variable."""
        ds = run_dataset(self.result)
        ds["target"] = ("axis", self.target, {"units": "m", "long_name": "tip target"})
        ds["tip_reached"] = ("axis", self.tip, {"units": "m", "long_name": f"tip of rod "
                                                f"{self.rod!r} at the values found"})
        if self.orientation is not None:
            ds.attrs["orientation_target"] = json.dumps(self.orientation.tolist())
        if self.angle is not None:
            ds.attrs["orientation_angle"] = float(self.angle)
        for key, initial, value in zip(self.keys, self.initial, self.values, strict=True):
            name = variable_name(key.name)  # no dots (CF); the key is an attribute
            ds[name] = ((), value, {"units": key.unit, "long_name": f"{key.name} found",
                                    "scene_key": key.name})
            ds[f"{name}_initial"] = ((), initial, {"units": key.unit, "scene_key": key.name,
                                                   "long_name": f"starting value of {key.name}"})
        if self.path is not None:
            record_path(ds, self.keys, self.path, "reach")
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
            "reach_unstable": int(self.unstable),
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
          max_evaluations: int = 200, progress: Progress | None = None,
          orientation: Sequence[Sequence[float]] | None = None,
          integrator: str = DEFAULT_INTEGRATOR) -> Reach:
    """Values of the scene keys ``actuate`` that put the tip of ``rod`` (default: the first
    rod) at ``tip`` [m], and, if given, its frame at ``orientation`` (rows d1, d2, d3 of
    the last segment), from the scene's values (module docstring), every equilibrium solved
    by ``integrator`` (a registered name). ``Reach.success`` is
    False when the target is out of reach. Raises SceneError for bad keys or a bad target,
    EquilibriumFailure when an equilibrium on the way cannot be solved."""
    from scipy.optimize import least_squares

    started = time.perf_counter()
    if not isinstance(scene, Scene):
        raise SceneError(f"reach needs a Scene (rodsim.load_scene), got {type(scene).__name__}")
    try:
        target = np.asarray(tip, dtype=float)
    except (TypeError, ValueError):
        target = np.empty(0)
    if target.shape != (3,) or not np.all(np.isfinite(target)):
        raise SceneError("the tip target needs three finite coordinates X,Y,Z [m]")
    if isinstance(tolerance, bool) or not isinstance(tolerance, numbers.Real) or not (
            0 < tolerance < math.inf):
        raise SceneError(f"tolerance {str(tolerance)[:40]!r}: must be a distance > 0 [m]")
    if (not isinstance(actuate, (list, tuple)) or not actuate
            or not all(isinstance(key, str) for key in actuate)):
        raise SceneError("actuate must be a non-empty list of scene keys (e.g. "
                         "['tendon_actuation.force'])")
    frame = None if orientation is None else _checked_orientation(orientation)
    keys = numeric_keys(scene, list(actuate))
    rod = rod or next(iter(scene.rods))
    if not isinstance(rod, str) or rod not in scene.rods:
        raise SceneError(f"rod {str(rod)[:40]!r}: no such rod; rods: {', '.join(scene.rods)}")
    length = float(scene.rods[rod].length)
    away = float(np.max(np.abs(target - np.asarray(scene.rods[rod].origin, dtype=float))))
    if away > MAX_REACH * length:
        raise SceneError(f"the target is {away:.3g} m from the origin of rod {rod!r}, "
                         f"{away / length:.3g} times its length {length:g} m: no shape of the "
                         "rod reaches it (the target must be in metres)")
    problem, lower, upper = ScaledEquilibria.at_scene_values(scene, keys, rod,
                                                             integrator_named(integrator).name)
    initial = problem.values.copy()
    held = _terminations(problem.result("reach")) if _rubs(scene) else {}

    far = np.full(3 if frame is None else 9, 10.0 * length)

    def residuals(u: np.ndarray) -> np.ndarray:
        # A step to values without a solvable equilibrium gets a residual far beyond any
        # tip's, so that the trust region rejects it and shrinks.
        if not problem.reached(u):
            return far
        gap = problem.nodes()[-1] - target
        if progress is not None:
            progress(None, f"reach: equilibrium {problem.evaluations}, tip "
                     f"{np.linalg.norm(gap):.3g} m from the target")
        if frame is None:
            return gap
        q = problem.tip_quaternion()
        return np.concatenate([gap, *(length * (_unit_director(q, k)[0] - frame[k])
                                      for k in (0, 2))])

    def jacobian(u: np.ndarray) -> np.ndarray:
        problem.at(u)
        position, quaternion = problem.tip_sensitivity()
        if frame is None:
            return position.T
        q = problem.tip_quaternion()
        rows = [length * _unit_director(q, k)[1] @ quaternion.T for k in (0, 2)]
        return np.vstack([position.T, *rows])

    start = np.array(problem.start, dtype=float)
    insensitive = np.linalg.norm(jacobian(start), axis=0) <= NO_SENSITIVITY * length
    for column in np.flatnonzero(insensitive):  # e.g. a tendon at zero tension
        room_up, room_down = upper[column] - start[column], start[column] - lower[column]
        step = min(NUDGE, 0.5 * max(room_up, room_down))
        start[column] += step if room_up >= room_down else -step
    solution = least_squares(residuals, start, jac=jacobian,
                             bounds=(lower, upper), xtol=1e-12, ftol=1e-15, gtol=1e-15,
                             max_nfev=max_evaluations, method="trf")
    values = problem.values_of(solution.x)
    problem.at(solution.x)  # the equilibrium the optimiser measured there (no cold re-solve)
    final = problem.result("reach")
    stability = final.stability
    assert stability is not None  # ScaledEquilibria.result assesses its equilibrium
    reached = final.tip(rod)
    distance = float(np.linalg.norm(reached - target))
    unstable = stability.unstable
    success = distance <= tolerance and not unstable
    angle, turned = None, ""
    if frame is not None:
        angle = frame_angle(tip_frame(final, rod), frame)
        success = success and angle <= tolerance / length
        turned = (f" and {angle:.3g} rad from the orientation (tolerance "
                  f"{tolerance / length:.3g} rad)")
    dead_zone = bool(held) and bool(np.any(values != initial)) and _terminations(final) == held
    if dead_zone:
        turned += (" (inside the backlash dead zone: the actuation moved, no tendon's "
                   "termination tension did)")
    described = ", ".join(f"{k.name} = {v:.6g} {k.unit}" for k, v in zip(keys, values,
                                                                          strict=True))
    where = ", ".join(f"{c:.6g}" for c in reached)
    if unstable:
        message = (f"the best tip found, ({where}) m, {distance:.3g} m from the target"
                   f"{turned}, is an UNSTABLE equilibrium (stiffness "
                   f"{stability.eigenvalue_text}: e.g. a rod compressed past "
                   f"buckling), with {described}; not a usable actuation")
    elif success:
        message = f"reached within {distance:.3g} m{turned} with {described}"
    else:
        message = (f"target out of reach: the closest tip found is ({where}) m, "
                   f"{distance:.3g} m from the target (tolerance {tolerance:.3g} m){turned}, "
                   f"with {described}")
    return Reach(keys, initial, values, target, reached, distance, tolerance, success,
                 message, problem.evaluations, problem.jacobians,
                 time.perf_counter() - started, rod, final, unstable, frame, angle, dead_zone,
                 np.array(problem.path))


def _rubs(scene: Scene) -> bool:
    """Whether a string tendon of ``scene`` has friction."""
    def rubs(string: Any) -> bool:
        return (string.friction > 0.0 or string.static_friction > 0.0
                or any(value > 0.0 for value in string.friction_points)
                or any(value > 0.0 for value in string.friction_profile)
                or any(value > 0.0 for value in string.static_friction_profile))

    return any(options.coupling == "string"
               and rubs(scene.term_options("tendons", name, "tendon_string"))
               for name, options in scene.tendons.items())


def _terminations(result: Result) -> dict[str, float]:
    """Each friction tendon's termination tension [N] at ``result``."""
    return {name: float(tension[-1]) for name, (_, tension) in result.tension_profiles.items()}
