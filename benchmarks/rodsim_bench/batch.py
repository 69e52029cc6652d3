"""Many equilibria (``rodsim bench batch``): equilibria per second of ``rodsim.solve_many``
on random tdcr-two-segment cases (the tensions of three tendons, 0-4 N and 0-3 N, and the
tip force's z component, -0.05 to 0.05 N; seeded), in this process (1 worker), on 2 local
worker processes, and (full size) on a dask LocalCluster of 2 workers; then warm-started
(``warm=True``, rodsim/app/batch_warm.py) in this process and on 2 local workers.

For each runner: the wall time and the CPU time of this process and its worker processes
(``time.process_time`` and ``RUSAGE_CHILDREN``: the pool's and the LocalCluster's workers
are this process's children, counted once they are reaped at the end of the call), after a
warm-up that loads the kernels; the best of the repeats, the runners interleaved. The
equilibria/s per core is cases / CPU, what the issue's aim (500/s per core) is about; the
wall rate is what a user waits for (on a shared machine the second core may be busy: the
load average at the start and the end is recorded). Every runner's equilibria are compared
with the 1-worker run of the same kind (cold or warm: the chunks and workers must not
change a bit), every warm equilibrium with the cold one of its case (the cold batch is each
case solved alone: checked on the first cases, every case at full size, ``rodsim.solve``
with its own model; a case that fails alone is counted), and the first cases of the warm
batch with those solved alone. Outputs ``batch-<size>.nc`` and
``batch-<size>.md``.
"""

from __future__ import annotations

import resource
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

import rodsim
from rodsim.app.batch import solve_many
from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with
from rodsim.io.archive import write_dataset
from rodsim_bench.machine import machine

__all__ = ["run", "RUNNERS", "KEYS", "random_cases"]

SCENE = "tdcr-two-segment"
SIZES = {"small": {"cases": 40, "repeats": 1, "alone": 5, "dask": False},
         "full": {"cases": 1000, "repeats": 3, "alone": 1000, "dask": True}}
#: (runner, workers, warm): in this process, the local pool, a dask LocalCluster; cold
#: (each case from rest) or warm-started.
RUNNERS = (("local", 1, False), ("local", 2, False), ("dask", 2, False), ("local", 1, True),
           ("local", 2, True))
KEYS = ("s1a.tendon_string.tension", "s2b.tendon_string.tension",
        "s2c.tendon_string.tension", "tip_load.force[2]")


def random_cases(count: int, seed: int = 35) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {KEYS[0]: rng.uniform(0.0, 4.0, count), KEYS[1]: rng.uniform(0.0, 3.0, count),
            KEYS[2]: rng.uniform(0.0, 3.0, count), KEYS[3]: rng.uniform(-0.05, 0.05, count)}


def _load() -> float:
    try:
        return float(Path("/proc/loadavg").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return float("nan")


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(cases: dict, runner: str, workers: int, warm: bool, chunk: int
           ) -> tuple[float, float, xr.Dataset]:
    """(wall, CPU of this process and its children) of one batch, and its Dataset."""
    wall, own, children = time.perf_counter(), time.process_time(), _children_cpu()
    with tempfile.TemporaryDirectory() as folder:  # the archive and its parts, as a user's
        batch = solve_many(SCENE, cases, output=Path(folder) / "batch.nc", workers=workers,
                           scheduler="local" if runner == "dask" else None, chunk=chunk,
                           log=lambda message: None, warm=warm)
    return (time.perf_counter() - wall,
            time.process_time() - own + _children_cpu() - children, batch)


def run(size: str, output_dir: str | Path, progress=None) -> list[Path]:
    setting = SIZES[size]
    count, repeats = setting["cases"], setting["repeats"]
    runners = [r for r in RUNNERS if setting["dask"] or r[0] != "dask"]
    cases = random_cases(count)
    chunk = max(1, min(50, count // 8))
    solve_many(SCENE, {k: v[:2] for k, v in cases.items()})  # warm-up: kernels loaded
    load_start = _load()
    wall = {r: [] for r in runners}
    cpu = {r: [] for r in runners}
    batches = {}
    for repeat in range(repeats):
        for runner, workers, warm in runners:
            if progress is not None:
                progress(repeat / repeats, f"batch: {runner}, {workers} worker(s)"
                         f"{', warm' if warm else ''} ({repeat + 1}/{repeats})")
            seconds, spent, batch = _timed(cases, runner, workers, warm, chunk)
            wall[runner, workers, warm].append(seconds)
            cpu[runner, workers, warm].append(spent)
            batches[runner, workers, warm] = batch
    load_end = _load()
    reference = batches["local", 1, False]["position"].values
    same_kind = {r: batches["local", 1, r[2]]["position"].values for r in runners}
    failed = {r: int(b.attrs["failed_cases"]) for r, b in batches.items()}
    difference = {r: float(np.nanmax(np.abs(b["position"].values - same_kind[r])))
                  for r, b in batches.items()}
    from_cold = {r: float(np.nanmax(np.abs(b["position"].values - reference)))
                 for r, b in batches.items()}
    iterations = {r: float(np.nanmean(b["newton_iters"].values)) for r, b in batches.items()}
    warm_reference = batches["local", 1, True]["position"].values
    scene = rodsim.load_scene(SCENE)
    keys = numeric_keys(scene, list(cases))
    table = np.column_stack(list(cases.values()))
    alone = warm_alone = 0.0
    alone_failed = 0
    for case in range(setting["alone"]):
        result = rodsim.solve(scene_with(scene, keys, table[case]), "static")
        alone_failed += not result.success
        if result.success:
            shape = np.concatenate([rod.positions for rod in result.rods.values()])
            alone = max(alone, float(np.max(np.abs(shape - reference[case]))))
            warm_alone = max(warm_alone, float(np.max(np.abs(shape - warm_reference[case]))))
    names = [f"{runner}-{workers}{'-warm' if warm else ''}" for runner, workers, warm in runners]
    best_cpu = {r: min(cpu[r]) for r in runners}
    best_wall = {r: min(wall[r]) for r in runners}
    ds = xr.Dataset(
        {"wall": (("runner", "repeat"), np.array([wall[r] for r in runners]),
                  {"units": "s", "long_name": "wall time of the batch"}),
         "cpu": (("runner", "repeat"), np.array([cpu[r] for r in runners]),
                 {"units": "s", "long_name": "CPU time of the batch, its workers included"}),
         "equilibria_per_cpu_second": ("runner", np.array([count / best_cpu[r]
                                                           for r in runners]),
                                       {"units": "1/s", "long_name": "cases per CPU second "
                                        "(best repeat)"}),
         "equilibria_per_second": ("runner", np.array([count / best_wall[r] for r in runners]),
                                   {"units": "1/s", "long_name": "cases per wall second "
                                    "(best repeat)"}),
         "failed_cases": ("runner", np.array([failed[r] for r in runners]),
                          {"units": "1", "long_name": "cases that failed"}),
         "largest_difference": ("runner", np.array([difference[r] for r in runners]),
                                {"units": "m", "long_name": "largest coordinate difference "
                                 "from the 1-worker run of the same kind (cold, warm)"}),
         "difference_from_cold": ("runner", np.array([from_cold[r] for r in runners]),
                                  {"units": "m", "long_name": "largest coordinate difference "
                                   "from the cold 1-worker run (each case solved alone)"}),
         "newton_iterations": ("runner", np.array([iterations[r] for r in runners]),
                               {"units": "1", "long_name": "Newton iterations a case, mean "
                                "(last repeat)"})},
        coords={"runner": ("runner", names, {"long_name": "runner-workers"}),
                "repeat": ("repeat", np.arange(repeats), {"long_name": "repeat"})})
    ds.attrs = {"title": "rodsim: batch throughput", "benchmark": "batch", "size": size,
                "scene": SCENE, "cases": count, "chunk": chunk, "keys": ", ".join(KEYS),
                "largest_difference_from_alone": alone,
                "largest_warm_difference_from_alone": warm_alone,
                "cases_solved_alone": setting["alone"],
                "cases_failed_alone": alone_failed,
                "load_average_start": load_start, "load_average_end": load_end,
                **{f"machine_{k}": v for k, v in machine().items()}}
    output = Path(output_dir) / f"batch-{size}.nc"
    write_dataset(ds, output)
    one = best_wall[runners[0]]
    lines = [f"# Batch throughput: {count} random {SCENE} cases ({size}, best of {repeats})",
             "", "| runner | workers | starts | wall [s] | CPU [s] | equilibria/s (wall) | "
             "equilibria/s per core (CPU) | wall speed-up | Newton iterations a case | "
             "failed | largest difference from 1 worker [m] | largest difference from cold "
             "[m] |", "|---|--:|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|"]
    for r in runners:
        runner, workers, warm = r
        lines.append(f"| {runner} | {workers} | {'warm' if warm else 'cold'} | "
                     f"{best_wall[r]:.2f} | {best_cpu[r]:.2f} | "
                     f"{count / best_wall[r]:.0f} | {count / best_cpu[r]:.0f} | "
                     f"{one / best_wall[r]:.2f}× | {iterations[r]:.2f} | {failed[r]} | "
                     f"{difference[r]:.1e} | {from_cold[r]:.1e} |")
    lines += ["", f"The first {setting['alone']} cases solved alone (their own model): "
              f"largest coordinate difference {alone:.1e} m from the cold batch, "
              f"{warm_alone:.1e} m from the warm one; {alone_failed} of them failed alone. "
              f"Chunks of {chunk} cases. Load "
              f"average {load_start:.2f} at the start, {load_end:.2f} at the end.", "",
              "Machine: " + ", ".join(f"{k} {v}" for k, v in machine().items())]
    table_path = output.with_suffix(".md")
    table_path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return [output, table_path]
