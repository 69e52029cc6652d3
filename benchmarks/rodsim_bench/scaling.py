"""Scaling benchmark (``rodsim bench scaling``): cost of every integrator in N.

Scene ``table1-50g`` (one rod, 50 g hanging mass) with N control points, N = 10 … 4000
(about 7 N unknowns), every integrator with its scene defaults (``cvode``/``ida`` with
``linear_solver = "auto"``: band up to ``BAND_LIMIT`` unknowns, sparse above). Then the band
and sparse linear solvers side by side for CVODE and IDA at several system sizes n, to find
where the band solver's dense (n × n) Jacobian template stops paying.

Every (configuration, N) runs in a fresh process (spawned, one process per job, on the study
runner's worker pool, rodsim/app/worker_pool.py): it imports rodsim, builds the model, runs
one warm-up solve and then up to 3 timed solves (fewer for long runs), and reports the wall
times (minimum = the time) and its peak resident set size (``VmHWM`` of /proc/self/status:
``getrusage().ru_maxrss`` is not usable here, on Linux it carries the spawning parent's peak
across fork + exec).
**Peak memory** of a run = that peak minus the peak of a baseline process that only imports
rodsim and builds the same model (the smaller of two such processes). A job
that exceeds its wall-time budget (``solver.max_wall_time``, then a hard kill of the
process), raises, or fails to converge is recorded with its message, not dropped. **Error**
= largest control-point distance to the ``static`` solution at the same N, over L.

In the full size, the integrators whose t(N_max)/t(N_max/10) exceeds 12 (i.e. grow clearly
faster than linearly) are profiled with cProfile at both sizes, to show where the time goes.

Writes ``scaling-<size>.nc``, ``scaling-<size>.png``, ``scaling-<size>.md`` (and, full size,
``scaling-<size>-profile.json``) under ``output_dir``.
"""

from __future__ import annotations

import json
import os
import textwrap
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rodsim_bench.work_precision import (
    count,
    fmt,
    machine_attributes,
    machine_line,
    markdown_profile,
    markdown_table,
    profile_solve,
    seconds,
)

__all__ = ["run", "report", "Job", "run_jobs", "SCENE"]

Progress = Callable[[float | None, str], None]

SCENE = "table1-50g"
#: Aim: t(N_max) / t(N_max / 10) at most this (about linear cost in N).
LINEAR_AIM = 12.0


@dataclass(frozen=True)
class Config:
    """One integrator configuration of the benchmark."""

    label: str
    integrator: str
    overrides: tuple[str, ...] = ()
    group: str = "auto"  # "auto": the integrators as shipped; "linear solver": band vs sparse


AUTO = (Config("static", "static"), Config("paper", "paper"),
        Config("cvode", "cvode"), Config("ida", "ida"))


def _forced(integrator: str, formulation: str, solver: str) -> Config:
    return Config(f"{integrator} {formulation} {solver}", integrator,
                  (f"solver.{integrator}.formulation={formulation}",
                   f"solver.{integrator}.linear_solver={solver}"), "linear solver")


def plan(size: str) -> tuple[list[int], list[tuple[Config, list[int]]]]:
    """The N values and, per configuration, the N at which it runs."""
    if size == "small":
        nodes = [10, 200]
        forced = [(_forced(i, "overdamped", s), [200]) for i in ("cvode", "ida")
                  for s in ("band", "sparse")]
        return nodes, [(c, nodes) for c in AUTO] + forced
    nodes = [10, 20, 40, 100, 200, 400, 1000, 2000, 4000]
    band_nodes = [40, 100, 200, 400, 1000, 2000]
    forced = [(_forced(i, "overdamped", s), band_nodes) for i in ("cvode", "ida")
              for s in ("band", "sparse")]
    forced += [(_forced("cvode", "inertial", s), [40, 200, 400, 1000]) for s in
               ("band", "sparse")]
    return nodes, [(c, nodes) for c in AUTO] + forced


# ------------------------------------------------------------------ child process


@dataclass(frozen=True)
class Job:
    """What one fresh process does: a baseline (import + build), timed runs, or a profile."""

    kind: str  # "baseline" | "time" | "profile"
    nodes: int
    integrator: str = ""
    overrides: tuple[str, ...] = ()
    max_wall_time: float = 120.0
    max_repeats: int = 3


def _maxrss_bytes() -> int:
    """Peak resident set size of this process [bytes].

    ``VmHWM`` of /proc/self/status where it exists, not ``getrusage(RUSAGE_SELF).ru_maxrss``:
    on Linux ru_maxrss survives fork + exec, so a spawned child reports at least its
    parent's peak (measured: a child of a 428 MiB parent reads 428 MiB, its VmHWM 14 MiB).
    """
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024  # kB
    except (OSError, ValueError, IndexError):
        pass
    return _ru_maxrss_bytes()


def _ru_maxrss_bytes() -> int:
    import resource

    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024  # KiB on Linux


def _child(job: Job) -> dict[str, Any]:
    import rodsim

    scene = rodsim.load_scene(SCENE, [f"nodes={job.nodes}", *job.overrides,
                                      f"solver.max_wall_time={job.max_wall_time!r}"])
    model = rodsim.build_model(scene)
    out: dict[str, Any] = {"unknowns": model.n, "nonzeros": model.nnz,
                           "maxrss_before": _maxrss_bytes()}
    if job.kind == "baseline":
        out["maxrss"] = _maxrss_bytes()
        return out
    if any(term.dynamic for term in model.terms):  # a reused model would carry state
        raise RuntimeError("the scaling scene must have no dynamic (registration) terms")
    if job.kind == "profile":
        out.update(profile_solve(scene, job.integrator))
        return out

    times, result = [], None
    for k in range(1 + job.max_repeats):
        begin, begin_cpu = time.perf_counter(), time.process_time()
        result = rodsim.solve(scene, job.integrator, model=model)
        elapsed = time.perf_counter() - begin
        if k == 0:
            out["first_run_time"] = elapsed
            out["first_run_cpu"] = time.process_time() - begin_cpu
            if not result.success:
                break
        else:
            times.append(elapsed)
        # Fewer repeats for long runs: their timing noise is relatively small.
        if (k >= 1 and elapsed > 5.0) or (k >= 2 and elapsed > 1.0) or (
                k == 0 and elapsed > 0.5 * job.max_wall_time):
            break
    out["maxrss"] = _maxrss_bytes()
    out["ru_maxrss"] = _ru_maxrss_bytes()
    out["times"] = times
    out["success"] = bool(result.success)
    out["message"] = result.message
    out["stats"] = {key: float(value) for key, value in result.stats.items()}
    out["positions"] = np.concatenate([r.positions for r in result.rods.values()]).tolist()
    out["length"] = float(model.length_scale)
    if job.integrator in ("cvode", "ida"):
        from rodsim.solvers import registered_integrators

        integrator = registered_integrators()[job.integrator]
        runner = integrator.for_scene(scene)
        system = runner.init(model).system
        out["system_size"] = int(system.size)
        out["linear_solver"] = runner.linear_solver(system.size)
    return out


def _child_run(job: Job) -> dict[str, Any]:
    """What a worker process runs: ``job``, and a dict back (or the error, never lost)."""
    try:
        return {"ok": True, **_child(job)}
    except BaseException as exc:  # noqa: BLE001  (reported to the parent, never lost)
        return {"ok": False, "error": f"{type(exc).__name__}: {exc}",
                "traceback": traceback.format_exc(limit=6), "maxrss": _maxrss_bytes()}


def run_jobs(jobs: list[Job], workers: int, deadline: Callable[[Job], float],
             progress: Progress, label: Callable[[Job], str]) -> list[dict[str, Any]]:
    """Run every job in a fresh spawned process of its own, ``workers`` at a time, on the
    study runner's worker pool (rodsim/app/worker_pool.py); a process that exceeds
    ``deadline(job)`` seconds is killed, and one that dies is recorded, as a failed job."""
    from rodsim.app.worker_pool import TaskFailure, run_tasks

    results: list[dict[str, Any] | None] = [None] * len(jobs)
    finished = 0

    def done(index: int, value: Any, seconds: float) -> None:
        nonlocal finished
        if isinstance(value, TaskFailure):
            value = {"ok": False, "error": (f"the process died without a result ({value.detail})"
                                            if value.kind == "died" else value.detail)}
        value["process_time"] = seconds
        results[index] = value
        finished += 1
        progress(finished / len(jobs), f"scaling: {label(jobs[index])} done "
                 f"({finished}/{len(jobs)})")

    run_tasks(_child_run, [(index, (job,)) for index, job in enumerate(jobs)], workers, done,
              deadline=lambda index: deadline(jobs[index]), fresh_processes=True)
    return [r or {"ok": False, "error": "not run"} for r in results]


# ------------------------------------------------------------------------ outputs


@dataclass
class Table:
    """Results on the (config, N) grid, filled from the jobs."""

    configs: list[Config]
    nodes: list[int]
    values: dict[str, np.ndarray] = field(default_factory=dict)
    text: dict[str, np.ndarray] = field(default_factory=dict)

    def array(self, name: str) -> np.ndarray:
        if name not in self.values:
            self.values[name] = np.full((len(self.configs), len(self.nodes)), np.nan)
        return self.values[name]

    def strings(self, name: str) -> np.ndarray:
        if name not in self.text:
            self.text[name] = np.full((len(self.configs), len(self.nodes)), "", dtype=object)
        return self.text[name]


VARIABLES = {
    "wall_time": ("s", "wall time to equilibrium, minimum over the timed runs (the warm-up "
                       "run's if none)"),
    "first_run_time": ("s", "wall time of the warm-up run (first solve in the process)"),
    "timed_runs": ("1", "number of timed runs after the warm-up"),
    "peak_memory": ("MiB", "peak resident memory of the runs minus that of a process that "
                           "only imports rodsim and builds the model"),
    "solve_memory": ("MiB", "peak resident memory of the runs above the same process's peak "
                            "before its first solve (in-process cross-check of peak_memory)"),
    "maxrss": ("MiB", "peak resident set size of the run's process (VmHWM)"),
    "ru_maxrss": ("MiB", "getrusage ru_maxrss of the run's process (on Linux at least the "
                         "spawning parent's peak: not used)"),
    "maxrss_before_solve": ("MiB", "peak resident set size of the run's process after the "
                                   "model build, before the first solve"),
    "success": ("1", "1 if the run reached equilibrium, 0 if it failed, NaN if not run"),
    "error": ("1", "largest control-point distance to the static solution at the same N, "
                   "over L"),
    "system_size": ("1", "size of the SUNDIALS system (cvode, ida)"),
    "steps": ("1", "integrator steps"),
    "force_evals": ("1", "evaluations of F(x)"),
    "jacobian_evals": ("1", "evaluations of the analytic Jacobian"),
    "newton_iters": ("1", "Newton iterations"),
    "effective_tolerance": ("1", "residual tolerance used (raised to the round-off floor)"),
}


def _fill(table: Table, jobs: list[Job], results: list[dict[str, Any]],
          keys: list[tuple[int, int]], baselines: dict[int, dict[str, Any]]) -> None:
    mib = 1.0 / 2**20
    for job, result, (i, j) in zip(jobs, results, keys, strict=True):
        base = baselines.get(job.nodes, {})
        if not result.get("ok"):
            table.array("success")[i, j] = 0
            table.strings("message")[i, j] = result.get("error", "failed")
            table.array("maxrss")[i, j] = result.get("maxrss", np.nan) * mib
            continue
        times = result["times"]
        table.array("wall_time")[i, j] = min(times) if times else result["first_run_time"]
        table.array("first_run_time")[i, j] = result["first_run_time"]
        table.array("timed_runs")[i, j] = len(times)
        table.array("maxrss")[i, j] = result["maxrss"] * mib
        table.array("ru_maxrss")[i, j] = result["ru_maxrss"] * mib
        table.array("maxrss_before_solve")[i, j] = result["maxrss_before"] * mib
        table.array("solve_memory")[i, j] = (result["maxrss"] - result["maxrss_before"]) * mib
        if base.get("ok"):
            table.array("peak_memory")[i, j] = (result["maxrss"] - base["maxrss"]) * mib
        table.array("success")[i, j] = int(result["success"])
        table.strings("message")[i, j] = result["message"]
        table.strings("linear_solver")[i, j] = result.get("linear_solver", "")
        table.array("system_size")[i, j] = result.get("system_size", np.nan)
        for key in ("steps", "force_evals", "jacobian_evals", "newton_iters",
                    "effective_tolerance"):
            table.array(key)[i, j] = result["stats"].get(key, np.nan)


def _errors(table: Table, results: dict[tuple[int, int], dict[str, Any]]) -> None:
    static = table.configs.index(AUTO[0])
    for (i, j), result in results.items():
        reference = results.get((static, j))
        if not (result.get("ok") and reference and reference.get("ok")
                and reference.get("success")):
            continue
        a, b = np.asarray(result["positions"]), np.asarray(reference["positions"])
        table.array("error")[i, j] = float(np.max(np.linalg.norm(a - b, axis=1))
                                           / result["length"])


def _dataset(table: Table, unknowns: dict[int, int], size: str):
    import xarray as xr

    dims = ("config", "nodes")
    data_vars = {name: (dims, table.array(name), {"units": units, "long_name": long})
                 for name, (units, long) in VARIABLES.items()}
    data_vars["message"] = (dims, table.strings("message").astype(str),
                            {"long_name": "the solver's message, or why the job failed"})
    data_vars["linear_solver"] = (dims, table.strings("linear_solver").astype(str),
                                  {"long_name": "SUNDIALS linear solver used (cvode, ida)"})
    data_vars["unknowns"] = ("nodes", np.array([unknowns.get(n, -1) for n in table.nodes]),
                             {"units": "1", "long_name": "free coordinates of the model"})
    coords = {
        "config": ("config", np.array([c.label for c in table.configs], dtype=str),
                   {"long_name": "integrator configuration"}),
        "nodes": ("nodes", np.array(table.nodes), {"units": "1",
                                                   "long_name": "control points N"}),
        "integrator": ("config", np.array([c.integrator for c in table.configs], dtype=str),
                       {"long_name": "rodsim integrator"}),
        "group": ("config", np.array([c.group for c in table.configs], dtype=str),
                  {"long_name": "'auto' (as shipped) or 'linear solver' (band vs sparse)"}),
        "overrides": ("config", np.array([" ".join(c.overrides) for c in table.configs],
                                         dtype=str),
                      {"long_name": "scene overrides of the configuration"}),
    }
    from rodsim.solvers.sundials import BAND_LIMIT

    ds = xr.Dataset(data_vars, coords=coords)
    ds.attrs.update({
        "title": "rodsim scaling benchmark",
        "benchmark": "scaling",
        "size": size,
        "scene": SCENE,
        "band_limit": BAND_LIMIT,
        "time_definition": "wall time of rodsim.solve(scene, integrator, model=model) in a "
                           "fresh process, minimum over up to 3 timed runs after a warm-up",
        "memory_definition": "peak RSS (VmHWM) of the run's process minus that of a process "
                             "that only imports rodsim and builds the model (smaller of two "
                             "such processes)",
        **machine_attributes(),
    })
    return ds


def ratio(ds, config: str, high: int, low: int) -> float:
    """t(high) / t(low) for one configuration (NaN if either is missing)."""
    row = ds["wall_time"].sel(config=config)
    nodes = ds["nodes"].values.tolist()
    if high not in nodes or low not in nodes:
        return float("nan")
    return float(row.sel(nodes=high) / row.sel(nodes=low))


def band_threshold(ds, integrator: str, formulation: str) -> tuple[float, list[str]]:
    """Smallest system size n from which sparse is faster than band at every larger n
    (NaN if band is never beaten), and one summary line per n where both succeeded."""
    band = f"{integrator} {formulation} band"
    sparse = f"{integrator} {formulation} sparse"
    if band not in ds["config"].values or sparse not in ds["config"].values:
        return float("nan"), []
    rows, sizes, ratios = [], [], []
    for n in ds["nodes"].values:
        tb = float(ds["wall_time"].sel(config=band, nodes=n))
        ts = float(ds["wall_time"].sel(config=sparse, nodes=n))
        both = (float(ds["success"].sel(config=band, nodes=n)) == 1
                and float(ds["success"].sel(config=sparse, nodes=n)) == 1)
        if not (both and np.isfinite(tb) and np.isfinite(ts)):
            continue
        size = float(ds["system_size"].sel(config=band, nodes=n))
        sizes.append(size)
        ratios.append(tb / ts)
        rows.append(n)
    threshold = float("nan")
    for k in range(len(sizes)):
        if all(r > 1.0 for r in ratios[k:]):
            threshold = sizes[k]
            break
    return threshold, [f"{int(s)}: {r:.2f}" for s, r in zip(sizes, ratios, strict=True)]


def fitted_exponent(nodes: np.ndarray, times: np.ndarray) -> float:
    """p of wall time ∝ N^p, least squares in log–log over the finite times (NaN with fewer
    than two)."""
    ok = np.isfinite(times) & (times > 0)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(nodes[ok]), np.log(times[ok]), 1)[0])


def measured_result(ds) -> str:
    """The figure's result line, computed from the archive: the exponent p of time ∝ N^p of
    each integrator (its default configuration) over N ≥ N_max/40 (the fixed costs of small
    N left out), each one's time at the largest N against static's, and from which size
    sparse beats band (CVODE overdamped)."""
    nodes = ds["nodes"].values.astype(float)
    upper = nodes >= nodes.max() / 40.0
    auto = [c for c, g in zip(ds["config"].values, ds["group"].values, strict=True)
            if g == "auto"]
    exponents, largest = [], []
    for config in auto:
        times = ds["wall_time"].sel(config=config).values.astype(float)
        ok = ds["success"].sel(config=config).values == 1
        times = np.where(ok, times, np.nan)
        exponents.append(f"{config} {fitted_exponent(nodes[upper], times[upper]):.2f}")
        largest.append(times[-1])
    text = (f"wall time ∝ N^p, p = {', '.join(exponents)} "
            f"(N = {int(nodes[upper][0])}–{int(nodes.max())})")
    if "static" in auto and np.isfinite(largest[auto.index("static")]):
        base = largest[auto.index("static")]
        others = [f"{c} {t / base:.2g}×" for c, t in zip(auto, largest, strict=True)
                  if c != "static" and np.isfinite(t)]
        text += f"; at N = {int(nodes.max())} static {base:.3g} s" + (
            f", {', '.join(others)}" if others else "")
    threshold, rows = band_threshold(ds, "cvode", "overdamped")
    if rows:
        text += ("; CVODE: band faster than sparse at every n measured" if np.isnan(threshold)
                 else f"; CVODE: sparse faster than band from n = {int(threshold)}")
    return text


#: The band-vs-sparse panels: how each linear solver is drawn, and what its legend says.
SOLVER_STYLES = {"band": ({"ls": "-", "mfc": None}, "band: solid line, filled markers"),
                 "sparse": ({"ls": "--", "mfc": "white"}, "sparse: dashed line, open markers")}
#: Markers of the formulations in the band-vs-sparse panels.
FORMULATION_MARKERS = {"overdamped": "o", "inertial": "s"}


def _plot(ds, path: Path) -> Path:
    """The scaling figure, drawn in rodsim's style (:func:`rodsim.app.figures.style`)."""
    from rodsim.app.figures import style  # selects the Agg backend

    with style():
        return _draw(ds, path)


def _draw(ds, path: Path) -> Path:
    """The four panels of :func:`_plot`: time and memory against N (every integrator) and
    against n (band against sparse)."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    nodes = ds["nodes"].values
    auto = [c for c, g in zip(ds["config"].values, ds["group"].values, strict=True)
            if g == "auto"]
    colours = {"static": "black", "paper": "tab:blue", "cvode": "tab:red", "ida": "tab:green"}
    for config in auto:
        row = ds.sel(config=config)
        ok = row["success"].values == 1
        axes[0, 0].loglog(nodes[ok], row["wall_time"].values[ok], "o-", label=config,
                          color=colours.get(config))
        axes[0, 1].loglog(nodes[ok], np.maximum(row["peak_memory"].values[ok], 0.1), "o-",
                          label=config, color=colours.get(config))
        bad = row["success"].values == 0
        if bad.any():
            axes[0, 0].plot(nodes[bad], np.full(bad.sum(), np.nanmax(ds["wall_time"].values)),
                            "x", color=colours.get(config), ms=9)
    finite = ds["wall_time"].values[np.isfinite(ds["wall_time"].values)]
    if finite.size:
        guide = nodes / nodes[0] * float(np.nanmin(finite))
        axes[0, 0].loglog(nodes, guide, "k:", lw=0.8, label="∝ N")
    axes[0, 0].set(xlabel="control points N", ylabel="wall time to equilibrium [s]",
                   title=f"{ds.attrs['scene']}: time (× = failed)")
    axes[0, 1].set(xlabel="control points N", ylabel="peak memory above baseline [MiB]",
                   title="peak memory (values < 0.1 MiB drawn at 0.1)")
    forced = [c for c, g in zip(ds["config"].values, ds["group"].values, strict=True)
              if g == "linear solver"]
    for config in forced:
        row = ds.sel(config=config)
        ok = row["success"].values == 1
        size = row["system_size"].values[ok]
        colour = "tab:red" if config.startswith("cvode") else "tab:green"
        solver = "band" if config.endswith("band") else "sparse"
        look = SOLVER_STYLES[solver][0] | {
            "marker": FORMULATION_MARKERS["inertial" if "inertial" in config else "overdamped"],
            "color": colour, "label": config}
        axes[1, 0].loglog(size, row["wall_time"].values[ok], **look)
        axes[1, 1].loglog(size, np.maximum(row["peak_memory"].values[ok], 0.1), **look)
    for ax in axes[1]:
        ax.axvline(ds.attrs["band_limit"], color="grey", ls=":", lw=1,
                   label=f"BAND_LIMIT = {ds.attrs['band_limit']}")
        if forced:  # which line is which solver, whatever the configuration names say
            handles, labels = ax.get_legend_handles_labels()
            for look, text in SOLVER_STYLES.values():
                handles.append(Line2D([], [], color="0.3", marker="o", **look))
                labels.append(text)
            ax.legend(handles, labels)
    axes[1, 0].set(xlabel="unknowns of the SUNDIALS system n", ylabel="wall time [s]",
                   title="band vs sparse: time")
    axes[1, 1].set(xlabel="unknowns of the SUNDIALS system n",
                   ylabel="peak memory above baseline [MiB]", title="band vs sparse: memory")
    for ax in axes.ravel():
        ax.grid(True, which="major", alpha=0.3)
        if ax.get_legend_handles_labels()[0] and ax.get_legend() is None:
            ax.legend()
    fig.suptitle(textwrap.fill(f"Scaling in N ({ds.attrs['size']}) — measured: "
                               f"{measured_result(ds)}", 130)
                 + f"\n{ds.attrs.get('machine_cpu', '')}, {ds.attrs.get('machine_date', '')}")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def _markdown(ds, profiles: list[dict[str, Any]]) -> str:
    nodes = ds["nodes"].values.tolist()
    high = nodes[-1]
    low = high // 10 if high // 10 in nodes else nodes[0]
    lines = [f"# Scaling benchmark ({ds.attrs['size']})", "",
             f"Scene `{ds.attrs['scene']}` with N control points; each (configuration, N) in "
             "a fresh process: warm-up solve, then up to 3 timed solves (time = minimum). "
             "Peak memory = peak RSS (VmHWM) of the run's process minus that of a process "
             "that only imports rodsim and builds the model.", "", machine_line(ds.attrs), ""]
    auto = [c for c, g in zip(ds["config"].values, ds["group"].values, strict=True)
            if g == "auto"]
    unknowns = ds["unknowns"].values.tolist()
    lines += ["## Time to equilibrium [s]", ""]
    rows = []
    for n, u in zip(nodes, unknowns, strict=True):
        row = [str(n), str(u)]
        for config in auto:
            point = ds.sel(config=config, nodes=n)
            text = fmt(float(point["wall_time"]))
            if float(point["success"]) == 0:
                text = "FAILED"
            solver = str(point["linear_solver"].values)
            row.append(f"{text} ({solver})" if solver and text != "FAILED" else text)
        rows.append(row)
    lines += markdown_table(["N", "unknowns", *auto], rows)
    lines += ["", f"## Growth t({high}) / t({low}) (aim ≤ {LINEAR_AIM:g}: about linear)", ""]
    lines += markdown_table(
        ["integrator", f"t({low})", f"t({high})", "ratio", "aim"],
        [[c, seconds(float(ds["wall_time"].sel(config=c, nodes=low))),
          seconds(float(ds["wall_time"].sel(config=c, nodes=high))),
          fmt(ratio(ds, c, high, low)),
          "holds" if ratio(ds, c, high, low) <= LINEAR_AIM else "does not hold"]
         for c in auto])
    lines += ["", "## Peak memory above baseline [MiB]", ""]
    rows = [[str(n)] + [fmt(float(ds["peak_memory"].sel(config=c, nodes=n)))
                        for c in auto] for n in nodes]
    lines += markdown_table(["N", *auto], rows)
    lines += ["", "## Work counts (steps / F evaluations / Jacobian evaluations)", ""]
    rows = [[str(n)] + ["/".join(count(float(ds[k].sel(config=c, nodes=n)))
                                 for k in ("steps", "force_evals", "jacobian_evals"))
                        for c in auto] for n in nodes]
    lines += markdown_table(["N", *auto], rows)
    forced = [c for c, g in zip(ds["config"].values, ds["group"].values, strict=True)
              if g == "linear solver"]
    if forced:
        lines += ["", "## Band vs sparse linear solver", "",
                  f"rodsim's `BAND_LIMIT` = {ds.attrs['band_limit']} unknowns (`auto` uses "
                  "band up to it).", ""]
        rows = []
        for config in forced:
            for n in nodes:
                point = ds.sel(config=config, nodes=n)
                if not np.isfinite(float(point["success"])):
                    continue
                status = "ok" if float(point["success"]) == 1 else (
                    "FAILED: " + str(point["message"].values)[:100])
                rows.append([config, str(n), count(float(point["system_size"])),
                             seconds(float(point["wall_time"])),
                             fmt(float(point["peak_memory"])),
                             fmt(float(point["solve_memory"])), status])
        lines += markdown_table(["configuration", "N", "system size n", "time",
                                 "peak memory [MiB]", "in-process [MiB]", "status"], rows,
                                "lrrrrrl")
        lines += ["", "Time ratio band / sparse per system size n (> 1: sparse is faster), "
                  "and the measured threshold (smallest n from which sparse is faster at "
                  "every larger measured n):", ""]
        for integrator, formulation in (("cvode", "overdamped"), ("ida", "overdamped"),
                                        ("cvode", "inertial")):
            threshold, summary = band_threshold(ds, integrator, formulation)
            if summary:
                verdict = (f"threshold n ≈ {threshold:.0f}" if np.isfinite(threshold) else
                           "no threshold: sparse is not faster at every larger n measured")
                lines.append(f"- {integrator} {formulation}: " + ", ".join(summary)
                             + f"; {verdict}")
    failed = [(str(c), int(n), str(ds["message"].sel(config=c, nodes=n).values))
              for c in ds["config"].values for n in nodes
              if float(ds["success"].sel(config=c, nodes=n)) == 0]
    if failed:
        lines += ["", "## Failed runs", ""]
        lines += markdown_table(["configuration", "N", "message"],
                                [[c, str(n), m[:200]] for c, n, m in failed])
    if profiles:
        lines += ["", "## Where the time goes (cProfile, one solve after a warm-up)", ""]
        for profile in profiles:
            if not profile.get("ok"):
                lines.append(f"- {profile['label']}: profile failed ({profile.get('error')})")
                continue
            lines += markdown_profile(profile["label"], profile)
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------- run


def run(size: str, output_dir: Path | str, progress: Progress | None = None) -> list[Path]:
    """Run the benchmark at ``size`` (``small`` or ``full``); returns the written paths."""
    from rodsim.io.archive import write_dataset

    if size not in ("small", "full"):
        raise ValueError(f"size {size!r}: expected 'small' or 'full'")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    progress = progress or (lambda fraction, status: None)
    output = Path(output_dir)
    output.mkdir(parents=True, exist_ok=True)
    nodes, grid = plan(size)
    max_wall_time = 30.0 if size == "small" else 120.0
    max_repeats = 1 if size == "small" else 3
    # Small: a smoke test, two processes at a time; full: one at a time (clean timings).
    workers = 2 if size == "small" else 1
    configs = [config for config, _ in grid]

    every_n = sorted({n for _, ns in grid for n in ns})
    # Two baseline processes per N (the smaller maxrss is kept: with transparent huge pages
    # a process's resident size can jump by a few MiB for reasons of its own).
    baseline_jobs = [Job("baseline", n) for n in every_n for _ in range(2)]
    jobs = list(baseline_jobs)
    keys: list[tuple[int, int]] = []
    for i, (config, ns) in enumerate(grid):
        for n in ns:
            jobs.append(Job("time", n, config.integrator, config.overrides, max_wall_time,
                            max_repeats))
            keys.append((i, every_n.index(n)))

    def deadline(job: Job) -> float:
        return 120.0 + (1 + job.max_repeats) * job.max_wall_time

    def label(job: Job) -> str:
        what = job.integrator or job.kind
        return f"{what} {' '.join(o.split('=')[-1] for o in job.overrides)} N={job.nodes}"

    results = run_jobs(jobs, workers, deadline, progress, label)
    baselines: dict[int, dict[str, Any]] = {}
    for job, result in zip(baseline_jobs, results[:len(baseline_jobs)], strict=True):
        best = baselines.get(job.nodes)
        if result.get("ok") and (best is None or result["maxrss"] < best["maxrss"]):
            baselines[job.nodes] = result
    unknowns = {n: r.get("unknowns", -1) for n, r in baselines.items()}
    table = Table(configs, every_n)
    timed_jobs, timed_results = jobs[len(baseline_jobs):], results[len(baseline_jobs):]
    _fill(table, timed_jobs, timed_results, keys, baselines)
    _errors(table, dict(zip(keys, timed_results, strict=True)))
    ds = _dataset(table, unknowns, size)

    profiles: list[dict[str, Any]] = []
    if size == "full":
        high, low = every_n[-1], every_n[-1] // 10
        slow = [c for c in configs if c.group == "auto"
                and not ratio(ds, c.label, high, low) <= LINEAR_AIM]
        if slow:
            profile_jobs = [Job("profile", n, c.integrator, c.overrides, max_wall_time)
                            for c in slow for n in (low, high)]
            profile_results = run_jobs(profile_jobs, 1, deadline, progress, label)
            for job, result in zip(profile_jobs, profile_results, strict=True):
                profiles.append({"label": f"{job.integrator} N={job.nodes}", **result})

    stem = output / f"scaling-{size}"
    paths = [write_dataset(ds, stem.with_suffix(".nc"))]
    if profiles:
        profile_path = stem.parent / f"{stem.name}-profile.json"
        profile_path.write_text(json.dumps(
            [{k: v for k, v in p.items() if k != "traceback"} for p in profiles],
            indent=1, default=float) + "\n")
        paths.append(profile_path)
    return paths + report(ds, stem)


def report(ds, stem: Path | str) -> list[Path]:
    """Draw the figure and write the markdown of a scaling Dataset, with the profiles of
    ``<stem>-profile.json`` if that file exists (also from a re-opened archive)."""
    stem = Path(stem)
    profile_path = stem.parent / f"{stem.name}-profile.json"
    profiles = json.loads(profile_path.read_text()) if profile_path.exists() else []
    markdown = stem.with_suffix(".md")
    markdown.write_text(_markdown(ds, profiles))
    return [_plot(ds, stem.with_suffix(".png")), markdown]
