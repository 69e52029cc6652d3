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
import os
import shutil
import sys
import tempfile
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import xarray as xr

from rodsim.app.study import (
    POINT_STATS,
    STATUS,
    Study,
    StudyError,
    StudySpec,
    assemble,
    evaluate_point,
    grid_points,
)
from rodsim.app.worker_pool import PARENT_POLL, TaskFailure, run_tasks
from rodsim.io.archive import write_dataset
from rodsim.io.archive_schema import ArchiveSchemaError, check_point_record
from rodsim.io.atomic import write_text_atomic
from rodsim.io.output import OutputError, check_target
from rodsim.io.provenance import git_commit, git_dirty
from rodsim.version import __version__

__all__ = ["run_study", "run_spec", "parts_folder", "spec_differences", "WORKER_DIED",
           "PointHook", "PARENT_POLL"]

#: Progress callback: (points done, points failed, points in total, seconds elapsed). The
#: first call comes before any point runs, with the points already recorded by an earlier,
#: interrupted run (resume) and 0 s; then one call per finished point, with the seconds
#: since that first call.
StudyProgress = Callable[[int, int, int, float], None]
#: Log callback for one-line warnings and notes (default: printed on stderr).
StudyLog = Callable[[str], None]

#: The message of a point whose worker process died starts with this.
WORKER_DIED = "worker process died"

#: A callable run in the worker process (local or dask; never the in-process runner) with
#: ``(spec, index)`` before each grid point: the tests inject faults through it (a worker
#: that dies or hangs). It must pickle (a module-level function or class instance).
PointHook = Callable[[StudySpec, tuple[int, ...]], None]

#: The hook :func:`run_spec` uses when given none (None: no hook). For the tests, which set it
#: (also in a child process before it runs the CLI); production code never does.
POINT_HOOK: PointHook | None = None

#: Marker file of a parts folder: the spec and the rodsim that computed its points.
MARKER = "spec.json"


def parts_folder(output: str | Path) -> Path:
    """Where the finished points of a study writing to ``output`` are kept until assembly."""
    output = Path(output)
    return output.with_name(output.name + ".parts")


def _point_file(folder: Path, index: tuple[int, ...]) -> Path:
    return folder / ("point-" + "-".join(str(i) for i in index) + ".json")


def _reason(exc: BaseException) -> str:
    """An OSError's reason without its repeated path, other exceptions as they print."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    return str(exc) or type(exc).__name__


def _stderr_log(message: str) -> None:
    print(f"rodsim: {message}", file=sys.stderr, flush=True)


# Files ----------------------------------------------------------------------------------


def _write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically and synced (:func:`rodsim.io.atomic.
    write_text_atomic`): a crash or a full disk never leaves a partial ``path``, nor the
    temporary (StudyError)."""
    try:
        write_text_atomic(path, text)
    except Exception as exc:
        raise StudyError(f"cannot write {path}: {_reason(exc)}") from exc


def _check_output(output: Path) -> None:
    """Refuse, before any point runs, an output the archive could not be written to."""
    folder = output.parent if str(output.parent) else Path(".")
    if not folder.is_dir():
        raise StudyError(f"cannot write {output}: folder {str(folder)!r} does not exist")
    if output.is_dir():
        raise StudyError(f"cannot write {output}: it is a folder; give a file name "
                         "(-o OUT.nc)")
    parts = parts_folder(output)
    if parts.exists() and not parts.is_dir():
        raise StudyError(f"cannot keep the study's points in {parts}: a file of that name "
                         "exists")
    try:  # permissions, read-only or pseudo file systems (/proc), devices: try, as the run will
        check_target(output)
    except OutputError as exc:
        raise StudyError(str(exc)) from None


def _short(value: Any, width: int = 60) -> str:
    text = json.dumps(value, sort_keys=True) if not isinstance(value, str) else repr(value)
    return text if len(text) <= width else text[:width - 1] + "…"


def _differences(old: Any, new: Any, path: str) -> list[str]:
    """Where two JSON values differ, as ``path: old → new`` lines (dicts and equal-length
    lists are compared item by item)."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for key in sorted(set(old) | set(new), key=str):
            where = f"{path}.{key}" if path else str(key)
            if key not in old:
                out.append(f"{where}: absent in the parts folder, {_short(new[key])} now")
            elif key not in new:
                out.append(f"{where}: {_short(old[key])} in the parts folder, absent now")
            else:
                out += _differences(old[key], new[key], where)
        return out
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        return [line for i, (a, b) in enumerate(zip(old, new, strict=True))
                for line in _differences(a, b, f"{path}[{i}]")]
    if old != new:
        return [f"{path}: {_short(old)} in the parts folder, {_short(new)} now"]
    return []


def spec_differences(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """What differs between two study specs, naming each key (the base scene key by key)."""
    old_scene = old.get("base_scene_json", "{}")
    new_scene = new.get("base_scene_json", "{}")
    rest = [key for key in sorted(set(old) | set(new))
            if key not in ("base_scene_json", "base_scene_toml")]
    lines = _differences({k: old[k] for k in rest if k in old},
                         {k: new[k] for k in rest if k in new}, "")
    if old_scene != new_scene:
        try:
            lines += ["base scene " + line for line in
                      _differences(json.loads(old_scene), json.loads(new_scene), "")]
        except (TypeError, ValueError):
            lines.append("base_scene_json differs")
    elif old.get("base_scene_toml") != new.get("base_scene_toml"):
        lines.append("base_scene_toml: the base scene file's text differs")
    return lines


def _marker(spec: StudySpec) -> dict[str, Any]:
    return {"spec": spec.to_dict(), "rodsim_version": __version__, "git_commit": git_commit(),
            "git_dirty": git_dirty()}


def _open_parts(folder: Path, spec: StudySpec,
                log: StudyLog) -> dict[tuple[int, ...], dict[str, Any]]:
    """Create the parts folder, or check it belongs to this spec and rodsim version and load
    its records (an unreadable record is reported and its point runs again)."""
    marker = folder / MARKER
    if folder.exists():
        if not marker.is_file():
            raise StudyError(f"{folder} exists but is not a rodsim study's parts folder "
                             f"(no {MARKER}); remove it or write the study elsewhere (-o)")
        try:
            stored = json.loads(marker.read_text(encoding="utf-8"))
        except RecursionError:
            raise StudyError(f"{folder}: unreadable {MARKER} (nested too deeply); remove the "
                             "folder or write the study elsewhere (-o)") from None
        except (OSError, ValueError) as exc:
            raise StudyError(f"{folder}: unreadable {MARKER} ({_reason(exc)}); remove the "
                             "folder or write the study elsewhere (-o)") from None
        if not isinstance(stored, dict) or not isinstance(stored.get("spec", {}), dict):
            raise StudyError(f"{folder}: {MARKER} does not hold a study spec; remove the "
                             "folder or write the study elsewhere (-o)")
        if "rodsim_version" not in stored:
            raise StudyError(f"{folder} was written by an older rodsim that did not record its "
                             f"version (rodsim_version differs: this is rodsim {__version__}); "
                             "remove it or write the study elsewhere (-o)")
        if stored["rodsim_version"] != __version__:
            raise StudyError(f"{folder} holds points computed by rodsim "
                             f"{stored['rodsim_version']}, this is rodsim {__version__} "
                             "(rodsim_version differs); remove it or write the study "
                             "elsewhere (-o)")
        differences = spec_differences(stored.get("spec", {}), spec.to_dict())
        if differences:
            more = f" (and {len(differences) - 3} more)" if len(differences) > 3 else ""
            raise StudyError(f"{folder} holds points of a different study definition: "
                             + "; ".join(differences[:3]) + more
                             + "; remove it or write the study elsewhere (-o)")
        commit = git_commit()
        if isinstance(stored.get("git_commit"), str) and commit and (
                stored["git_commit"] != commit):
            log(f"note: the points in {folder} were computed at git commit "
                f"{stored['git_commit'][:12]}, this rodsim is at {commit[:12]}; resuming")
    else:  # create it complete, then rename: a kill never leaves a folder without its marker
        try:
            staging = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", dir=folder.parent))
        except OSError as exc:
            raise StudyError(f"cannot create {folder}: {_reason(exc)}") from None
        try:
            _write_atomic(staging / MARKER, json.dumps(_marker(spec), sort_keys=True))
            os.replace(staging, folder)
        except BaseException as exc:
            shutil.rmtree(staging, ignore_errors=True)
            if isinstance(exc, OSError):
                raise StudyError(f"cannot create {folder}: {_reason(exc)}") from None
            raise
    grid = set(grid_points(spec))
    rods = spec.rod_names
    records = {}
    for path in sorted(folder.glob("point-*.json")):
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
            check_point_record(record, spec.sigma_points, rods, POINT_STATS)
            index = tuple(record["index"]) if isinstance(record["index"], list) else None
            if index not in grid or _point_file(folder, index).name != path.name:
                raise ValueError(f"index {str(record['index'])[:40]} does not belong in "
                                 "this file")
        except (OSError, ValueError, RecursionError, ArchiveSchemaError) as exc:
            reason = "nested too deeply" if isinstance(exc, RecursionError) else _reason(exc)
            log(f"warning: {path} is unreadable, incomplete or invalid ({reason}); its point "
                "runs again")
            continue
        records[index] = record
    return records


# Workers -------------------------------------------------------------------------------------


def _died(index: tuple[int, ...], detail: str) -> dict[str, Any]:
    return {"index": list(index), "status": STATUS["error"],
            "message": f"{WORKER_DIED} while running this point ({detail})"}


def _run_point(spec: StudySpec, index: tuple[int, ...],
               hook: PointHook | None = None) -> dict[str, Any]:
    """:func:`evaluate_point` in a worker process, after the injected ``hook`` if any."""
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


def _connect(scheduler: str) -> tuple[Any, Any]:
    """A dask Client (and the LocalCluster for ``"local"``): StudyError when unreachable."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise StudyError("--scheduler needs dask.distributed: pip install 'rodsim[dask]'") \
            from None
    cluster = None
    try:
        if scheduler == "local":
            cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                   dashboard_address=None)
        return Client(cluster if cluster is not None else scheduler), cluster
    except Exception as exc:
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close()
        reason = (_reason(exc).strip().splitlines() or [type(exc).__name__])[0]
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
                raise StudyError(f"lost the dask cluster ({_reason(exc)}); the finished points "
                                 "are kept: run the study again to resume") from None
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
    interpreter). ``scheduler``: a dask.distributed address, or ``"local"``; connected
    before anything is written; a scheduler with no worker for ``worker_timeout`` seconds
    while points wait fails the study. ``log`` receives one-line warnings (default: stderr).
    Raises :class:`StudyError` for an output that cannot be written (checked before any
    point runs), a parts folder of another study or rodsim version, an unreachable
    scheduler, or a point that cannot be saved.
    """
    output = Path(output)
    log = log or _stderr_log
    hook = point_hook if point_hook is not None else POINT_HOOK
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise StudyError(f"workers must be a positive whole number, not {workers!r}")
    if isinstance(worker_timeout, bool) or not isinstance(worker_timeout, (int, float)) or \
            not 0 < worker_timeout < math.inf:
        raise StudyError(f"worker_timeout must be a number of seconds > 0, not "
                         f"{str(worker_timeout)[:40]!r}")
    _check_output(output)
    with contextlib.ExitStack() as stack:
        if scheduler:
            client, cluster = _connect(scheduler)
            if cluster is not None:
                stack.callback(cluster.close)
            stack.callback(client.close)
        folder = parts_folder(output)
        records = _open_parts(folder, spec, log)
        points = grid_points(spec)
        todo = [index for index in points if index not in records]
        start = time.perf_counter()
        failed = sum(r["status"] != STATUS["ok"] for r in records.values())
        if progress is not None:
            progress(len(records), failed, len(points), 0.0)

        def persist(record: dict[str, Any]) -> None:
            nonlocal failed
            index = tuple(record["index"])
            _write_atomic(_point_file(folder, index), json.dumps(record))
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
            log(f"warning: cannot remove {folder} ({_reason(exc)}); the archive {output} is "
                "complete, the folder can be deleted")
    return dataset


def run_study(study: Study, size: str, output: str | Path, **kwargs: Any) -> xr.Dataset:
    """Run a declared study at ``size`` (``small`` or ``full``); see :func:`run_spec`."""
    return run_spec(study.spec(size), output, **kwargs)

