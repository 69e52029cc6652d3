"""The outcome of one run, and its xarray Dataset (the archive's content).

Dataset layout (docs/archive.md): all rods' control points are concatenated along one
``node`` dimension, with the coordinate ``rod`` naming the rod of each node (a CF
"contiguous ragged array"); likewise ``segment`` for quaternions. Select one rod with
``ds.sel(node=ds.rod == "tendon", segment=ds.segment_rod == "tendon")`` or
:meth:`Result.positions`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.core.scene import Scene
from rodsim.version import __version__

if TYPE_CHECKING:
    import xarray as xr

    from rodsim.core.model import Model
    from rodsim.core.stability import Stability

__all__ = ["Result", "RodShape", "SCHEMA_VERSION", "count_text"]

#: Version of the archive layout; bump when variables or attributes change meaning.
SCHEMA_VERSION = "1"

#: Statistics every run reports (missing ones are 0; NaN where an integrator cannot count
#: them: CVODE's and IDA's own Newton iterations and linear solves happen inside SUNDIALS,
#: and scikit-sundae does not report them), with their meaning.
STAT_DOCS = {
    "steps": "integrator steps (time steps or load steps)",
    "newton_iters": "Newton iterations (nonlinear solver iterations)",
    "force_evals": "evaluations of F(x) (RHS / residual evaluations)",
    "jacobian_evals": "evaluations of the analytic Jacobian",
    "linear_solves": "sparse or band linear solves",
    "wall_time": "wall time to equilibrium [s]",
    "effective_tolerance": "residual tolerance used: the requested one, or the model's "
                           "round-off floor if higher",
}


def count_text(value: float) -> str:
    """A statistic for display: the integer, or ``n/a`` when it was not counted (NaN)."""
    return "n/a" if np.isnan(value) else str(int(value))


@dataclass(frozen=True)
class RodShape:
    """Equilibrium of one rod: control points (N, 3) [m], quaternions (N − 1, 4), rest s [m]."""

    positions: np.ndarray
    quaternions: np.ndarray
    s: np.ndarray
    segment_s: np.ndarray

    @property
    def tip(self) -> np.ndarray:
        return self.positions[-1]


@dataclass
class Result:
    """One run of one integrator on one scene.

    Use :meth:`to_xarray` for the archive Dataset, :meth:`positions` for a rod's centerline.
    """

    scene: Scene
    integrator: str
    options: dict[str, Any]
    success: bool
    message: str
    residual: float
    stats: dict[str, float]
    rods: dict[str, RodShape]
    state: np.ndarray
    history: dict[str, list[float]] = field(default_factory=dict)
    version: str = __version__
    #: Stability verdict of a successful run's equilibrium (rodsim/core/stability.py); None for
    #: a failed run.
    stability: Stability | None = None

    @classmethod
    def from_model(cls, model: Model, x: np.ndarray, *, integrator: str,
                   options: dict[str, Any], success: bool, message: str, residual: float,
                   stats: dict[str, float], history: dict[str, list[float]],
                   stability: Stability | None = None) -> Result:
        full = model.full(x)
        rods = {
            name: RodShape(full[rod.layout.position_index], full[rod.layout.quaternion_index],
                           rod.geometry.node_s, rod.geometry.segment_s)
            for name, rod in model.rods.items()
        }
        stats = {key: float(stats.get(key, 0.0)) for key in STAT_DOCS} | {
            k: float(v) for k, v in stats.items() if k not in STAT_DOCS}
        return cls(model.scene, integrator, dict(options), success, message, residual, stats,
                   rods, np.array(x, dtype=float), history, stability=stability)

    def positions(self, rod: str | None = None) -> np.ndarray:
        """Control points of ``rod`` (default: the first rod), shape (N, 3) [m]."""
        return self.rods[rod or next(iter(self.rods))].positions

    def tip(self, rod: str | None = None) -> np.ndarray:
        """Tip (last control point) of ``rod`` (default: the first rod) [m]."""
        return self.positions(rod)[-1]

    @property
    def quaternion_norm_error(self) -> float:
        """Largest | |q| − 1 | over every segment of every rod."""
        return float(max(np.max(np.abs(np.linalg.norm(r.quaternions, axis=1) - 1.0))
                         for r in self.rods.values()))

    def to_xarray(self) -> xr.Dataset:
        """The archive Dataset of this run (see the module docstring and docs/archive.md)."""
        import xarray as xr  # imported here: a solve alone does not need it

        names = list(self.rods)
        shapes = list(self.rods.values())
        node_rod = np.concatenate([[n] * len(r.s) for n, r in zip(names, shapes, strict=True)])
        seg_rod = np.concatenate([[n] * len(r.segment_s)
                                  for n, r in zip(names, shapes, strict=True)])
        ds = xr.Dataset(
            data_vars={
                "position": (("node", "axis"), np.concatenate([r.positions for r in shapes]),
                             {"units": "m", "long_name": "control point position"}),
                "quaternion": (("segment", "component"),
                               np.concatenate([r.quaternions for r in shapes]),
                               {"units": "1", "long_name": "segment orientation quaternion "
                                "(q1, q2, q3 imaginary, q4 real)"}),
            },
            coords={
                "axis": ("axis", ["x", "y", "z"], {"long_name": "world axis"}),
                "component": ("component", ["q1", "q2", "q3", "q4"],
                              {"long_name": "quaternion component"}),
                "s": ("node", np.concatenate([r.s for r in shapes]),
                      {"units": "m", "long_name": "rest arc length of the control point"}),
                "rod": ("node", node_rod.astype(str), {"long_name": "rod of the control point"}),
                "segment_s": ("segment", np.concatenate([r.segment_s for r in shapes]),
                              {"units": "m", "long_name": "rest arc length of the segment "
                               "midpoint"}),
                "segment_rod": ("segment", seg_rod.astype(str),
                                {"long_name": "rod of the segment"}),
            },
        )
        if self.history.get("time"):
            time_attrs = ({"units": "1", "long_name": "load fraction after each load step"}
                          if self.integrator == "static" else
                          {"units": "s", "long_name": "pseudo-time after each step"})
            ds["history_time"] = ("step", np.asarray(self.history["time"], dtype=float),
                                  time_attrs)
            ds["history_residual"] = ("step", np.asarray(self.history["residual"], dtype=float),
                                      {"units": "1", "long_name": "scaled force residual "
                                       "after each step"})
            ds["history_tip"] = (("step", "axis"), np.asarray(self.history["tip"], dtype=float),
                                 {"units": "m", "long_name": f"tip of rod {names[0]!r} after "
                                  "each step"})
        ds.attrs.update(self._attributes())
        return ds

    def _attributes(self) -> dict[str, Any]:
        attrs: dict[str, Any] = {
            "title": f"rodsim run of scene {self.scene.name!r} with the {self.integrator} "
                     "integrator",
            "rodsim_version": self.version,
            "schema_version": SCHEMA_VERSION,
            "integrator": self.integrator,
            "integrator_options": json.dumps(self.options, sort_keys=True),
            "success": int(self.success),
            "message": self.message,
            "residual": float(self.residual),
            "solver_tolerance": float(self.scene.data["solver"]["tolerance"]),
            "quaternion_norm_error": self.quaternion_norm_error,
            "scene_json": self.scene.to_json(),
            "scene_toml": self.scene.source,
        }
        if self.stability is not None:
            attrs["stable"] = int(self.stability.stable)
            attrs["stiffness_min_eigenvalue"] = float(self.stability.min_eigenvalue)
        for key, value in self.stats.items():
            attrs[f"stats_{key}"] = float(value)
        attrs.update(flatten_scene(self.scene.data))
        return attrs


def flatten_scene(data: dict[str, Any], prefix: str = "scene") -> dict[str, Any]:
    """Scene values as flat ``scene.rods.catheter.length``-style attributes (netCDF-safe)."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        name = f"{prefix}.{key}"
        if isinstance(value, dict):
            out.update(flatten_scene(value, name))
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            for i, item in enumerate(value):
                out.update(flatten_scene(item, f"{name}.{i}"))
        elif isinstance(value, bool):
            out[name] = int(value)
        elif isinstance(value, list):
            out[name] = (", ".join(value) if all(isinstance(v, str) for v in value)
                         else np.asarray(value, dtype=float))
        else:
            out[name] = value
    return out
