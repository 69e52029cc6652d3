"""Run a study's grid in parallel, persist every point as it finishes, and resume.

Points run on local worker processes (default), in this process (``workers = 1``), or on
a dask.distributed cluster (``scheduler = "tcp://…"``, or ``"local"`` for a LocalCluster).
Each finished point is written at once, atomically, to ``<output>.parts/`` as a small JSON
record; a study that is killed resumes where it stopped: points already recorded are not
run again. A point that fails is recorded with its status and message and does not stop
the study — nor does a point whose worker process dies (a crash, ``os._exit``, the OOM
killer): it is recorded with status ``error`` and a message starting "worker process
died", and the rest of the study goes on in a fresh pool. When every point is recorded the
study's Dataset is assembled, written atomically to ``<output>``, and the parts folder is
removed.

Local workers are the shared pool of rodsim/app/worker_pool.py.

Interrupts: a ``KeyboardInterrupt`` (Ctrl-C; the CLI turns SIGTERM into one) cancels the
points not yet started and ends the worker processes at once; the points already finished
stay in the parts folder. Local workers also end by themselves within about a second when
the process that started them dies (SIGKILL), rather than idling forever.
"""

from __future__ import annotations

import contextlib
import json
import math
import multiprocessing
import numbers
import os
import shutil
import sys
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import xarray as xr

from rodsim.app.study import Study
from rodsim.app.study_parts import (
    StudyLog,
    check_study_output,
    failure_reason,
    open_parts,
    parts_folder,
    point_file,
    save_text,
)
from rodsim.app.study_points import assemble, evaluate_point
from rodsim.app.study_resume import resumed_spec
from rodsim.app.study_spec import StudyError, StudySpec, grid_points
from rodsim.app.worker_pool import PARENT_POLL, TaskFailure, run_tasks
from rodsim.core.schema import is_integer
from rodsim.io.archive import write_dataset
from rodsim.io.archive_schema import STATUS

__all__ = ["run_study", "run_spec", "parts_folder", "WORKER_DIED",
           "PointHook", "PARENT_POLL"]

#: Progress callback: (points done, points failed, points in total, seconds elapsed). The
#: first call comes before any point runs, with the points already recorded by an earlier,
#: interrupted run (resume) and 0 s; then one call per finished point, with the seconds
#: since that first call.
StudyProgress = Callable[[int, int, int, float], None]

#: The message of a point whose worker process died starts with this.
WORKER_DIED = "worker process died"

#: A callable run in the worker process (local or dask; never the in-process runner) with
#: ``(spec, index)`` before each grid point: the tests inject faults through it (a worker
#: that dies or hangs). It must pickle (a module-level function or class instance).
PointHook = Callable[[StudySpec, tuple[int, ...]], None]

#: The hook :func:`run_spec` uses when given none (None: no hook). For the tests, which set it
#: (also in a child process before it runs the CLI); production code never does.
POINT_HOOK: PointHook | None = None

def _stderr_log(message: str) -> None:
    print(f"rodsim: {message}", file=sys.stderr, flush=True)


# Workers -------------------------------------------------------------------------------------


def _died(index: tuple[int, ...], detail: str) -> dict[str, Any]:
    return {"index": list(index), "status": STATUS["error"],
            "message": f"{WORKER_DIED} while running this point ({detail})"}


def _run_point(spec: StudySpec, index: tuple[int, ...],
               hook: PointHook | None = None) -> dict[str, Any]:
    """``evaluate_point`` in a worker process, after the injected ``hook`` if any."""
    if hook is not None:
        hook(spec, index)
    return evaluate_point(spec, index)


def _run_local(spec: StudySpec, todo: list[tuple[int, ...]], workers: int,
               persist: Callable[[dict[str, Any]], None], log: StudyLog,
               hook: PointHook | None = None) -> None:
    """The points of ``todo`` on the shared worker pool (rodsim/app/worker_pool.py)."""

    def done(index: tuple[int, ...], value: Any, seconds: float) -> None:
        if isinstance(value, TaskFailure):
            if value.kind == "died":
                record = _died(index, value.detail)
                log(f"point {list(index)}: {record['message']}")
            else:
                record = {"index": list(index), "status": STATUS["error"],
                          "message": f"worker error: {value.detail}"}
        else:
            record = value
        persist(record)

    _preload(spec, todo[0])
    run_tasks(_run_point, [(index, (spec, index, hook)) for index in todo], workers, done,
              log=log, noun="points")


def _preload(spec: StudySpec, index: tuple[int, ...]) -> None:
    """Import the solvers and load the kernels of a point's model in this process before the
    pool forks its workers, which then inherit them instead of each loading them again
    (0.5 s of CPU per worker); nothing to inherit when workers are spawned. A point that
    cannot be built is left to its worker to report."""
    if multiprocessing.get_start_method() != "fork":
        return
    from rodsim.app.study import point_model, point_scene
    from rodsim.solvers import registered_integrators

    try:
        scene = point_scene(spec, index)
        registered_integrators()
        model = point_model(spec, scene)
        model.evaluate(model.x0)
    except Exception:  # noqa: BLE001 - the point's worker records what went wrong
        return


# Dask ------------------------------------------------------------------------------------


def _connect(scheduler: str, workers: int | None = None) -> tuple[Any, Any]:
    """A dask Client (and the LocalCluster for ``"local"``, of ``workers`` single-threaded
    worker processes, default 2): StudyError when unreachable."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise StudyError("--scheduler needs dask.distributed: pip install 'rodsim[dask]'") \
            from None
    cluster = None
    try:
        if scheduler == "local":
            cluster = LocalCluster(n_workers=workers or 2, threads_per_worker=1,
                                   processes=True,
                                   dashboard_address=None)
        return Client(cluster if cluster is not None else scheduler), cluster
    except Exception as exc:
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close()
        reason = (failure_reason(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise StudyError(f"cannot reach the dask scheduler {scheduler!r}: {reason}") from None


#: Default of ``worker_timeout``: seconds a dask scheduler may have no worker at all while
#: points wait before the study fails (``rodsim study --worker-timeout``).
WORKER_TIMEOUT = 60.0
#: Seconds between two looks at the scheduler's workers while points wait.
WORKER_POLL = 0.5


def _completed(client: Any, futures: dict[Any, Any], worker_timeout: float) -> Any:
    """The futures as they complete (dask's ``as_completed``), watching the scheduler: when
    it has had no worker for ``worker_timeout`` seconds while futures wait, StudyError — a
    scheduler nobody serves is a failure, not a silent wait."""
    from distributed import as_completed as dask_completed

    pending = dask_completed(futures)
    alone_since: float | None = None
    while True:
        try:
            batch = pending.next_batch(block=False)
        except StopIteration:
            return
        if batch:
            yield from batch
            alone_since = None
            continue
        if pending.is_empty():
            return
        time.sleep(WORKER_POLL)
        try:
            workers = len(client.scheduler_info().get("workers", {}))
        except Exception:  # noqa: BLE001 - the scheduler is gone: as_completed says how
            workers = 1
        if workers:
            alone_since = None
        elif alone_since is None:
            alone_since = time.perf_counter()
        elif time.perf_counter() - alone_since > worker_timeout:
            raise StudyError(f"the dask scheduler has had no worker for {worker_timeout:g} s "
                             f"while {pending.count()} point(s) waited: start workers for it "
                             "(`dask worker ADDRESS`) or run without --scheduler; the "
                             "finished points are kept (run the study again to resume)")


def _run_dask(client: Any, spec: StudySpec, todo: list[tuple[int, ...]],
              persist: Callable[[dict[str, Any]], None], log: StudyLog,
              hook: PointHook | None = None, worker_timeout: float = WORKER_TIMEOUT) -> None:
    from concurrent.futures import CancelledError

    from distributed import KilledWorker

    futures: dict[Any, tuple[int, ...]] = {}
    finished = False

    def results(batch: list[tuple[int, ...]]) -> list[tuple[int, ...]]:
        """Run ``batch`` on the cluster and persist each point's record; returns the points
        dask gave up on because their worker died (KilledWorker), unrecorded."""
        futures.clear()
        futures.update({client.submit(_run_point, spec, index, hook, pure=False): index
                        for index in batch})
        killed = []
        for future in _completed(client, futures, worker_timeout):
            index = futures[future]
            try:
                record = future.result()
            except KilledWorker:
                killed.append(index)
                continue
            except (CancelledError, OSError) as exc:  # the cluster is gone, not the point
                raise StudyError(f"lost the dask cluster ({failure_reason(exc)}); the finished "
                                 "points are kept: run the study again to resume") from None
            except Exception as exc:
                detail = traceback.format_exception_only(type(exc), exc)[-1].strip()
                record = {"index": list(index), "status": STATUS["error"],
                          "message": f"worker error: {detail}"}
            persist(record)
        return killed

    try:
        suspects = results(list(todo))
        if len(suspects) > 1:  # a dying worker takes the points beside it along: find which
            log(f"dask workers died while {len(suspects)} points ran; running them one at a "
                "time to find which")
            suspects = [index for index in suspects if results([index])]
        for index in suspects:
            record = _died(index, "dask gave up on it after its worker(s) died: KilledWorker")
            log(f"point {list(index)}: {record['message']}")
            persist(record)
        finished = True
    finally:
        if not finished:
            with contextlib.suppress(Exception):
                client.cancel(list(futures), force=True)


# The study -----------------------------------------------------------------------------------


def run_spec(spec: StudySpec, output: str | Path, *, workers: int | None = None,
             scheduler: str | None = None, progress: StudyProgress | None = None,
             keep_parts: bool = False, log: StudyLog | None = None,
             point_hook: PointHook | None = None,
             worker_timeout: float = WORKER_TIMEOUT) -> xr.Dataset:
    """Run (or resume) every point of ``spec`` and write the assembled Dataset to ``output``.

    ``workers``: local worker processes (default: one per core, at most one per point);
    ``1`` runs the points in this process (no protection against a point that crashes the
    interpreter); with ``scheduler = "local"``, the LocalCluster's workers (default 2).
    ``scheduler``: a dask.distributed address, or ``"local"``; connected
    before anything is written; a scheduler with no worker for ``worker_timeout`` seconds
    while points wait fails the study. ``log`` receives one-line warnings (default: stderr).
    Raises ``StudyError`` for an output that cannot be written (checked before any
    point runs), a parts folder of another study or rodsim version, an unreachable
    scheduler, or a point that cannot be saved.
    """
    output = Path(output)
    log = log or _stderr_log
    hook = point_hook if point_hook is not None else POINT_HOOK
    if workers is not None and (not is_integer(workers) or workers < 1):
        raise StudyError(f"workers must be a positive whole number, not {workers!r}")
    if isinstance(worker_timeout, bool) or not isinstance(worker_timeout, numbers.Real) or \
            not 0 < worker_timeout < math.inf:
        raise StudyError(f"worker_timeout must be a number of seconds > 0, not "
                         f"{str(worker_timeout)[:40]!r}")
    check_study_output(output)
    with contextlib.ExitStack() as stack:
        if scheduler:
            client, cluster = _connect(scheduler, workers)
            if cluster is not None:
                stack.callback(cluster.close)
            stack.callback(client.close)
        folder = parts_folder(output)
        # A study begun when its base scene's implicit integrator was another keeps it
        # (rodsim/app/study_resume.py).
        spec = resumed_spec(folder, spec, log)
        records = open_parts(folder, spec, log)
        points = grid_points(spec)
        todo = [index for index in points if index not in records]
        start = time.perf_counter()
        failed = sum(r["status"] != STATUS["ok"] for r in records.values())
        if progress is not None:
            progress(len(records), failed, len(points), 0.0)

        def persist(record: dict[str, Any]) -> None:
            nonlocal failed
            index = tuple(record["index"])
            save_text(point_file(folder, index), json.dumps(record))
            records[index] = record
            failed += record["status"] != STATUS["ok"]
            if progress is not None:
                progress(len(records), failed, len(points), time.perf_counter() - start)

        if not todo:
            pass
        elif scheduler:
            _run_dask(client, spec, todo, persist, log, hook, worker_timeout)
        elif workers == 1:
            for index in todo:
                persist(evaluate_point(spec, index))
        else:
            _run_local(spec, todo, min(workers or os.cpu_count() or 1, len(todo)), persist,
                       log, hook)
    dataset = assemble(spec, list(records.values()))
    write_dataset(dataset, output)
    if not keep_parts:
        try:
            shutil.rmtree(folder)
        except OSError as exc:
            log(f"warning: cannot remove {folder} ({failure_reason(exc)}); the archive {output} is "
                "complete, the folder can be deleted")
    return dataset


def run_study(study: Study, size: str, output: str | Path, **kwargs: Any) -> xr.Dataset:
    """Run a declared study at ``size`` (``small`` or ``full``); see ``run_spec``."""
    return run_spec(study.spec(size), output, **kwargs)

