"""The archive contract (docs/archive.md) as checks: what a run archive, a study archive and
a study's point record must hold before anything reads them.

:func:`check_archive` runs when an archive is read (:func:`rodsim.io.archive.read_dataset`),
so ``rerun`` and ``plot`` only ever see archives of the right shape; a tampered or
truncated archive — a missing attribute or variable, JSON that is not a JSON object or is
nested absurdly deep, a stored scene whose node counts disagree with the stored positions,
sweep values that do not fit their dimension — raises :class:`ArchiveSchemaError` with a
one-line message naming what is wrong. :func:`check_point_record` does the same for the
point files of a study's parts folder (docs/archive.md, "The parts folder").
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from datetime import datetime
from typing import Any

import numpy as np
import xarray as xr

from rodsim.core.scene import Scene, SceneError
from rodsim.io.cf_layout import key_variable
from rodsim.io.provenance import CONVENTIONS

__all__ = ["ArchiveSchemaError", "check_archive", "check_point_record", "parse_json_object",
           "MAX_SIGMA_POINTS", "KINDS", "SCHEMA_VERSION", "READABLE_SCHEMA_VERSIONS"]

#: Version of the archive layout; bump when variables or attributes change meaning.
#: 2: CF-1.8 provenance attributes (Conventions, history, source, references, date_created,
#: library versions, git commit) in every archive, the ``step`` coordinate, the scene only as
#: ``scene_json`` (no more ``scene.*`` attributes), no _FillValue on coordinates.
#: 3: the CF file layout (rodsim/io/cf_layout.py): text dimension coordinates stored as
#: numeric indices with ``<dim>_label`` beside them, text as character arrays, scene values
#: of track, fit and reach archives in variables named without dots (attribute
#: ``scene_key``); a _FillValue on a coordinate (as xarray adds when saving an archive
#: back) is accepted on read in every schema.
SCHEMA_VERSION = "3"

#: Layouts this rodsim reads: schema 1 archives (before the CF attributes) hold the same
#: variables, ``scene_json`` and ``integrator_options``, so they are read, re-run and plotted
#: as they are; only the checks of the provenance attributes are skipped for them.
READABLE_SCHEMA_VERSIONS = ("1", "2", "3")

#: Text attributes every schema 2 archive carries (docs/archive.md, "Conventions and
#: provenance"; git_commit and git_dirty only from a checkout).
PROVENANCE_ATTRIBUTES = ("history", "source", "references", "date_created", "rodsim_version",
                         "numpy_version", "scipy_version", "scikit_sundae_version",
                         "sundials_version")

#: Status codes of a study point (the ``status`` variable of a study archive).
STATUS = {"ok": 0, "solver_failure": 1, "error": 2}

#: Largest σ grid a study archive may declare (the shipped studies use 101).
MAX_SIGMA_POINTS = 100_001

#: Keys every study spec (``spec_json``) holds.
SPEC_KEYS = ("name", "title", "paper", "size", "integrator", "reference", "plot", "history",
             "sigma_points", "base_scene_json", "sweeps")


class ArchiveSchemaError(ValueError):
    """An archive or a point record does not follow the archive contract."""


def parse_json_object(text: Any, what: str) -> dict[str, Any]:
    """``text`` parsed as a JSON object (dict), or ArchiveSchemaError naming ``what``."""
    if not isinstance(text, str):
        raise ArchiveSchemaError(f"{what} is not text")
    try:
        value = json.loads(text)
    except RecursionError:
        raise ArchiveSchemaError(f"{what} is nested too deeply") from None
    except ValueError as exc:
        raise ArchiveSchemaError(f"{what} is not valid JSON ({exc})") from None
    if not isinstance(value, dict):
        raise ArchiveSchemaError(f"{what} is not a JSON object (got {type(value).__name__})")
    return value


def stored_scene(text: Any, what: str) -> Scene:
    """A scene stored as JSON (``scene_json``, ``base_scene_json``), validated."""
    raw = parse_json_object(text, what)
    try:
        return Scene.from_dict(raw)
    except RecursionError:
        raise ArchiveSchemaError(f"{what} is nested too deeply") from None
    except SceneError as exc:
        raise ArchiveSchemaError(f"{what} is not a valid scene: {exc}") from None


def _attribute(ds: xr.Dataset, name: str) -> Any:
    if name not in ds.attrs:
        raise ArchiveSchemaError(f"attribute {name!r} is missing")
    return ds.attrs[name]


def _variable(ds: xr.Dataset, name: str, dims: tuple[str, ...], numeric: bool = True
              ) -> xr.DataArray:
    """Variable or coordinate ``name`` with exactly ``dims`` (numeric unless told)."""
    if name not in ds.variables:
        raise ArchiveSchemaError(f"variable {name!r} is missing")
    variable = ds[name]
    if variable.dims != dims:
        raise ArchiveSchemaError(f"variable {name!r} has dimensions {variable.dims}, "
                                 f"expected {dims}")
    if numeric and variable.dtype.kind not in "fiu":
        raise ArchiveSchemaError(f"variable {name!r} is not numeric ({variable.dtype})")
    return variable


def _size(ds: xr.Dataset, dim: str, expected: int, why: str) -> None:
    if ds.sizes.get(dim) != expected:
        raise ArchiveSchemaError(f"dimension {dim!r} has size {ds.sizes.get(dim)}, expected "
                                 f"{expected} ({why})")


def _labels(ds: xr.Dataset, dim: str, labels: list[str]) -> None:
    """The coordinate of ``dim`` holds exactly ``labels`` (what selections by label use)."""
    stored = _variable(ds, dim, (dim,), numeric=False).values
    if [str(v) for v in stored] != labels:
        raise ArchiveSchemaError(f"coordinate {dim!r} is not {', '.join(labels)}")


#: Archive kinds (attribute ``kind``; a run archive without it is a ``run``): a fit or a
#: reach archive is a run archive of the fitted or reached scene with extra variables.
KINDS = ("run", "track", "fit", "reach")


def check_archive(ds: xr.Dataset) -> None:
    """Check a run archive (also a fit or reach archive), a track archive (``kind`` =
    ``track``) or a study archive (``study`` attribute) against its contract."""
    kind = ds.attrs.get("kind", "run")
    if str(ds.attrs.get("schema_version")) != "1":
        _check_provenance(ds)
    if "study" in ds.attrs:
        _check_study(ds)
    elif kind not in KINDS:
        raise ArchiveSchemaError(f"attribute 'kind' = {str(kind)[:40]!r} is not one of "
                                 + ", ".join(KINDS))
    elif kind == "track":
        _check_run(ds, ("step",))
        _check_track(ds)
    else:
        _check_run(ds)


def _check_provenance(ds: xr.Dataset) -> None:
    """The CF and provenance attributes of a schema 2 archive, and a coordinate for the
    ``step`` dimension."""
    if ds.attrs.get("Conventions") != CONVENTIONS:
        raise ArchiveSchemaError(f"attribute 'Conventions' is not {CONVENTIONS!r}")
    for name in PROVENANCE_ATTRIBUTES:
        value = _attribute(ds, name)
        if not isinstance(value, str) or not value.strip():
            raise ArchiveSchemaError(f"attribute {name!r} is not a non-empty text")
    created = ds.attrs["date_created"]
    try:
        datetime.strptime(created, "%Y-%m-%dT%H:%M:%SZ")
    except ValueError:
        raise ArchiveSchemaError(f"attribute 'date_created' = {created[:40]!r} is not an ISO "
                                 "8601 UTC time (YYYY-MM-DDThh:mm:ssZ)") from None
    if "git_dirty" in ds.attrs and "git_commit" not in ds.attrs:
        raise ArchiveSchemaError("attribute 'git_dirty' without 'git_commit'")
    if "step" in ds.dims:
        _variable(ds, "step", ("step",))


def _check_track(ds: xr.Dataset) -> None:
    ramps = parse_json_object(_attribute(ds, "ramp_json"), "attribute 'ramp_json'")
    if not ramps:
        raise ArchiveSchemaError("attribute 'ramp_json' names no ramped key")
    for key, values in ramps.items():
        if not isinstance(values, list) or not all(_finite_number(v) for v in values):
            raise ArchiveSchemaError(f"ramp_json {key[:40]!r} is not a list of numbers")
        if len(values) < ds.sizes.get("step", 0):
            raise ArchiveSchemaError(f"ramp_json {key[:40]!r} has fewer values than steps")
        try:
            variable = key_variable(ds, key)
        except KeyError:
            raise ArchiveSchemaError(f"no variable holds ramped key {key[:60]!r}") from None
        _variable(ds, variable.name, ("step",))


def _check_run(ds: xr.Dataset, leading: tuple[str, ...] = ()) -> None:
    from rodsim.solvers import registered_integrators

    integrator = _attribute(ds, "integrator")
    integrators = registered_integrators()
    if not isinstance(integrator, str) or integrator not in integrators:
        raise ArchiveSchemaError(f"attribute 'integrator' = {str(integrator)[:40]!r} is not "
                                 "one of " + ", ".join(integrators))
    parse_json_object(_attribute(ds, "integrator_options"), "attribute 'integrator_options'")
    scene = stored_scene(_attribute(ds, "scene_json"), "attribute 'scene_json'")
    _variable(ds, "position", (*leading, "node", "axis"))
    _variable(ds, "quaternion", (*leading, "segment", "component"))
    _labels(ds, "axis", ["x", "y", "z"])
    _labels(ds, "component", ["q1", "q2", "q3", "q4"])
    rods = _variable(ds, "rod", ("node",), numeric=False).values.astype(str)
    segment_rods = _variable(ds, "segment_rod", ("segment",), numeric=False).values.astype(str)
    for name, rod in scene.rods.items():
        nodes = rod.nodes
        for what, stored, expected in (("control points", rods, nodes),
                                       ("segments", segment_rods, nodes - 1)):
            count = int(np.sum(stored == name))
            if count != expected:
                raise ArchiveSchemaError(f"rod {name!r} has {count} stored {what}, its scene "
                                         f"(scene_json) says {expected}")
    _size(ds, "node", sum(rod.nodes for rod in scene.rods.values()),
          "the scene's control points")


def _check_study(ds: xr.Dataset) -> None:
    from rodsim.solvers import registered_integrators

    spec = parse_json_object(_attribute(ds, "spec_json"), "attribute 'spec_json'")
    for key in SPEC_KEYS:
        if key not in spec:
            raise ArchiveSchemaError(f"spec_json has no {key!r}")
    for key, spec_key in (("study", "name"), ("size", "size")):
        if ds.attrs.get(key) != spec[spec_key]:
            raise ArchiveSchemaError(f"attribute {key!r} does not match spec_json's "
                                     f"{spec_key!r}")
    integrator = spec["integrator"]
    if integrator is not None and (not isinstance(integrator, str)
                                   or integrator not in registered_integrators()):
        raise ArchiveSchemaError(f"spec_json integrator {str(integrator)[:40]!r} is unknown")
    points = spec["sigma_points"]
    if isinstance(points, bool) or not isinstance(points, int) or not (
            2 <= points <= MAX_SIGMA_POINTS):
        raise ArchiveSchemaError(f"spec_json sigma_points = {str(points)[:40]} is not a whole "
                                 f"number from 2 to {MAX_SIGMA_POINTS}")
    if not isinstance(spec["history"], bool):
        raise ArchiveSchemaError("spec_json history is not true or false")
    scene = stored_scene(spec["base_scene_json"], "spec_json base_scene_json")
    stored_scene(_attribute(ds, "scene_json"), "attribute 'scene_json'")
    sweeps = spec["sweeps"]
    if not isinstance(sweeps, list) or not sweeps:
        raise ArchiveSchemaError("spec_json sweeps is not a non-empty list")
    dims = []
    for i, sweep in enumerate(sweeps):
        _check_sweep(ds, sweep, f"spec_json sweeps[{i}]")
        dims.append(sweep["name"])
    if len(set(dims)) != len(dims):
        raise ArchiveSchemaError("spec_json sweeps repeat a name")
    shape = tuple(dims)
    _size(ds, "sigma", points, "spec_json sigma_points")
    _labels(ds, "axis", ["x", "y", "z"])
    rods = _variable(ds, "rod", ("rod",), numeric=False).values.astype(str)
    if set(rods) != set(scene.rods) or len(rods) != len(scene.rods):
        raise ArchiveSchemaError(f"coordinate 'rod' ({', '.join(rods)[:60]}) does not name "
                                 "the base scene's rods")
    _variable(ds, "status", shape)
    _variable(ds, "message", shape, numeric=False)
    _variable(ds, "residual", shape)
    _variable(ds, "tip", (*shape, "rod", "axis"))
    _variable(ds, "centerline", (*shape, "rod", "sigma", "axis"))
    _variable(ds, "sigma", ("sigma",))


def _check_sweep(ds: xr.Dataset, sweep: Any, what: str) -> None:
    if not isinstance(sweep, Mapping):
        raise ArchiveSchemaError(f"{what} is not a JSON object")
    for key in ("name", "key", "values", "labels"):
        if key not in sweep:
            raise ArchiveSchemaError(f"{what} has no {key!r}")
    name, key, values, labels = sweep["name"], sweep["key"], sweep["values"], sweep["labels"]
    if not isinstance(name, str) or not name:
        raise ArchiveSchemaError(f"{what} name is not a non-empty string")
    keys = [key] if isinstance(key, str) else key
    if not isinstance(keys, list) or not keys or not all(isinstance(k, str) for k in keys):
        raise ArchiveSchemaError(f"{what} key is not a scene key or a list of them")
    if not isinstance(values, list) or not values:
        raise ArchiveSchemaError(f"{what} values is not a non-empty list")
    if not isinstance(key, str) and not all(
            isinstance(v, list) and len(v) == len(keys) for v in values):
        raise ArchiveSchemaError(f"{what} values do not give one value per key")
    if labels is not None and (not isinstance(labels, list) or len(labels) != len(values)):
        raise ArchiveSchemaError(f"{what} labels do not match its values")
    if name not in ds.dims:
        raise ArchiveSchemaError(f"{what} names dimension {name[:40]!r}, which is missing")
    _size(ds, name, len(values), f"{what} has {len(values)} values")


def _finite_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(
        value)


def _number(value: Any) -> bool:
    """A number, NaN allowed (statistics an integrator cannot count are NaN)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def check_point_record(record: Any, sigma_points: int, rods: list[str],
                       stats: tuple[str, ...]) -> None:
    """Check one point record of a study's parts folder (as :func:`rodsim.app.study.
    evaluate_point` writes it) for a study spec with ``sigma_points`` samples of σ, whose
    scene has ``rods`` and whose records carry the statistics ``stats``. A successful point
    must hold finite numbers of the right shapes; a failed one, its status and message."""

    if not isinstance(record, dict):
        raise ArchiveSchemaError("not a JSON object")
    for key in ("index", "status", "message"):
        if key not in record:
            raise ArchiveSchemaError(f"no {key!r}")
    index = record["index"]
    if not isinstance(index, list) or not all(
            isinstance(i, int) and not isinstance(i, bool) for i in index):
        raise ArchiveSchemaError("index is not a list of whole numbers")
    if record["status"] not in STATUS.values() or isinstance(record["status"], bool):
        raise ArchiveSchemaError(f"status {str(record['status'])[:20]!r} is not one of "
                                 + ", ".join(map(str, STATUS.values())))
    if not isinstance(record["message"], str):
        raise ArchiveSchemaError("message is not text")
    if "residual" in record and not _number(record["residual"]):
        raise ArchiveSchemaError("residual is not a number")
    if "stats" in record:
        recorded = record["stats"]
        if not isinstance(recorded, dict) or not all(
                key in recorded and _number(recorded[key]) for key in stats):
            raise ArchiveSchemaError("stats lack a statistic or hold a non-number")
    if record["status"] != STATUS["ok"]:
        return
    for key in ("residual", "stats", "quaternion_norm_error", "tip", "centerline"):
        if key not in record:
            raise ArchiveSchemaError(f"a successful point without {key!r}")
    for key in ("residual", "quaternion_norm_error", "tip_error", "area_error"):
        if key in record and not _finite_number(record[key]):
            raise ArchiveSchemaError(f"{key} is not a finite number")
    for key, shape in (("tip", (3,)), ("centerline", (sigma_points, 3))):
        stored = record[key]
        if not isinstance(stored, dict) or sorted(stored) != sorted(rods):
            raise ArchiveSchemaError(f"{key} does not name the scene's rods")
        for rod, values in stored.items():
            try:
                array = np.asarray(values, dtype=float)
            except (TypeError, ValueError):
                raise ArchiveSchemaError(f"{key} of rod {rod!r} is not numbers") from None
            if array.shape != shape or not np.all(np.isfinite(array)):
                raise ArchiveSchemaError(f"{key} of rod {rod!r} is not {shape} finite numbers")
    _check_history(record)


def _check_history(record: dict[str, Any]) -> None:
    """The optional per-step history: times, tips (steps × 3) and errors of equal length."""
    if not any(key in record for key in ("history_time", "history_tip", "history_error")):
        return
    shapes = {}
    for key in ("history_time", "history_tip", "history_error"):
        try:
            shapes[key] = np.asarray(record.get(key, []), dtype=float).shape
        except (TypeError, ValueError):
            raise ArchiveSchemaError(f"{key} is not numbers") from None
    steps = shapes["history_time"]
    if len(steps) != 1 or shapes["history_tip"] not in ((steps[0], 3), (0,)) or (
            shapes["history_error"] not in (steps, (0,))):
        raise ArchiveSchemaError("history_time, history_tip and history_error do not have "
                                 "one entry per step")
