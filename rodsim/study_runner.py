"""Run a study's grid in parallel, persist every point as it finishes, and resume.

Points run on local worker processes (default), in this process (``workers = 1``), or on
a dask.distributed cluster (``scheduler = "tcp://…"``, or ``"local"`` for a LocalCluster).
Each finished point is written at once, atomically, to ``<output>.parts/`` as a small JSON
record; a study that is killed resumes where it stopped: points already recorded are not
run again. A point that fails is recorded with its status and message and does not stop
the study. When every point is recorded the study's Dataset is assembled, written
atomically to ``<output>``, and the parts folder is removed.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import xarray as xr

from rodsim.archive import write_dataset
from rodsim.study import STATUS, Study, StudyError, assemble, evaluate_point, grid_points

__all__ = ["run_study", "run_spec", "parts_folder"]

#: Progress callback: (points done, points failed, points in total, seconds elapsed).
StudyProgress = Callable[[int, int, int, float], None]


def parts_folder(output: str | Path) -> Path:
    """Where the finished points of a study writing to ``output`` are kept until assembly."""
    output = Path(output)
    return output.with_name(output.name + ".parts")


def _point_file(folder: Path, index: tuple[int, ...]) -> Path:
    return folder / ("point-" + "-".join(str(i) for i in index) + ".json")


def _write_atomic(path: Path, text: str) -> None:
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    with os.fdopen(handle, "w", encoding="utf-8") as stream:
        stream.write(text)
    os.replace(temporary, path)


def _open_parts(folder: Path, spec: dict[str, Any]) -> dict[tuple[int, ...], dict[str, Any]]:
    """Create the parts folder, or check it belongs to this spec and load its records."""
    marker = folder / "spec.json"
    if folder.exists():
        if not marker.exists():
            raise StudyError(f"{folder} exists but is not a rodsim study's parts folder")
        if json.loads(marker.read_text(encoding="utf-8")) != spec:
            raise StudyError(f"{folder} holds points of a different study or size; remove it "
                             "or write the study elsewhere (-o)")
    else:  # create it complete, then rename: a kill never leaves a folder without its spec
        staging = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", dir=folder.parent))
        _write_atomic(staging / "spec.json", json.dumps(spec, sort_keys=True))
        os.replace(staging, folder)
    records = {}
    for path in folder.glob("point-*.json"):
        record = json.loads(path.read_text(encoding="utf-8"))
        records[tuple(record["index"])] = record
    return records


def _local(spec: dict[str, Any], todo: list[tuple[int, ...]],
           workers: int) -> Iterator[dict[str, Any]]:
    if workers == 1:
        for index in todo:
            yield evaluate_point(spec, index)
        return
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(evaluate_point, spec, index) for index in todo]
        for future in as_completed(futures):
            yield future.result()


def _dask(spec: dict[str, Any], todo: list[tuple[int, ...]],
          scheduler: str) -> Iterator[dict[str, Any]]:
    try:
        from distributed import Client, LocalCluster
        from distributed import as_completed as dask_completed
    except ImportError:
        raise StudyError("--scheduler needs dask.distributed: pip install 'rodsim[dask]'") \
            from None
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None) if scheduler == "local" else None
    try:
        with Client(cluster if cluster is not None else scheduler) as client:
            futures = [client.submit(evaluate_point, spec, index, pure=False)
                       for index in todo]
            for future in dask_completed(futures):
                yield future.result()
    except OSError as exc:
        raise StudyError(f"cannot reach the dask scheduler {scheduler!r}: {exc}") from None
    finally:
        if cluster is not None:
            cluster.close()


def run_spec(spec: dict[str, Any], output: str | Path, *, workers: int | None = None,
             scheduler: str | None = None, progress: StudyProgress | None = None,
             keep_parts: bool = False) -> xr.Dataset:
    """Run (or resume) every point of ``spec`` and write the assembled Dataset to ``output``."""
    output = Path(output)
    if not (output.parent if str(output.parent) else Path(".")).is_dir():
        raise StudyError(f"cannot write {output}: folder {str(output.parent)!r} does not exist")
    folder = parts_folder(output)
    records = _open_parts(folder, spec)
    points = grid_points(spec)
    todo = [index for index in points if index not in records]
    workers = max(1, min(workers or os.cpu_count() or 1, len(todo) or 1))
    start = time.perf_counter()
    failed = sum(r["status"] != STATUS["ok"] for r in records.values())
    if progress is not None:
        progress(len(records), failed, len(points), 0.0)
    if not todo:
        stream: Iterator[dict[str, Any]] = iter(())
    elif scheduler:
        stream = _dask(spec, todo, scheduler)
    else:
        stream = _local(spec, todo, workers)
    for record in stream:
        _write_atomic(_point_file(folder, tuple(record["index"])), json.dumps(record))
        records[tuple(record["index"])] = record
        failed += record["status"] != STATUS["ok"]
        if progress is not None:
            progress(len(records), failed, len(points), time.perf_counter() - start)
    dataset = assemble(spec, list(records.values()))
    write_dataset(dataset, output)
    if not keep_parts:
        shutil.rmtree(folder)
    return dataset


def run_study(study: Study, size: str, output: str | Path, **kwargs: Any) -> xr.Dataset:
    """Run a declared study at ``size`` (``small`` or ``full``); see :func:`run_spec`."""
    return run_spec(study.spec(size), output, **kwargs)
