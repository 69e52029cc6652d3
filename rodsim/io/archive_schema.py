"""The archive contract (docs/archive.md) as checks: what a run archive, a study archive and
a study's point record must hold before anything reads them.

``check_archive`` runs when an archive is read (``rodsim.io.archive.read_dataset``),
so ``rerun`` and ``plot`` only ever see archives of the right shape; a tampered or
truncated archive — a missing attribute or variable, JSON that is not a JSON object or is
nested absurdly deep, a stored scene whose node counts disagree with the stored positions,
sweep values that do not fit their dimension — raises ``ArchiveSchemaError`` with a
one-line message naming what is wrong. The point records of a study's parts folder have
their own contract (``rodsim.io.point_record``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Hashable, Mapping
from datetime import datetime
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.core.scene import Scene, SceneError
from rodsim.core.tendon_friction import SLIP_NAMES
from rodsim.io.cf_layout import key_variable
from rodsim.io.provenance import CONVENTIONS

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["ArchiveSchemaError", "check_archive", "check_attribute_sizes", "finite_number",
           "parse_json_object",
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

#: Longest JSON or TOML attribute (scene_json, scene_toml, spec_json, ramp_json, …) [chars]:
#: a scene file is at most 1 MiB, but its resolved scene holds the points of a vessel's csv
#: centerline (10 MB of JSON for 400 000 points; a csv may hold 64 MiB), and a ramp of the
#: most steps takes 2.5 MB per ramped key. ``rodsim`` refuses a scene beyond it before any
#: work (:func:`check_attribute_sizes`), so that every archive it writes, it reads.
MAX_JSON_CHARS = 64 * 1024 ** 2
#: Longest other text attribute (a title, a message, a history line, units) [chars].
MAX_TEXT_CHARS = 10_000
#: Deepest nesting of a JSON attribute (a scene is 4 levels deep, a study spec 6).
MAX_JSON_DEPTH = 32
#: Most steps of a track archive (rodsim.app.inverse.track.MAX_STEPS) or of a history.
MAX_STEPS = 100_000
#: Attributes holding JSON or TOML (longer than plain text).
LONG_ATTRIBUTES = ("scene_json", "scene_toml", "spec_json", "ramp_json", "integrator_options",
                   "fit_parameters", "reach_parameters")

#: The error estimates a run, fit, reach or track archive may carry, in units of L
#: (docs/archive.md; rodsim/app/trust.py): attributes, and in a track archive also variables
#: along ``step``, in a study archive variables along its point dimensions.
ERROR_ESTIMATES = ("discretisation_error", "penalty_error")

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
    _check_depth(value, what)
    return value


def parse_json_names(text: Any, what: str) -> list[str]:
    """``text`` parsed as a non-empty JSON list of distinct names (the fitted or actuated
    keys), or ArchiveSchemaError naming ``what``."""
    if not isinstance(text, str):
        raise ArchiveSchemaError(f"{what} is not text")
    try:
        value = json.loads(text)
    except (ValueError, RecursionError):
        raise ArchiveSchemaError(f"{what} is not valid JSON") from None
    if (not isinstance(value, list) or not value or len(set(map(str, value))) != len(value)
            or not all(isinstance(v, str) and 0 < len(v) <= 200 for v in value)):
        raise ArchiveSchemaError(f"{what} is not a list of distinct scene keys")
    return value


def _check_depth(value: Any, what: str) -> None:
    """ArchiveSchemaError when ``value`` nests deeper than ``MAX_JSON_DEPTH``."""
    level, depth = [value], 0
    while level:
        depth += 1
        if depth > MAX_JSON_DEPTH:
            raise ArchiveSchemaError(f"{what} is nested too deeply (more than "
                                     f"{MAX_JSON_DEPTH} levels)")
        level = [item for container in level if isinstance(container, (dict, list))
                 for item in (container.values() if isinstance(container, dict)
                              else container)]


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


def _variable(ds: xr.Dataset, name: Hashable, dims: tuple[str, ...], numeric: bool = True
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
#: reach archive is a run archive of the fitted or reached scene with extra variables, a
#: modes archive one of the equilibrium with a ``mode`` dimension, a batch archive holds
#: many equilibria along ``case`` (rodsim/io/batch_dataset.py), a trajectory archive a run in
#: physical time along ``time`` (rodsim/io/trajectory_dataset.py).
KINDS = ("run", "track", "fit", "reach", "modes", "batch", "trajectory")


def check_archive(ds: xr.Dataset) -> None:
    """Check a run archive (also a fit or reach archive), a track archive (``kind`` =
    ``track``) or a study archive (``study`` attribute) against its contract."""
    _check_sizes(ds)
    kind = ds.attrs.get("kind", "run")
    if str(ds.attrs.get("schema_version")) != "1":
        _check_provenance(ds)
    if "study" in ds.attrs:
        _check_study(ds)
    elif not isinstance(kind, str) or kind not in KINDS:
        raise ArchiveSchemaError(f"attribute 'kind' = {str(kind)[:40]!r} is not one of "
                                 + ", ".join(KINDS))
    elif kind == "track":
        _check_run(ds, ("step",))
        _check_track(ds)
    elif kind == "batch":
        _check_run(ds, ("case",))
        _check_batch(ds)
    elif kind == "trajectory":
        _check_trajectory(ds)
    else:
        _check_run(ds)
        if kind == "fit":
            _check_fit(ds)
        elif kind == "reach":
            _check_reach(ds)
        elif kind == "modes":
            _check_modes(ds)


def _check_size(name: str, value: Any, where: str) -> None:
    """One attribute's size: JSON and TOML ones of the archive up to ``MAX_JSON_CHARS``,
    other texts up to ``MAX_TEXT_CHARS``."""
    limit = MAX_JSON_CHARS if name in LONG_ATTRIBUTES and not where else MAX_TEXT_CHARS
    if isinstance(value, (str, bytes)) and len(value) > limit:
        raise ArchiveSchemaError(f"attribute {name[:40]!r}{where} holds {len(value)} "
                                 f"characters, more than the {limit} allowed")
    if isinstance(value, np.ndarray) and value.size > MAX_TEXT_CHARS:
        raise ArchiveSchemaError(f"attribute {name[:40]!r}{where} holds {value.size} "
                                 "values")


def check_attribute_sizes(attrs: Mapping[str, Any]) -> None:
    """The archive attributes ``attrs`` within the reader's bounds (ArchiveSchemaError
    otherwise): ``rodsim`` checks a scene's before any work, so that what it writes, it
    reads."""
    for name, value in attrs.items():
        _check_size(str(name), value, "")


def _check_sizes(ds: xr.Dataset) -> None:
    """Bounded sizes: text attributes of the archive and of its variables, and steps."""
    check_attribute_sizes(ds.attrs)
    for variable in ds.variables:
        for name, value in ds[variable].attrs.items():
            _check_size(str(name), value, f" of variable {str(variable)[:40]!r}")
    if ds.sizes.get("step", 0) > MAX_STEPS:
        raise ArchiveSchemaError(f"dimension 'step' has {ds.sizes['step']} steps, more than "
                                 f"the {MAX_STEPS} allowed")


def _scalar(ds: xr.Dataset, name: str) -> float:
    """A scalar numeric variable ``name``."""
    return float(_variable(ds, name, ()).values)


def _key_scalar(ds: xr.Dataset, key: str, suffix: str = "") -> float:
    """The scalar variable of scene key ``key`` (and ``suffix``), named as the archive's
    schema names it (``rodsim.io.cf_layout.key_variable``)."""
    try:
        variable = key_variable(ds, key, suffix)
    except KeyError:
        raise ArchiveSchemaError(f"no variable holds {key[:60]!r}"
                                 + (f" ({suffix})" if suffix else "")) from None
    return _scalar(ds, str(variable.name))


def _number_attribute(ds: xr.Dataset, name: str) -> float:
    value = _attribute(ds, name)
    if isinstance(value, np.ndarray) and value.size == 1:
        value = value.item()
    if not isinstance(value, (int, float, np.integer, np.floating)) or isinstance(value, bool):
        raise ArchiveSchemaError(f"attribute {name!r} is not a number")
    return float(value)


def _check_fit(ds: xr.Dataset) -> None:
    """A fit archive: the data and their matches (point × axis, finite), the fitted keys with
    a value, an initial value and a standard error each, the residual RMS."""
    data = _variable(ds, "data_position", ("point", "axis"))
    matched = _variable(ds, "matched_position", ("point", "axis"))
    if ds.sizes["point"] < 1 or not (np.all(np.isfinite(data.values))
                                     and np.all(np.isfinite(matched.values))):
        raise ArchiveSchemaError("data_position or matched_position is empty or not finite")
    for name in parse_json_names(_attribute(ds, "fit_parameters"),
                                 "attribute 'fit_parameters'"):
        for suffix in ("", "initial", "standard_error"):
            _key_scalar(ds, name, suffix)
    _number_attribute(ds, "residual_rms")


def _check_reach(ds: xr.Dataset) -> None:
    """A reach archive: the target and the tip reached (axis, finite), the actuated keys
    with a value and an initial value each, the distance."""
    for name in ("target", "tip_reached"):
        if not np.all(np.isfinite(_variable(ds, name, ("axis",)).values)):
            raise ArchiveSchemaError(f"variable {name!r} is not finite")
    for name in parse_json_names(_attribute(ds, "reach_parameters"),
                                 "attribute 'reach_parameters'"):
        for suffix in ("", "initial"):
            _key_scalar(ds, name, suffix)
    _number_attribute(ds, "distance")


def _check_modes(ds: xr.Dataset) -> None:
    """A modes archive: at least one mode, its frequency, ω² (real and imaginary parts) and
    rotational share along ``mode``, the shapes laid out as the positions and quaternions."""
    if ds.sizes.get("mode", 0) < 1:
        raise ArchiveSchemaError("a modes archive without a mode")
    for name in ("mode", "frequency", "eigenvalue_real", "eigenvalue_imag",
                 "rotational_share"):
        _variable(ds, name, ("mode",))
    _variable(ds, "mode_position", ("mode", "node", "axis"))
    _variable(ds, "mode_quaternion", ("mode", "segment", "component"))
    if not np.all(np.isfinite(ds["mode_position"].values)):
        raise ArchiveSchemaError("variable 'mode_position' is not finite")


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
    """A track archive: its ramps (key → at least as many values as stored steps, at most
    ``MAX_STEPS``), each ramped key a coordinate along ``step`` holding the stored
    steps' values, at least one step."""
    ramps = parse_json_object(_attribute(ds, "ramp_json"), "attribute 'ramp_json'")
    if not ramps:
        raise ArchiveSchemaError("attribute 'ramp_json' names no ramped key")
    steps = ds.sizes.get("step", 0)
    if steps < 1:
        raise ArchiveSchemaError("a track archive without a step")
    for key, values in ramps.items():
        if not isinstance(values, list) or not all(finite_number(v) for v in values):
            raise ArchiveSchemaError(f"ramp_json {key[:40]!r} is not a list of numbers")
        if not max(steps, 2) <= len(values) <= MAX_STEPS:
            raise ArchiveSchemaError(f"ramp_json {key[:40]!r} has {len(values)} values for "
                                     f"{steps} stored steps (from max(steps, 2) to "
                                     f"{MAX_STEPS} expected)")
        try:
            variable = key_variable(ds, key)
        except KeyError:
            raise ArchiveSchemaError(f"no variable holds ramped key {key[:60]!r}") from None
        stored = _variable(ds, variable.name, ("step",)).values
        if not np.array_equal(np.asarray(stored, dtype=float), np.asarray(values[:steps])):
            raise ArchiveSchemaError(f"variable {str(variable.name)[:40]!r} does not hold the "
                                     "ramp_json values of the stored steps")
    for name in ERROR_ESTIMATES:  # optional: each step's estimate (an older archive has none)
        if name in ds.variables:
            _variable(ds, name, ("step",))


def _check_batch(ds: xr.Dataset) -> None:
    """A batch archive: at least one case, a status of the known flags per case, each
    key of ``case_keys`` a variable along ``case``, and ``penalty_error`` along ``case``
    when attribute ``penalty_estimates`` is 1."""
    cases = ds.sizes.get("case", 0)
    if cases < 1 or _number_attribute(ds, "cases") != cases:
        raise ArchiveSchemaError(f"a batch archive of {cases} cases (attribute 'cases' "
                                 f"= {ds.attrs.get('cases')!r})")
    status = _variable(ds, "status", ("case",)).values
    if not np.isin(status, list(STATUS.values())).all():
        raise ArchiveSchemaError("variable 'status' holds a value that is not a status flag")
    _variable(ds, "message", ("case",), numeric=False)
    for key in parse_json_names(_attribute(ds, "case_keys"), "attribute 'case_keys'"):
        try:
            variable = key_variable(ds, key)
        except KeyError:
            raise ArchiveSchemaError(f"no variable holds case key {key[:60]!r}") from None
        _variable(ds, variable.name, ("case",))
    if "penalty_estimates" in ds.attrs and _number_attribute(ds, "penalty_estimates"):
        _variable(ds, "penalty_error", ("case",))  # asked for: each case's estimate


def _check_run(ds: xr.Dataset, leading: tuple[str, ...] = ()) -> None:
    from rodsim.solvers import registered_integrators

    integrator = _attribute(ds, "integrator")
    integrators = registered_integrators()
    if not isinstance(integrator, str) or integrator not in integrators:
        raise ArchiveSchemaError(f"attribute 'integrator' = {str(integrator)[:40]!r} is not "
                                 "one of " + ", ".join(integrators))
    parse_json_object(_attribute(ds, "integrator_options"), "attribute 'integrator_options'")
    _check_layout(ds, leading)


def _check_points(ds: xr.Dataset, kind: str) -> None:
    """The routing points that broke loose (``kind`` "breakaway") or stuck again
    ("restick") along ``kind``, where the archive has them: times finite and in order,
    directions −1 or 1."""
    if f"{kind}_time" not in ds.variables:
        return
    found = _variable(ds, f"{kind}_time", (kind,)).values
    _variable(ds, f"{kind}_tendon", (kind,), numeric=False)
    _variable(ds, f"{kind}_point", (kind,))
    _variable(ds, f"{kind}_point_s", (kind,))
    ways = _variable(ds, f"{kind}_direction", (kind,)).values
    if (not np.all(np.isfinite(found)) or np.any(np.diff(found) < 0.0)
            or not np.all(np.isin(ways, (-1, 1)))):
        raise ArchiveSchemaError(f"variable '{kind}_time' is not finite or not in time "
                                 f"order, or '{kind}_direction' holds a value other than "
                                 "-1, 1")

def _check_trajectory(ds: xr.Dataset) -> None:
    """A trajectory archive: increasing finite times (at least one), the shapes along them
    laid out as a run's, the energies along ``time``, ``complete`` and ``t_end``."""
    times = _variable(ds, "time", ("time",)).values
    if times.size < 1 or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0.0):
        raise ArchiveSchemaError("coordinate 'time' is empty, not finite or not increasing")
    for name in ("kinetic_energy", "potential_energy", "dissipated_energy", "work"):
        _variable(ds, name, ("time",))
    if _number_attribute(ds, "complete") not in (0.0, 1.0) or not _number_attribute(
            ds, "t_end") > 0.0:
        raise ArchiveSchemaError("attribute 'complete' is not 0 or 1, or 't_end' not > 0")
    if "events" in ds.variables or "event_name" in ds.variables:  # optional (older archives)
        events = _variable(ds, "events", ("event",)).values
        _variable(ds, "event_name", ("event",), numeric=False)
        if not np.all(np.isfinite(events)) or np.any(np.diff(events) < 0.0):
            raise ArchiveSchemaError("variable 'events' is not finite or not in time order")
    for kind in ("breakaway", "restick"):  # optional (stiction; older archives)
        _check_points(ds, kind)
    if "step_end" in ds.variables:  # optional: under error control
        _check_steps(ds)
    if "interpolated" in ds.variables and not np.all(  # optional (older archives)
            np.isin(_variable(ds, "interpolated", ("time",)).values, (0, 1))):
        raise ArchiveSchemaError("variable 'interpolated' holds a value other than 0, 1")
    _check_layout(ds, ("time",))


def _check_steps(ds: xr.Dataset) -> None:
    """An error-controlled run's steps (rodsim/io/trajectory_dataset.py): the accepted ones'
    ends increasing and finite, their lengths > 0; the rejected attempts' starts in time
    order, their lengths > 0, their err > 1; the counts as ``stats_accepted`` and
    ``stats_rejected`` say."""
    ends = _variable(ds, "step_end", ("accepted",)).values
    sizes = _variable(ds, "step_size", ("accepted",)).values
    times = _variable(ds, "rejected_time", ("rejected",)).values
    lengths = _variable(ds, "rejected_size", ("rejected",)).values
    errors = _variable(ds, "rejected_error", ("rejected",)).values
    if (not np.all(np.isfinite(ends)) or np.any(np.diff(ends) <= 0.0)
            or not np.all(np.isfinite(sizes) & (sizes > 0.0))):
        raise ArchiveSchemaError("variables 'step_end', 'step_size': not finite, not "
                                 "increasing or not > 0")
    if (not np.all(np.isfinite(times)) or np.any(np.diff(times) < 0.0)
            or not np.all(np.isfinite(lengths) & (lengths > 0.0)) or np.any(errors <= 1.0)):
        raise ArchiveSchemaError("variables 'rejected_time', 'rejected_size', "
                                 "'rejected_error': not finite, not in time order, not > 0, "
                                 "or an err ≤ 1")
    if (_number_attribute(ds, "stats_accepted") != ends.size
            or _number_attribute(ds, "stats_rejected") != times.size):
        raise ArchiveSchemaError("attributes 'stats_accepted', 'stats_rejected' differ from "
                                 "the steps' counts")


def _check_layout(ds: xr.Dataset, leading: tuple[str, ...]) -> None:
    """The scene, the shapes (positions, quaternions) and the node and segment labels."""
    scene = stored_scene(_attribute(ds, "scene_json"), "attribute 'scene_json'")
    _variable(ds, "position", (*leading, "node", "axis"))
    _variable(ds, "quaternion", (*leading, "segment", "component"))
    _labels(ds, "axis", ["x", "y", "z"])
    _labels(ds, "component", ["q1", "q2", "q3", "q4"])
    for name in ERROR_ESTIMATES:  # optional; a number, NaN where it could not be made
        if name in ds.attrs and not _number_attribute(ds, name) >= 0.0 and not math.isnan(
                _number_attribute(ds, name)):
            raise ArchiveSchemaError(f"attribute {name!r} is negative")
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
    if "contact_force" in ds.variables or "contact_resultant" in ds.variables:
        _variable(ds, "contact_force", (*leading, "node", "axis"))
        _variable(ds, "contact_resultant", (*leading, "axis"))
    if "tension_profile" in ds.variables:
        _variable(ds, "tension_profile", (*leading, "chord"))
        _variable(ds, "chord_s", ("chord",))
        _variable(ds, "chord_tendon", ("chord",), numeric=False)
    if "slip_state" in ds.variables:
        states = _variable(ds, "slip_state", (*leading, "chord")).values
        _variable(ds, "chord_point_s", ("chord",))
        if not np.all(np.isin(states, list(SLIP_NAMES))):
            raise ArchiveSchemaError("variable 'slip_state' holds a value other than "
                                     + ", ".join(str(v) for v in SLIP_NAMES))


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
    for key in ERROR_ESTIMATES:  # optional: a study archive of an older rodsim has none
        if key in ds.variables:
            _variable(ds, key, shape)


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


def finite_number(value: Any) -> bool:
    """A finite number (not a bool), as JSON holds it."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(
        value)
