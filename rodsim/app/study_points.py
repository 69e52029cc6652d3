"""A study's points: the model a point shares with the others, the evaluation of one point
into a small JSON-able record (what the runner persists as soon as the point finishes), the
assembly of the records into the study's Dataset, and the re-run of a stored study."""

from __future__ import annotations

import traceback
from collections.abc import Callable
from typing import Any

import numpy as np
import xarray as xr

from rodsim.app.scoring import point_errors, resample, score_against_last
from rodsim.app.study_spec import StudyError, StudySpec, grid_points, point_scene
from rodsim.core.scene import Scene, SceneError
from rodsim.core.schema import shown
from rodsim.io.archive_schema import STATUS
from rodsim.io.compare import largest_distance
from rodsim.io.statistics import POINT_STATS
from rodsim.io.study_dataset import study_dataset
from rodsim.solvers.result import Result

__all__ = ["point_model", "evaluate_point", "point_estimates", "solved_record", "assemble",
           "rerun_study"]


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


def solved_record(record: dict[str, Any], solve_point: Callable[[], tuple[Scene, Result]]
                  ) -> tuple[dict[str, Any], tuple[Scene, Result] | None]:
    """``record`` with the outcome of ``solve_point()`` — status, message, residual and
    statistics; for a success its stability verdict (the eigenvalue only if unstable) and
    quaternion norm error — and the scene and result of a success (None otherwise). Never
    raises: a bad scene value or a bug is recorded, so that one point or case does not stop
    a study or a batch (rodsim/app/batch.py)."""
    try:
        scene, result = solve_point()
    except SceneError as exc:
        return record | {"status": STATUS["error"], "message": f"bad scene value: {exc}"}, None
    except Exception as exc:  # a bug must not stop the study: record it
        detail = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return (record | {"status": STATUS["error"], "message": f"internal error: {detail}"},
                None)
    record |= {
        "status": STATUS["ok"] if result.success else STATUS["solver_failure"],
        "message": result.message,
        "residual": result.residual,
        "stats": {k: float(result.stats.get(k, 0.0)) for k in POINT_STATS},
    }
    if not result.success:
        return record, None
    if result.stability is not None:
        record["stable"] = int(result.stability.stable)
        if not result.stability.stable:
            record["stiffness_min_eigenvalue"] = float(result.stability.min_eigenvalue)
    record["quaternion_norm_error"] = result.quaternion_norm_error
    return record, (scene, result)


def evaluate_point(spec: StudySpec, index: tuple[int, ...]) -> dict[str, Any]:
    """Solve one grid point; never raises: a failure is recorded with its status and message.

    Runs in worker processes (local pool or dask): it takes a picklable spec and returns
    plain data. The model is ``point_model``'s.
    """
    from rodsim.app.api import solve

    def solve_point() -> tuple[Scene, Result]:
        scene = point_scene(spec, index)
        return scene, solve(scene, spec.integrator or scene.solver.integrator,
                            model=point_model(spec, scene))

    record, solved = solved_record({"index": list(index)}, solve_point)
    if solved is None:  # the state a failed solver stopped in is no result: store none
        return record
    scene, result = solved
    sigma = np.linspace(0.0, 1.0, spec.sigma_points)
    record |= {
        "tip": {name: shape.tip.tolist() for name, shape in result.rods.items()},
        "centerline": {name: resample(shape.s, shape.positions, sigma).tolist()
                       for name, shape in result.rods.items()},
    }
    first = next(iter(result.rods.values()))
    record |= point_estimates(result)
    record |= point_errors(
        scene, spec.reference, np.asarray(record["centerline"][next(iter(result.rods))]),
        sigma, float(first.s[-1]),
        result.history.get("tip", []) if spec.history else None)
    if spec.history:
        record["history_time"] = list(result.history.get("time", []))
        record["history_tip"] = list(result.history.get("tip", []))
    return record


def point_estimates(result: Result) -> dict[str, float]:
    """The discretisation and penalty error estimates [L] of a point's converged ``result``:
    the very estimates ``rodsim run`` prints for the point's scene (``rodsim.app.trust.assess``
    without a model: a point's model has its rest-state anchors, as a run's). About 3× a
    warm point's solve in CPU (docs/studies.md, "Error estimates")."""
    from rodsim.app.trust import assess

    estimates = assess(result)
    return {"discretisation_error": float(estimates.discretisation.error),
            "penalty_error": float(estimates.penalty.error)}


def assemble(spec: StudySpec, records: list[dict[str, Any]]) -> xr.Dataset:
    """One Dataset for the whole study, a dimension per swept parameter: the layout of
    ``rodsim.io.study_dataset.study_dataset``, a convergence sweep scored against its
    last point (``rodsim.app.scoring.score_against_last``). StudyError when a grid point
    has no record."""
    by_index = {tuple(r["index"]) for r in records}
    missing = [i for i in grid_points(spec) if i not in by_index]
    if missing:
        raise StudyError(f"{len(missing)} grid points have no record, e.g. {missing[0]}")
    ds = study_dataset(spec, records, f"rodsim.app.study.assemble(study {spec.name!r}, "
                                      f"size {spec.size!r})")
    if spec.reference == "last":
        rods = list(ds["rod"].values)
        score_against_last(ds, spec.sweeps[0].name, spec.base_scene().rods[rods[0]].length)
    return ds


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
