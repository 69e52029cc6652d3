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
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.io.cf_layout import variable_name
from rodsim.io.provenance import history
from rodsim.io.run_dataset import run_dataset
from rodsim.solvers.base import Progress
from rodsim.solvers.result import Result

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Reach", "reach", "DEFAULT_TOLERANCE"]

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

    def to_xarray(self) -> xr.Dataset:
        """The reach archive: the run archive of the scene with the values found, the
        target and the tip reached, and each actuation value as a scalar variable."""
        ds = run_dataset(self.result)
        ds["target"] = ("axis", self.target, {"units": "m", "long_name": "tip target"})
        ds["tip_reached"] = ("axis", self.tip, {"units": "m", "long_name": f"tip of rod "
                                                f"{self.rod!r} at the values found"})
        for key, initial, value in zip(self.keys, self.initial, self.values, strict=True):
            name = variable_name(key.name)  # no dots (CF); the key is an attribute
            ds[name] = ((), value, {"units": key.unit, "long_name": f"{key.name} found",
                                    "scene_key": key.name})
            ds[f"{name}_initial"] = ((), initial, {"units": key.unit, "scene_key": key.name,
                                                   "long_name": f"starting value of {key.name}"})
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


def reach(scene: Scene, tip: Sequence[float], actuate: Sequence[str], *,
          rod: str | None = None, tolerance: float = DEFAULT_TOLERANCE,
          max_evaluations: int = 200, progress: Progress | None = None) -> Reach:
    """Values of the scene keys ``actuate`` that put the tip of ``rod`` (default: the first
    rod) at ``tip`` [m], from the scene's values (module docstring). ``Reach.success`` is
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
    keys = numeric_keys(scene, actuate)
    rod = rod or next(iter(scene.rods))
    if rod not in scene.rods:
        raise SceneError(f"rod {rod!r}: no such rod; rods: {', '.join(scene.rods)}")
    problem, lower, upper = ScaledEquilibria.at_scene_values(scene, keys, rod)
    initial = problem.values.copy()

    far = np.full(3, 10.0 * scene.rods[rod].length)

    def residuals(u: np.ndarray) -> np.ndarray:
        # A step to values without a solvable equilibrium gets a residual far beyond any
        # tip's, so that the trust region rejects it and shrinks.
        if not problem.reached(u):
            return far
        gap = problem.nodes()[-1] - target
        if progress is not None:
            progress(None, f"reach: equilibrium {problem.evaluations}, tip "
                     f"{np.linalg.norm(gap):.3g} m from the target")
        return gap

    def jacobian(u: np.ndarray) -> np.ndarray:
        problem.at(u)
        return problem.node_sensitivity()[:, -1, :].T

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
    described = ", ".join(f"{k.name} = {v:.6g} {k.unit}" for k, v in zip(keys, values,
                                                                          strict=True))
    where = ", ".join(f"{c:.6g}" for c in reached)
    message = (f"reached within {distance:.3g} m with {described}" if success else
               f"target out of reach: the closest tip found is ({where}) m, {distance:.3g} m "
               f"from the target (tolerance {tolerance:.3g} m), with {described}")
    return Reach(keys, initial, values, target, reached, distance, tolerance, success,
                 message, problem.evaluations, problem.jacobians,
                 time.perf_counter() - started, rod, final)
