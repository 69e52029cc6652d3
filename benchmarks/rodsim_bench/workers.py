"""Studies and workers (``rodsim bench workers``): shipped studies on 1 and 2 local worker
processes (``--workers``) and on a dask LocalCluster of 1 and 2 workers (``--scheduler local
--workers N``), each a fresh ``rodsim study`` process, interleaved, median of the repeats:
wall time (what the user waits for) and CPU time of the process and its workers (user +
system, ``RUSAGE_CHILDREN``; a LocalCluster's workers are the study process's children).

Two studies: ``fig7b`` (seven points of milliseconds each: the process's imports and archive
dominate, the Amdahl case) and ``convergence`` (sixty points of the two-rod tendon scene,
up to N = 80: the points dominate). The machine's load average at the start and the end is
recorded: on a loaded machine the wall-time ratio says little about what a second core would
give, the CPU ratio says what the workers cost.

With ``RODSIM_BENCH_BASELINE`` set to a git revision (rodsim_bench/baseline.py), the local
cases are also run by that revision's code in the same run, interleaved (not the dask ones:
before 4d4ff50 ``--scheduler local`` ignored ``--workers`` and always started two).

Outputs ``workers-<size>.nc`` and ``workers-<size>.md``.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from rodsim.io.archive import write_dataset
from rodsim_bench.baseline import BaselineTree, baseline_revision
from rodsim_bench.machine import machine

__all__ = ["run", "WORKERS", "RUNNERS", "STUDIES"]

STUDIES = ("fig7b", "convergence")
#: Per size: repeats, the studies' own size, and the studies (small: a smoke run of the
#: same code paths on one study).
SIZES = {"small": {"repeats": 1, "study_size": "small", "studies": STUDIES[:1]},
         "full": {"repeats": 3, "study_size": "full", "studies": STUDIES}}
#: local: ``--workers N`` (1 = in-process); dask: ``--scheduler local --workers N``.
RUNNERS = ("local", "dask")
WORKERS = (1, 2)


def _load() -> float:
    try:
        return float(Path("/proc/loadavg").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return float("nan")


def _study(study: str, runner: str, workers: int, study_size: str, folder: str,
           baseline: BaselineTree | None = None) -> tuple[float, float]:
    """(wall, CPU) seconds of one ``rodsim study`` process with its workers (by
    ``baseline``'s code when given)."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    where: dict[str, Any] = {}
    if baseline is not None:
        env, where = baseline.env(env), {"cwd": str(baseline.tree)}
    extra = ["--scheduler", "local"] if runner == "dask" else []
    tag = "baseline" if baseline is not None else "this"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "rodsim", "study", study, "--size",
                           study_size, "--workers", str(workers), *extra, "-o",
                           f"{folder}/{study}-{runner}-{workers}-{tag}.nc"],
                          capture_output=True, text=True, env=env, timeout=1800, check=False,
                          **where)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"study {study} ({runner}, {workers} workers, {tag}): exit "
                           f"{done.returncode}: {done.stderr[-500:]}")
    return wall, (after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)


def run(size: str, output_dir: str | Path, progress=None) -> list[Path]:
    revision = baseline_revision()
    with tempfile.TemporaryDirectory(prefix="rodsim-workers-") as folder:
        baseline = BaselineTree(revision, Path(folder)) if revision else None
        return _run(size, output_dir, progress, folder, baseline)


def _run(size: str, output_dir: str | Path, progress, folder: str,
         baseline: BaselineTree | None) -> list[Path]:
    setting = SIZES[size]
    repeats = setting["repeats"]
    studies = setting["studies"]
    codes = ["this"] + ([f"baseline {baseline.commit[:7]}"] if baseline is not None else [])
    shape = (len(codes), len(studies), len(RUNNERS), len(WORKERS), repeats)
    wall, cpu = np.full(shape, np.nan), np.full(shape, np.nan)
    cases = [(c, i, j, k) for c in range(len(codes)) for i in range(len(studies))
             for j in range(len(RUNNERS)) for k in range(len(WORKERS))
             if c == 0 or RUNNERS[j] == "local"]
    if baseline is not None:  # warm-up: the baseline's kernels compiled into its tree
        for study in studies:
            _study(study, "local", 1, "small", folder, baseline)
    load_start = _load()
    for repeat in range(repeats):  # interleaved, so that a load change hits every row
        for n, (c, i, j, k) in enumerate(cases):
            if progress is not None:
                progress((repeat * len(cases) + n) / (repeats * len(cases)),
                         f"workers: {codes[c]}, {studies[i]}, {RUNNERS[j]}, {WORKERS[k]} "
                         f"workers ({repeat + 1}/{repeats})")
            wall[c, i, j, k, repeat], cpu[c, i, j, k, repeat] = _study(
                studies[i], RUNNERS[j], WORKERS[k], setting["study_size"], folder,
                baseline if c else None)
    load_end = _load()
    med_wall, med_cpu = np.median(wall, axis=-1), np.median(cpu, axis=-1)
    dims = ("code", "study", "runner", "workers", "repeat")
    ds = xr.Dataset(
        {"wall": (dims, wall, {"units": "s", "long_name": "wall time of the study process"}),
         "cpu": (dims, cpu, {"units": "s", "long_name": "CPU time of the study process and "
                             "its workers"})},
        coords={"code": ("code", codes, {"long_name": "this checkout, or the baseline "
                                         "revision's code (RODSIM_BENCH_BASELINE)"}),
                "study": ("study", list(studies), {"long_name": "shipped study"}),
                "runner": ("runner", list(RUNNERS),
                           {"long_name": "local worker processes or a dask LocalCluster"}),
                "workers": ("workers", np.array(WORKERS), {"long_name": "--workers"}),
                "repeat": ("repeat", np.arange(repeats), {"long_name": "repeat"})})
    ds.attrs = {"title": "rodsim: studies on 1 and 2 workers, local and dask",
                "benchmark": "workers", "size": size,
                "study_size": setting["study_size"], "load_average_start": load_start,
                "load_average_end": load_end,
                **{f"machine_{k}": v for k, v in machine().items()}}
    output = Path(output_dir) / f"workers-{size}.nc"
    write_dataset(ds, output)
    lines = [f"# `rodsim study NAME --size {setting['study_size']}` on 1 and 2 workers, local "
             f"processes and a dask LocalCluster ({size}, median of {repeats})", "",
             "| code | study | runner | workers | wall [s] | CPU [s] | speed-up (wall, vs 1) | "
             "CPU / CPU(1) | CPU / this code's |", "|---|---|---|--:|--:|--:|--:|--:|--:|"]
    for c, code in enumerate(codes):
        for i, study in enumerate(studies):
            for j, runner in enumerate(RUNNERS):
                for k, workers in enumerate(WORKERS):
                    if np.isnan(med_wall[c, i, j, k]):
                        continue
                    lines.append(
                        f"| {code} | {study} | {runner} | {workers} | "
                        f"{med_wall[c, i, j, k]:.2f} | {med_cpu[c, i, j, k]:.2f} | "
                        f"{med_wall[c, i, j, 0] / med_wall[c, i, j, k]:.2f} | "
                        f"{med_cpu[c, i, j, k] / med_cpu[c, i, j, 0]:.2f} | "
                        f"{med_cpu[c, i, j, k] / med_cpu[0, i, j, k]:.2f} |")
    lines += ["", f"Load average (1 min) at the start {load_start:.1f}, at the end "
              f"{load_end:.1f}, on {os.cpu_count()} cores.", "",
              "Machine: " + ", ".join(f"{k} {v}" for k, v in machine().items())]
    table = output.with_suffix(".md")
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return [output, table]
