"""Studies: a base scene, swept parameters on a grid, and what to collect at each point.

A study is declared once (``studies/<name>.py`` defines ``STUDY``) and runs point by point:
:func:`evaluate_point` solves one grid point and returns a small JSON-able record (what the
runner persists as soon as the point finishes); :func:`assemble` turns the records into one
xarray Dataset with a dimension per swept parameter. Centerlines of different N are
compared on a common normalised arc-length grid σ = s / L. Everything needed to re-run a
point — the resolved base scene, the sweeps, the integrator — is stored in the Dataset's
attributes (``spec_json``), independent of the study file that created it.
"""

from __future__ import annotations

import importlib
import itertools
import json
import pkgutil
import re
import traceback
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import xarray as xr

from rodsim.core.analytic.reference import REFERENCE_KINDS, reference_centerline
from rodsim.core.scene import Scene, SceneError
from rodsim.core.schema import shown
from rodsim.io.archive_schema import SCHEMA_VERSION, STATUS
from rodsim.io.compare import largest_distance
from rodsim.io.provenance import archive_attributes
from rodsim.io.run_dataset import step_coordinate

__all__ = ["Sweep", "Study", "StudySpec", "SweepSpec", "StudyError", "available_studies",
           "load_study", "evaluate_point", "assemble", "rerun_study", "STATUS"]

#: Point status codes stored in the ``status`` variable.
#: Per-point statistics copied from the run (see rodsim.solvers.result.STAT_DOCS).
POINT_STATS = ("steps", "newton_iters", "force_evals", "jacobian_evals", "linear_solves",
               "wall_time")


class StudyError(ValueError):
    """A study definition, name, size or archive is invalid."""


@dataclass(frozen=True)
class Sweep:
    """One swept scene value: a dimension of the study's Dataset.

    ``key`` is a scene key as for ``--set`` (full dotted path or unambiguous suffix), or a
    tuple of keys swept together (each value is then a tuple with one entry per key);
    ``values`` are the scene values; ``labels`` the coordinate values when the scene values
    are not scalars (term lists, tuples), default the values themselves.
    """

    name: str
    key: str | tuple[str, ...]
    values: tuple[Any, ...]
    units: str = "1"
    long_name: str = ""
    labels: tuple[Any, ...] | None = None

    @property
    def coordinate(self) -> tuple[Any, ...]:
        return self.labels if self.labels is not None else self.values


@dataclass(frozen=True)
class Study:
    """A study declaration (see the module docstring).

    Attributes
    ----------
    name, title
        Registry name (``rodsim study NAME``) and a one-line title.
    paper
        What the paper shows for it (figure number and claim), for docs and plots.
    scene
        Base scene: a shipped scene name or a path.
    integrator
        Integrator used at every point; ``None`` uses each point's ``solver.integrator``
        (so a sweep over that key compares integrators).
    sweeps
        ``{"small": [...], "full": [...]}``: the grid for each size.
    overrides
        Fixed ``key=value`` changes applied to the base scene.
    reference
        ``exact``, ``paper``, ``extensible`` or ``arc`` (analytic, per point), ``last`` (the
        last point along the first sweep, e.g. the finest N), or ``None``.
    plot
        Figure kind for ``rodsim plot`` (see rodsim/app/figures/plot.py).
    history
        Keep per-step history (tip and error against the reference per step: Fig. 8).
    sigma_points
        Samples of the common normalised arc-length grid.
    """

    name: str
    title: str
    paper: str
    scene: str
    integrator: str | None
    sweeps: dict[str, list[Sweep]]
    overrides: tuple[str, ...] = ()
    reference: str | None = None
    plot: str = "centerlines"
    history: bool = False
    sigma_points: int = 101

    def spec(self, size: str) -> StudySpec:
        """Everything a worker needs to run this study's points (JSON-able, picklable)."""
        if size not in self.sweeps:
            raise StudyError(f"study {self.name!r} has no size {size!r}; sizes: "
                             + ", ".join(self.sweeps))
        if self.reference is not None and self.reference not in (*REFERENCE_KINDS, "last"):
            raise StudyError(f"study {self.name!r}: unknown reference {self.reference!r}")
        from rodsim.app.api import load_scene

        try:
            scene = load_scene(self.scene, self.overrides)
        except SceneError as exc:
            raise StudyError(f"study {self.name!r}: {exc}") from None
        spec = StudySpec(
            name=self.name, title=self.title, paper=self.paper, size=size,
            integrator=self.integrator, reference=self.reference, plot=self.plot,
            history=self.history, sigma_points=self.sigma_points,
            base_scene_json=scene.to_json(), base_scene_toml=scene.source,
            sweeps=tuple(SweepSpec(s.name, s.key, s.values, s.units, s.long_name, s.labels)
                         for s in self.sweeps[size]))
        return StudySpec.from_json(spec.to_json())  # as it reads back: tuples become lists


@dataclass(frozen=True)
class SweepSpec(Sweep):
    """One sweep of a :class:`StudySpec`, as stored: the fields of :class:`Sweep`, with
    ``values`` as JSON values (a list where a declaration has a tuple)."""

    def scene_values(self, i: int) -> dict[str, Any]:
        """The scene values of the sweep's ``i``-th point, by scene key."""
        if isinstance(self.key, str):
            return {self.key: self.values[i]}
        return dict(zip(self.key, self.values[i], strict=True))

    def to_dict(self) -> dict[str, Any]:
        """The sweep as a JSON object (the layout of ``spec_json``'s ``sweeps``)."""
        return {"name": self.name,
                "key": self.key if isinstance(self.key, str) else list(self.key),
                "values": [list(v) if isinstance(v, tuple) else v for v in self.values],
                "units": self.units, "long_name": self.long_name,
                "labels": None if self.labels is None else list(self.labels)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SweepSpec:
        key = data["key"]
        labels = data.get("labels")
        return cls(data["name"], key if isinstance(key, str) else tuple(key),
                   tuple(data["values"]), data.get("units", "1"), data.get("long_name", ""),
                   None if labels is None else tuple(labels))


@dataclass(frozen=True)
class StudySpec:
    """One size of a study, resolved: everything a worker needs to run its points, and what
    a study archive stores as ``spec_json`` (:meth:`to_json`) to re-run them without the
    study file. :meth:`from_json` reads what :meth:`to_json` (or any earlier rodsim) wrote.

    Attributes
    ----------
    name, title, paper, integrator, reference, plot, history, sigma_points
        As in the :class:`Study` declaration.
    size
        ``small`` or ``full``.
    base_scene_json, base_scene_toml
        The resolved base scene (:meth:`Scene.to_json`) and its file's text.
    sweeps
        The grid, one :class:`SweepSpec` per dimension.
    """

    name: str
    title: str
    paper: str
    size: str
    integrator: str | None
    reference: str | None
    plot: str
    history: bool
    sigma_points: int
    base_scene_json: str
    base_scene_toml: str
    sweeps: tuple[SweepSpec, ...]

    def to_dict(self) -> dict[str, Any]:
        """The spec as a JSON object (the layout of ``spec_json``)."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "sweeps"}
        return out | {"sweeps": [sweep.to_dict() for sweep in self.sweeps]}

    def to_json(self) -> str:
        """Canonical JSON (sorted keys): byte for byte what study archives store."""
        return json.dumps(self.to_dict(), sort_keys=True)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> StudySpec:
        """The spec of a JSON object as :meth:`to_dict` writes it (StudyError if it is not
        one)."""
        try:
            return cls(**{f.name: data[f.name] for f in fields(cls)
                          if f.name not in ("sweeps", "base_scene_toml")},
                       base_scene_toml=data.get("base_scene_toml", ""),
                       sweeps=tuple(SweepSpec.from_dict(s) for s in data["sweeps"]))
        except (KeyError, TypeError, AttributeError) as exc:
            raise StudyError(f"not a study spec ({type(exc).__name__}: {exc})") from None

    @classmethod
    def from_json(cls, text: str) -> StudySpec:
        """The spec stored as ``text`` (an archive's ``spec_json``)."""
        try:
            data = json.loads(text)
        except (ValueError, RecursionError):
            raise StudyError("study spec: not valid JSON, or nested too deeply") from None
        if not isinstance(data, dict):
            raise StudyError(f"study spec: not a JSON object (got {type(data).__name__})")
        return cls.from_dict(data)

    def base_scene(self) -> Scene:
        """The resolved base scene."""
        return Scene.from_json(self.base_scene_json, self.base_scene_toml)

    @property
    def rod_names(self) -> list[str]:
        """The base scene's rods, in scene order."""
        return list(json.loads(self.base_scene_json)["rods"])


def grid_shape(spec: StudySpec) -> tuple[int, ...]:
    return tuple(len(s.values) for s in spec.sweeps)


def grid_points(spec: StudySpec) -> list[tuple[int, ...]]:
    """Every point of the grid as a tuple of indices, in C order."""
    return list(itertools.product(*(range(n) for n in grid_shape(spec))))


def point_scene(spec: StudySpec, index: tuple[int, ...]) -> Scene:
    """The scene of one grid point: the base scene with each sweep's value set."""
    values: dict[str, Any] = {}
    for sweep, i in zip(spec.sweeps, index, strict=True):
        values.update(sweep.scene_values(i))
    return spec.base_scene().with_values(values)


#: The last model built in this process for each study's base scene (spec.base_scene_json):
#: a point whose scene differs from it only in term options or solver settings shares its
#: assembly (:meth:`rodsim.core.model.Model.with_values`). Worker processes keep it across
#: the points they run.
_POINT_MODELS: dict[str, Any] = {}


def point_model(spec: StudySpec, scene: Scene) -> Any:
    """The model of a point's ``scene``: the process's last model of the study's base scene
    with the swept values set, when only values of terms (or the solver's settings) differ;
    else a new model, kept for the next points (SceneError when too large for memory)."""
    from rodsim.core.memory import check_memory
    from rodsim.core.model import Model

    last = _POINT_MODELS.get(spec.base_scene_json)
    if last is not None:
        shared = last.with_values(scene, fallback=False)
        if shared is not None:
            return shared
    check_memory(scene)
    model = Model(scene)
    _POINT_MODELS.clear()  # one study at a time: no growing cache
    _POINT_MODELS[spec.base_scene_json] = model
    return model


def evaluate_point(spec: StudySpec, index: tuple[int, ...]) -> dict[str, Any]:
    """Solve one grid point; never raises: a failure is recorded with its status and message.

    Runs in worker processes (local pool or dask): it takes a picklable spec and returns
    plain data. The model is :func:`point_model`'s.
    """
    from rodsim.app.api import solve

    record: dict[str, Any] = {"index": list(index)}
    try:
        scene = point_scene(spec, index)
        result = solve(scene, spec.integrator or scene.solver.integrator,
                       model=point_model(spec, scene))
    except SceneError as exc:
        return record | {"status": STATUS["error"], "message": f"bad scene value: {exc}"}
    except Exception as exc:  # a bug must not stop the study: record it
        detail = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return record | {"status": STATUS["error"], "message": f"internal error: {detail}"}
    record |= {
        "status": STATUS["ok"] if result.success else STATUS["solver_failure"],
        "message": result.message,
        "residual": result.residual,
        "stats": {k: result.stats.get(k, 0.0) for k in POINT_STATS},
    }
    if not result.success:  # the state a failed solver stopped in is no result: store none
        return record
    sigma = np.linspace(0.0, 1.0, spec.sigma_points)
    if result.stability is not None:  # the point's verdict; the eigenvalue only if unstable
        record["stable"] = int(result.stability.stable)
        if not result.stability.stable:
            record["stiffness_min_eigenvalue"] = float(result.stability.min_eigenvalue)
    record |= {
        "quaternion_norm_error": result.quaternion_norm_error,
        "tip": {name: shape.tip.tolist() for name, shape in result.rods.items()},
        "centerline": {name: _resample(shape.s, shape.positions, sigma).tolist()
                       for name, shape in result.rods.items()},
    }
    first = next(iter(result.rods.values()))
    length = float(first.s[-1])
    if spec.reference in REFERENCE_KINDS:
        reference = reference_centerline(scene, spec.reference, sigma * length)
        if reference is not None:
            mine = np.asarray(record["centerline"][next(iter(result.rods))])
            record["tip_error"] = float(np.linalg.norm(mine[-1] - reference[-1]) / length)
            record["area_error"] = ribbon_area(mine, reference) / length
            if spec.history:
                tips = np.asarray(result.history.get("tip", []), dtype=float).reshape(-1, 3)
                record["history_error"] = (np.linalg.norm(tips - reference[-1], axis=1)
                                           / length).tolist()
    if spec.history:
        record["history_time"] = list(result.history.get("time", []))
        record["history_tip"] = list(result.history.get("tip", []))
    return record


def _resample(s: np.ndarray, positions: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Positions at normalised rest arc length σ (linear along the discrete centerline)."""
    t = s / s[-1]
    return np.stack([np.interp(sigma, t, positions[:, k]) for k in range(3)], axis=1)


def ribbon_area(a: np.ndarray, b: np.ndarray) -> float:
    """Area between two centerlines sampled at the same σ, in the x–y plane (Fig. 21).

    The sum of the quadrilaterals (a_i, a_{i+1}, b_{i+1}, b_i): the area of the polygon the
    two curves enclose when they do not cross, and never cancelling when they do.
    """
    ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    quads = np.stack([np.stack([ax[:-1], ay[:-1]], 1), np.stack([ax[1:], ay[1:]], 1),
                      np.stack([bx[1:], by[1:]], 1), np.stack([bx[:-1], by[:-1]], 1)], 1)
    x, y = quads[..., 0], quads[..., 1]
    signed = 0.5 * np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1)
    return float(np.sum(np.abs(signed)))


def assemble(spec: StudySpec, records: list[dict[str, Any]]) -> xr.Dataset:
    """One Dataset for the whole study, a dimension per swept parameter (module docstring)."""
    shape = grid_shape(spec)
    dims = tuple(s.name for s in spec.sweeps)
    by_index = {tuple(r["index"]): r for r in records}
    missing = [i for i in grid_points(spec) if i not in by_index]
    if missing:
        raise StudyError(f"{len(missing)} grid points have no record, e.g. {missing[0]}")
    ok = [r for r in records if "tip" in r]
    rods = list(ok[0]["tip"]) if ok else spec.rod_names
    sigma = np.linspace(0.0, 1.0, spec.sigma_points)

    def grid(fill: Any, tail: tuple[int, ...] = (), dtype: Any = float) -> np.ndarray:
        return np.full(shape + tail, fill, dtype=dtype)

    status = grid(STATUS["error"], dtype=np.int8)
    message = grid("", dtype=object)
    # Errors only against a reference: a study without one stores no error variables.
    errors = ("tip_error", "area_error") if spec.reference in REFERENCE_KINDS else ()
    verdicts = ("stable", "stiffness_min_eigenvalue")
    scalars = {k: grid(np.nan) for k in ("residual", "quaternion_norm_error", *errors,
                                         *verdicts, *POINT_STATS)}
    tip = grid(np.nan, (len(rods), 3))
    centerline = grid(np.nan, (len(rods), len(sigma), 3))
    steps = max((len(r.get("history_time", [])) for r in records), default=0)
    history = {"history_time": grid(np.nan, (steps,)), "history_error": grid(np.nan, (steps,)),
               "history_tip": grid(np.nan, (steps, 3))}
    for index, r in by_index.items():
        status[index], message[index] = r["status"], r["message"]
        for key in ("residual", "quaternion_norm_error", *errors, *verdicts):
            if key in r:
                scalars[key][index] = r[key]
        for key in POINT_STATS:
            if "stats" in r:
                scalars[key][index] = r["stats"][key]
        if "tip" not in r:
            continue
        for k, rod in enumerate(rods):
            tip[index + (k,)] = r["tip"][rod]
            centerline[index + (k,)] = r["centerline"][rod]
        for key, array in history.items():
            values = np.asarray(r.get(key, []), dtype=float)
            if len(values):
                array[index + (slice(0, len(values)),)] = values
    data_vars: dict[str, Any] = {
        "status": (dims, status, {"units": "1", "long_name": "point status",
                                  "flag_values": np.array(list(STATUS.values()), dtype=np.int8),
                                  "flag_meanings": " ".join(STATUS)}),
        # Text has no units (CF): string variables and coordinates carry long_name only.
        "message": (dims, message.astype(str),
                    {"long_name": "solver message of the point, or why it failed"}),
        "tip": (dims + ("rod", "axis"), tip, {"units": "m", "long_name": "tip position"}),
        "centerline": (dims + ("rod", "sigma", "axis"), centerline,
                       {"units": "m", "long_name": "centerline at normalised arc length"}),
    }
    docs = {
        "residual": ("1", "final scaled force residual"),
        "quaternion_norm_error": ("1", "largest | |q| - 1 |"),
        "stable": ("1", "1 if the point's equilibrium is stable, 0 if not (NaN: failed point "
                        "or no verdict)"),
        "stiffness_min_eigenvalue": ("1", "smallest eigenvalue of the stiffness at an unstable "
                                          "point (NaN where stable)"),
        "tip_error": ("1", f"tip distance to the {spec.reference} reference / L"),
        "area_error": ("m", f"area between the centerline and the {spec.reference} "
                            "reference / L (Fig. 21)"),
        "steps": ("1", "integrator steps"), "newton_iters": ("1", "Newton iterations"),
        "force_evals": ("1", "force evaluations"), "jacobian_evals": ("1", "Jacobian evaluations"),
        "linear_solves": ("1", "linear solves"), "wall_time": ("s", "wall time to equilibrium"),
    }
    for key, values in scalars.items():
        units, long_name = docs[key]
        data_vars[key] = (dims, values, {"units": units, "long_name": long_name})
    if spec.history:
        data_vars["history_time"] = (dims + ("step",), history["history_time"],
                                     {"units": "s", "long_name": "pseudo-time after each step"})
        data_vars["history_tip"] = (dims + ("step", "axis"), history["history_tip"],
                                    {"units": "m", "long_name": "tip after each step"})
        if errors:
            data_vars["history_error"] = (
                dims + ("step",), history["history_error"],
                {"units": "1", "long_name": f"tip distance to the {spec.reference} "
                 "reference / L after each step"})
    coords: dict[str, Any] = {
        "rod": ("rod", rods, {"long_name": "rod"}),
        "sigma": ("sigma", sigma, {"units": "1", "long_name": "normalised rest arc length s/L"}),
        "axis": ("axis", ["x", "y", "z"], {"long_name": "world axis"}),
    }
    for s in spec.sweeps:
        labels = np.asarray(s.coordinate)
        key = s.key if isinstance(s.key, str) else ", ".join(s.key)
        attrs = {"units": s.units, "long_name": s.long_name or key, "scene_key": key}
        if not np.issubdtype(labels.dtype, np.number):  # names ("corde", "on"): no units
            del attrs["units"]
        coords[s.name] = (s.name, labels, attrs)
    if spec.history:
        coords.update(step_coordinate(steps))
    ds = xr.Dataset(data_vars, coords)
    if spec.reference == "last":
        _score_against_last(ds, dims[0], spec.base_scene().rods[rods[0]].length)
    ds.attrs.update({
        "title": f"rodsim study {spec.name}: {spec.title}",
        **archive_attributes(f"rodsim.app.study.assemble(study {spec.name!r}, "
                              f"size {spec.size!r})"),
        "study": spec.name, "size": spec.size, "paper": spec.paper,
        "integrator": str(spec.integrator or "per point (solver.integrator)"),
        "reference": str(spec.reference),
        "plot": spec.plot, "spec_json": spec.to_json(),
        "scene_json": spec.base_scene_json, "scene_toml": spec.base_scene_toml,
        "schema_version": SCHEMA_VERSION,
        "points": int(np.prod(shape)), "failed_points": int(np.sum(status != STATUS["ok"])),
    })
    return ds


def _score_against_last(ds: xr.Dataset, dim: str, length: float) -> None:
    """Tip and area errors of the first rod against the last point along ``dim`` (which a
    convergence sweep orders from coarse to fine)."""
    first = ds["centerline"].isel(rod=0)
    reference = first.isel({dim: -1})
    gap = first.isel(sigma=-1) - reference.isel(sigma=-1)
    ds["tip_error"] = (np.sqrt((gap**2).sum("axis")) / length).transpose(*ds["status"].dims)
    areas = xr.apply_ufunc(ribbon_area, first, reference,
                           input_core_dims=[["sigma", "axis"]] * 2, vectorize=True)
    ds["area_error"] = (areas / length).transpose(*ds["status"].dims)
    ds["tip_error"].attrs = {"units": "1",
                             "long_name": f"tip distance to the last {dim} point / L"}
    ds["area_error"].attrs = {"units": "m", "long_name": f"area between the centerline and "
                              f"the last {dim} point's / L (Fig. 21)"}


def available_studies() -> dict[str, Study]:
    """Every study shipped in ``studies/`` (installed as the package ``rodsim.studies``)."""
    import rodsim.studies as package

    found = {}
    for module in pkgutil.iter_modules(package.__path__):
        if module.name.startswith("_"):
            continue
        study = getattr(importlib.import_module(f"rodsim.studies.{module.name}"), "STUDY", None)
        if isinstance(study, Study):
            found[study.name] = study
    return dict(sorted(found.items(), key=lambda item: natural_key(item[0])))


def natural_key(name: str) -> tuple[tuple[int, int | str], ...]:
    """Sort key ordering the numbers within names by value: fig6 before fig22."""
    return tuple((0, int(part)) if part.isdigit() else (1, part)
                 for part in re.split(r"(\d+)", name) if part)


def load_study(name: str) -> Study:
    """A shipped study by name (StudyError listing the available ones otherwise)."""
    studies = available_studies()
    if name not in studies:
        raise StudyError(f"unknown study {name!r}; available: {', '.join(studies)}")
    return studies[name]


def rerun_study(dataset: xr.Dataset, select: dict[str, Any] | None = None
                ) -> tuple[list[dict[str, Any]], float]:
    """Re-run a stored study (every point, or those matching ``select`` = {dim: label}).

    Returns the new records and the largest distance [m] between stored and recomputed
    centerlines (infinite when a point's success differs from the stored one, or either
    centerline holds a NaN).
    """
    spec = StudySpec.from_json(dataset.attrs["spec_json"])
    dims = [s.name for s in spec.sweeps]
    select = dict(select or {})
    values = {d: [v.item() for v in dataset[d].values] for d in dims}

    def swept() -> str:
        return "; ".join(f"{d}: {', '.join(_label_text(v) for v in values[d])}" for d in dims)

    for dim, wanted in select.items():
        given = shown(f"{dim}={_label_text(wanted)}", bare=True)
        if dim not in dims:
            raise StudyError(f"{given}: {shown(dim, bare=True)} is not a swept parameter of "
                             f"this study; the swept values are {swept()}")
        if not any(_same(v, wanted) for v in values[dim]):
            raise StudyError(f"{given}: no point has this value; the values of {dim} are "
                             f"{', '.join(map(_label_text, values[dim]))}")
    points = []
    for index in grid_points(spec):
        labels = {d: values[d][i] for d, i in zip(dims, index, strict=True)}
        if all(_same(labels[d], v) for d, v in select.items()):
            points.append(index)
    if not points:
        chosen = ", ".join(f"{d}={_label_text(v)}" for d, v in select.items())
        raise StudyError(f"no point has {chosen}; the swept values are {swept()}")
    records, largest = [], 0.0
    rods = list(dataset["rod"].values)
    for index in points:
        record = evaluate_point(spec, index)
        records.append(record)
        stored_ok = int(dataset["status"].values[index]) == STATUS["ok"]
        if stored_ok != (record["status"] == STATUS["ok"]):
            largest = np.inf  # a point that succeeded once and failed now (or the reverse)
        elif stored_ok:
            stored = dataset["centerline"].values[index]
            new = np.stack([np.asarray(record["centerline"][rod]) for rod in rods])
            largest = max(largest, largest_distance(stored, new))
    return records, largest


def _label_text(value: Any) -> str:
    """A swept value as a user would type it after ``DIM=``."""
    if isinstance(value, float):
        return f"{value:.12g}"
    return str(value)


def _same(label: Any, wanted: Any) -> bool:
    try:
        return bool(np.isclose(float(label), float(wanted), rtol=1e-12, atol=0.0))
    except (TypeError, ValueError):
        return str(label) == str(wanted)
