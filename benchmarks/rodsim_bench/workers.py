"""Studies and workers (``rodsim bench workers``): ``rodsim study fig7b --size full``
(``small``: ``--size small``) with ``--workers 1`` and ``--workers 2``, each a fresh
process, interleaved, median of the repeats: wall time (what the user waits for) and CPU
time of the process and its workers (user + system, ``RUSAGE_CHILDREN``). The machine's
load average at the start and the end is recorded: on a loaded machine the wall-time ratio
says little about what a second core would give, the CPU ratio says what the workers cost.

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

import numpy as np
import xarray as xr

from rodsim.io.archive import write_dataset
from rodsim_bench.machine import machine

__all__ = ["run", "WORKERS"]

SIZES = {"small": {"repeats": 1, "study_size": "small"},
         "full": {"repeats": 3, "study_size": "full"}}
STUDY = "fig7b"
WORKERS = (1, 2)


def _load() -> float:
    try:
        return float(Path("/proc/loadavg").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return float("nan")


def _study(workers: int, study_size: str, folder: str) -> tuple[float, float]:
    """(wall, CPU) seconds of one ``rodsim study`` process with its workers."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "rodsim", "study", STUDY, "--size",
                           study_size, "--workers", str(workers), "-o",
                           f"{folder}/{STUDY}-{workers}.nc"], capture_output=True, text=True,
                          env=env, timeout=1800, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"study with {workers} workers: exit {done.returncode}: "
                           f"{done.stderr[-500:]}")
    return wall, (after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)


def run(size: str, output_dir: str | Path, progress=None) -> list[Path]:
    setting = SIZES[size]
    repeats = setting["repeats"]
    wall = {w: [] for w in WORKERS}
    cpu = {w: [] for w in WORKERS}
    load_start = _load()
    with tempfile.TemporaryDirectory(prefix="rodsim-workers-") as folder:
        for repeat in range(repeats):
            for workers in WORKERS:
                if progress is not None:
                    progress(repeat / repeats, f"workers: {workers} workers "
                             f"({repeat + 1}/{repeats})")
                w, c = _study(workers, setting["study_size"], folder)
                wall[workers].append(w)
                cpu[workers].append(c)
    load_end = _load()
    med_wall = {w: float(np.median(wall[w])) for w in WORKERS}
    med_cpu = {w: float(np.median(cpu[w])) for w in WORKERS}
    ds = xr.Dataset(
        {"wall": (("workers", "repeat"), np.array([wall[w] for w in WORKERS]),
                  {"units": "s", "long_name": "wall time of the study process"}),
         "cpu": (("workers", "repeat"), np.array([cpu[w] for w in WORKERS]),
                 {"units": "s", "long_name": "CPU time of the study process and its "
                  "workers"})},
        coords={"workers": ("workers", np.array(WORKERS), {"long_name": "--workers"}),
                "repeat": ("repeat", np.arange(repeats), {"long_name": "repeat"})})
    ds.attrs = {"title": f"rodsim: study {STUDY} on 1 and 2 workers",
                "benchmark": "workers", "size": size,
                "study_size": setting["study_size"], "load_average_start": load_start,
                "load_average_end": load_end,
                **{f"machine_{k}": v for k, v in machine().items()}}
    output = Path(output_dir) / f"workers-{size}.nc"
    write_dataset(ds, output)
    lines = [f"# `rodsim study {STUDY} --size {setting['study_size']}` on 1 and 2 workers "
             f"({size}, median of {repeats})", "",
             "| workers | wall [s] | CPU [s] | speed-up (wall, vs 1) | CPU / CPU(1) |",
             "|--:|--:|--:|--:|--:|"]
    lines += [f"| {w} | {med_wall[w]:.2f} | {med_cpu[w]:.2f} | "
              f"{med_wall[1] / med_wall[w]:.2f} | {med_cpu[w] / med_cpu[1]:.2f} |"
              for w in WORKERS]
    lines += ["", f"Load average (1 min) at the start {load_start:.1f}, at the end "
              f"{load_end:.1f}, on {os.cpu_count()} cores.", "",
              "Machine: " + ", ".join(f"{k} {v}" for k, v in machine().items())]
    table = output.with_suffix(".md")
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return [output, table]
