"""Many equilibria of one scene: ``rodsim.solve_many`` and ``rodsim batch`` (docs/batch.md).

A batch is a scene and a table of cases (rodsim/app/batch_cases.py: one column per numeric
scene key, one row per case), checked in full before any case runs. The model is assembled
once per process; each case only sets its values (``rodsim.core.model.Model.with_values``,
the study points' way of sharing a model: rodsim/app/study_points.py) and converges on its own
from the rest state, with its own verdict, message and stability verdict (and, with
``penalty=True``, ``rodsim run``'s penalty estimate: rodsim/app/batch_penalty.py): the same
solve as ``rodsim.solve`` of that case alone. A case that fails is recorded with its message and the
others go on. With ``warm=True`` each case starts instead from a neighbouring case's
equilibrium (rodsim/app/batch_warm.py), in chunks of a solve order.

Cases run in chunks of ``CHUNK`` (a task of the local worker pool,
rodsim/app/worker_pool.py, or of a dask cluster; workers keep their imports, kernels and
model from chunk to chunk). With an output path, every finished chunk is written at once,
atomically, to ``<output>.parts/`` (the study's parts folder, rodsim/app/study_parts.py, with
the batch's definition as its marker): a batch that is killed resumes where it stopped, its
written chunks not run again. The archive (rodsim/io/batch_dataset.py) has a ``case``
dimension.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.app.batch_cases import checked_cases
from rodsim.app.batch_job import SEGMENT, BatchJob, shape_record, shared_model
from rodsim.app.batch_penalty import record_penalty
from rodsim.app.inverse.parameter_keys import scene_with
from rodsim.app.study_parts import (
    StudyLog,
    check_study_output,
    failure_reason,
    open_folder,
    parts_folder,
    save_text,
)
from rodsim.app.study_points import solved_record
from rodsim.app.study_spec import StudyError
from rodsim.app.worker_pool import TaskFailure, run_tasks
from rodsim.core.scene import Scene
from rodsim.io.archive_schema import STATUS, ArchiveSchemaError
from rodsim.io.batch_dataset import batch_dataset, check_chunk_record
from rodsim.io.statistics import POINT_STATS

if TYPE_CHECKING:
    import xarray as xr

    from rodsim.solvers.result import Result

__all__ = ["BatchJob", "solve_many", "solve_chunk", "CHUNK", "BatchProgress"]

#: Cases per task (and per file of the parts folder): a few tenths of a second of work on
#: tdcr-two-segment, enough to make a task's transport negligible.
CHUNK = 50

#: Progress callback: (cases done, cases failed, cases in total, seconds elapsed); the first
#: call, before any case runs, counts the cases kept from an interrupted run.
BatchProgress = Callable[[int, int, int, float], None]


def _case(job: BatchJob, case: int) -> dict[str, Any]:
    """Solve one case from rest with the shared model; never raises (a failure is recorded
    with its status and message). A failed solve stores no shape."""
    from rodsim.app.api import solve

    def solve_case() -> tuple[Scene, Result]:
        base, keys, model = shared_model(job)
        scene = scene_with(base, keys, job.values[case])
        return scene, solve(scene, job.integrator, model=model.with_values(scene))

    record, solved = solved_record({"case": case}, solve_case)
    if solved is not None:
        shape_record(record, solved[1])
        record_penalty(job, case, record, solved[1])
    return record


def solve_chunk(job: BatchJob, start: int, end: int) -> dict[str, Any]:
    """The record of the chunk of positions ``start`` to ``end`` (excluded): cases ``start``
    to ``end`` of a cold batch, positions of the solve order of a warm one
    (rodsim/app/batch_warm.py); what a worker returns and the parts folder keeps
    (``chunk-<start>.json``)."""
    if job.warm:
        from rodsim.app.batch_warm import warm_chunk

        return warm_chunk(job, start, end)
    return {"start": start, "end": end, "cases": [_case(job, c) for c in range(start, end)]}


def _failed_chunk(job: BatchJob, start: int, end: int, message: str) -> dict[str, Any]:
    return {"start": start, "end": end, "cases": [
        {"case": c, "status": STATUS["error"], "message": message}
        for c in job.cases_of(start, end)]}


def _chunk_file(folder: Path, start: int) -> Path:
    return folder / f"chunk-{start:09d}.json"


def _expected_cases(job: BatchJob, record: Any) -> list[int] | None:
    """The cases a chunk record of ``job`` must hold, in order, by its start and end (None
    for a cold batch, whose chunks hold cases start to end, or a record without them)."""
    if not job.warm or not isinstance(record, dict):
        return None
    start, end = record.get("start"), record.get("end")
    if not (type(start) is int and type(end) is int and 0 <= start <= end <= job.cases):
        return None
    return job.cases_of(start, end)


def _load_parts(folder: Path, job: BatchJob, shape: tuple[int, int],
                log: StudyLog) -> dict[int, dict[str, Any]]:
    """The chunk records of a parts folder (an unreadable one is reported and runs again)."""
    starts = dict(job.chunks())
    records = {}
    for path in sorted(folder.glob("chunk-*.json")):
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
            check_chunk_record(record, shape, POINT_STATS, _expected_cases(job, record))
            if starts.get(record["start"]) != record["end"] or \
                    _chunk_file(folder, record["start"]).name != path.name:
                raise ValueError("its cases do not belong in this file")
        except (OSError, ValueError, RecursionError, ArchiveSchemaError) as exc:
            reason = "nested too deeply" if isinstance(exc, RecursionError) else \
                failure_reason(exc)
            log(f"warning: {path} is unreadable, incomplete or invalid ({reason}); its cases "
                "run again")
            continue
        records[record["start"]] = record
    return records


def _stderr_log(message: str) -> None:
    print(f"rodsim: {message}", file=sys.stderr, flush=True)


def _run_dask(client: Any, job: BatchJob, todo: list[tuple[int, int]],
              persist: Callable[[dict[str, Any]], None]) -> None:
    """The chunks of ``todo`` on a dask cluster (the study's watch of a scheduler without
    workers, rodsim/app/study_runner.py)."""
    from distributed import KilledWorker

    from rodsim.app.study_runner import WORKER_TIMEOUT, _completed

    futures = {client.submit(solve_chunk, job, start, end, pure=False): (start, end)
               for start, end in todo}
    try:
        for future in _completed(client, futures, WORKER_TIMEOUT):
            start, end = futures[future]
            try:
                record = future.result()
            except KilledWorker:
                record = _failed_chunk(job, start, end, "worker process died while running "
                                       "this chunk (dask gave up on it: KilledWorker)")
            except OSError as exc:
                raise StudyError(f"lost the dask cluster ({failure_reason(exc)}); the "
                                 "finished cases are kept: run the batch again to resume"
                                 ) from None
            persist(record)
    finally:
        with contextlib.suppress(Exception):
            client.cancel(list(futures), force=True)


def solve_many(scene: Any, cases: Any, integrator: str | None = None, *,
               output: str | Path | None = None, workers: int | None = 1,
               scheduler: str | None = None, chunk: int = CHUNK,
               progress: BatchProgress | None = None, log: StudyLog | None = None,
               keep_parts: bool = False, warm: bool = False, penalty: bool = False
               ) -> xr.Dataset:
    """The equilibrium of every case of ``cases`` (scene key → values, one per case; a dict,
    an xarray Dataset or a pandas DataFrame) on ``scene`` (a Scene, a path, a shipped scene
    name), as one Dataset with a ``case`` dimension (docs/batch.md).

    ``integrator``: default ``static``. ``output``: write the archive there, keeping each
    finished chunk of ``chunk`` cases in ``<output>.parts/`` until the end (a killed batch
    resumes). ``workers``: processes (1, the default: this process; None: one per core);
    ``scheduler``: a dask.distributed address or ``"local"``. ``progress`` hears
    (done, failed, total, seconds) after each chunk. ``warm``: start each case from a
    neighbouring case's equilibrium (rodsim/app/batch_warm.py: fewer Newton iterations;
    the equilibria differ from the cold ones by at most a Newton correction at the
    residual's floor, 2.6e-9 L on tdcr-two-segment, and the same table gives the same
    answers bit for bit whatever the chunks and workers; the chunk is rounded up to a
    multiple of 25 cases, whole segments of the solve order). ``penalty``: also each
    converged case's penalty error estimate, the one ``rodsim run`` prints (variable
    ``penalty_error``; rodsim/app/batch_penalty.py; about 1.7× the CPU a case, so off by
    default).

    Raises SceneError for a bad scene or cases table (nothing is run or written), StudyError
    for an output that cannot be written, a parts folder of another batch or an unreachable
    scheduler. A case that fails does not raise: see the ``status`` and ``message``.
    """
    from rodsim.app.api import load_scene
    from rodsim.solvers import DEFAULT_INTEGRATOR, integrator_named

    log = log or _stderr_log
    base = load_scene(scene)
    name = integrator or DEFAULT_INTEGRATOR
    integrator_named(name)
    if isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1:
        raise StudyError(f"chunk must be a positive whole number, not {chunk!r}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise StudyError(f"workers must be a positive whole number, not {workers!r}")
    if not isinstance(warm, bool):
        raise StudyError(f"warm must be True or False, not {warm!r}")
    if not isinstance(penalty, bool):
        raise StudyError(f"penalty must be True or False, not {penalty!r}")
    keys, values = checked_cases(base, cases)
    order = None
    if warm:  # chunks of whole segments (rodsim/app/batch_warm.py)
        from rodsim.app.batch_warm import solve_order

        order = solve_order(values)
        chunk = -(-chunk // SEGMENT) * SEGMENT
    job = BatchJob(base.to_json(), base.source, name, tuple(k.name for k in keys), values,
                   chunk, order, penalty)
    shape = (sum(r.nodes for r in base.rods.values()),
             sum(r.nodes - 1 for r in base.rods.values()))
    if output is not None:
        output = Path(output)
        check_study_output(output)
    with contextlib.ExitStack() as stack:
        client = None
        if scheduler:  # connected before anything is written (the study's connection)
            from rodsim.app.study_runner import _connect

            client, cluster = _connect(scheduler, workers)
            if cluster is not None:
                stack.callback(cluster.close)
            stack.callback(client.close)
        records = _run(job, shape, output, workers, client, progress, log)
    dataset = batch_dataset(base, name, keys, values, records, shared_model(job)[2],
                            f"rodsim.solve_many(scene {base.name!r}, {job.cases} cases, "
                            f"integrator={name!r}{', warm=True' if warm else ''}"
                            f"{', penalty=True' if penalty else ''})", warm, penalty)
    if output is not None:
        from rodsim.io.archive import write_dataset

        write_dataset(dataset, output)
        if not keep_parts:
            folder = parts_folder(output)
            try:
                shutil.rmtree(folder)
            except OSError as exc:
                log(f"warning: cannot remove {folder} ({failure_reason(exc)}); the archive "
                    f"{output} is complete, the folder can be deleted")
    return dataset


def _run(job: BatchJob, shape: tuple[int, int], output: Path | None, workers: int | None,
         client: Any, progress: BatchProgress | None, log: StudyLog) -> list[dict[str, Any]]:
    """Run the chunks not yet in ``output``'s parts folder (every chunk without an output),
    persisting each as it finishes; returns every case's record, in case order."""
    folder = None
    records: dict[int, dict[str, Any]] = {}
    if output is not None:
        folder = parts_folder(output)
        open_folder(folder, job.definition(), log, noun="batch")
        records = _load_parts(folder, job, shape, log)
    todo = [(s, e) for s, e in job.chunks() if s not in records]
    failed = sum(c["status"] != STATUS["ok"] for r in records.values() for c in r["cases"])
    done = sum(len(r["cases"]) for r in records.values())
    started = time.perf_counter()
    if progress is not None:
        progress(done, failed, job.cases, 0.0)

    def persist(record: dict[str, Any]) -> None:
        nonlocal done, failed
        if folder is not None:
            save_text(_chunk_file(folder, record["start"]), json.dumps(record))
        records[record["start"]] = record
        done += len(record["cases"])
        failed += sum(c["status"] != STATUS["ok"] for c in record["cases"])
        if progress is not None:
            progress(done, failed, job.cases, time.perf_counter() - started)

    def finished(key: tuple[int, int], value: Any, seconds: float) -> None:
        if isinstance(value, TaskFailure):
            detail = ("worker process died while running this chunk" if value.kind == "died"
                      else "worker error") + f" ({value.detail})"
            value = _failed_chunk(job, *key, detail)
        persist(value)

    if not todo:
        pass
    elif client is not None:
        _run_dask(client, job, todo, persist)
    elif workers == 1 or len(todo) == 1:
        for start, end in todo:
            persist(solve_chunk(job, start, end))
    else:
        shared_model(job)  # forked workers inherit the kernels and the model
        run_tasks(solve_chunk, [((s, e), (job, s, e)) for s, e in todo],
                  min(workers or os.cpu_count() or 1, len(todo)), finished, log=log,
                  noun="chunks")
    cases = [case for start in sorted(records) for case in records[start]["cases"]]
    if job.warm:  # in the solve order: back to case order
        cases.sort(key=lambda record: record["case"])
    return cases


def rerun_batch(dataset: xr.Dataset) -> tuple[xr.Dataset, float]:
    """Re-run a stored batch (its scene, integrator and cases) from the archive alone, in
    this process; returns the new Dataset and the largest distance [m] between the stored
    and the recomputed control points over the cases that succeeded (infinite when a case's
    success differs, or when the integrator options the stored scene gives today are not
    the stored ones)."""
    import dataclasses

    from rodsim.io.archive import ArchiveError, scene_of
    from rodsim.io.archive_schema import parse_json_names, parse_json_object
    from rodsim.io.cf_layout import key_variable
    from rodsim.io.compare import largest_rod_distance
    from rodsim.solvers import registered_integrators

    scene = scene_of(dataset)
    integrator = str(dataset.attrs["integrator"])
    stored = parse_json_object(dataset.attrs["integrator_options"],
                               "attribute 'integrator_options'")
    today = json.loads(json.dumps(dataclasses.asdict(
        registered_integrators()[integrator].options_of(scene))))
    if stored != today:
        raise ArchiveError("archive is inconsistent: integrator_options differ from the "
                           "scene's solver options")
    keys = parse_json_names(dataset.attrs["case_keys"], "attribute 'case_keys'")
    cases = {key: key_variable(dataset, key).values for key in keys}
    warm = bool(int(dataset.attrs.get("warm_starts", 0)))  # absent before warm starts
    penalty = bool(int(dataset.attrs.get("penalty_estimates", 0)))  # absent before them
    again = solve_many(scene, cases, integrator, warm=warm, penalty=penalty)
    ok = dataset["status"].values == STATUS["ok"]
    if not np.array_equal(ok, again["status"].values == STATUS["ok"]):
        return again, float("inf")
    if not ok.any():
        return again, 0.0
    return again, largest_rod_distance(dataset["position"].values[ok], dataset["rod"].values,
                                       again["position"].values[ok], again["rod"].values)
