"""Large-N benchmark (``rodsim bench large-n``): every integrator on ``table1-50g`` at
N = 4 000 … 100 000 control points, its time, its Newton iterations, whether it succeeds, its
distance to ``static``'s equilibrium, and the memory of the model's assembly per node.

The scaling benchmark (:mod:`rodsim_bench.scaling`) stops at N = 4 000; this one asks for
what issue 24 asked: t(100 000)/t(10 000) ≤ 12 for static and CVODE, Newton iterations at
N = 100 000 within 2× of N = 4 000, static, CVODE, IDA and paper within 1e-6 L of each other
at N = 40 000, and memory per node. Every job is a fresh process (the scaling benchmark's
:func:`~rodsim_bench.scaling.run_jobs`), one at a time (the machine is shared), with a
wall-time budget of ``solver.max_wall_time``; one solve per job (no repeats: these are long).

**Assembly memory** of a model = peak resident set size of a process that imports rodsim and
builds it, minus that of one that builds the N = 10 model (a process's fixed cost), per node.

Sizes: ``small`` N = 4 000 and 10 000 (static and CVODE), ``full`` N = 4 000, 10 000, 40 000
and 100 000 (every integrator up to 40 000; static and CVODE at 100 000). Writes
``large-n-<size>.nc`` and ``large-n-<size>.md`` under ``output_dir``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from rodsim_bench.scaling import SCENE, Job, run_jobs
from rodsim_bench.work_precision import machine_attributes, machine_line, markdown_table

__all__ = ["run", "plan"]

Progress = Callable[[float | None, str], None]

INTEGRATORS = ("static", "cvode", "ida", "paper")


def plan(size: str) -> tuple[list[int], list[tuple[str, int]]]:
    """The N values and the (integrator, N) jobs of ``size``."""
    if size == "small":
        nodes = [4000, 10000]
        return nodes, [(i, n) for n in nodes for i in ("static", "cvode")]
    nodes = [4000, 10000, 40000, 100000]
    return nodes, [(i, n) for n in nodes for i in INTEGRATORS
                   if n <= 40000 or i in ("static", "cvode")]


def run(size: str, output_dir: Path | str, progress: Progress | None = None) -> list[Path]:
    """Run the benchmark at ``size`` (``small`` or ``full``); returns the written paths."""
    if size not in ("small", "full"):
        raise ValueError(f"size {size!r}: expected 'small' or 'full'")
    progress = progress or (lambda fraction, status: None)
    nodes, grid = plan(size)
    budget = 120.0 if size == "small" else 300.0
    jobs = [Job("baseline", 10)] + [Job("baseline", n) for n in nodes]
    jobs += [Job("time", n, integrator, (), budget, 0) for integrator, n in grid]

    def label(job: Job) -> str:
        return f"{job.integrator or 'build'} N={job.nodes}"

    results = run_jobs(jobs, 1, lambda job: 120.0 + 2.0 * job.max_wall_time, progress, label)
    base, builds, runs = results[0], results[1:1 + len(nodes)], results[1 + len(nodes):]
    ds = _dataset(nodes, grid, base, builds, runs, size)
    output = Path(output_dir)
    output.mkdir(parents=True, exist_ok=True)
    stem = output / f"large-n-{size}"
    ds.to_netcdf(stem.with_suffix(".nc"))
    stem.with_suffix(".md").write_text(_markdown(ds))
    return [stem.with_suffix(".nc"), stem.with_suffix(".md")]


def _dataset(nodes: list[int], grid: list[tuple[str, int]], base: dict[str, Any],
             builds: list[dict[str, Any]], runs: list[dict[str, Any]], size: str):
    import xarray as xr

    mib = 1.0 / 2**20
    shape = (len(INTEGRATORS), len(nodes))
    arrays = {key: np.full(shape, np.nan) for key in (
        "wall_time", "cpu_time", "success", "error", "newton_iters", "finish_newton_iters",
        "steps", "jacobian_evals", "effective_tolerance", "maxrss")}
    message = np.full(shape, "", dtype=object)
    linear = np.full(shape, "", dtype=object)
    positions: dict[tuple[int, int], np.ndarray] = {}
    for (integrator, n), result in zip(grid, runs, strict=True):
        i, j = INTEGRATORS.index(integrator), nodes.index(n)
        arrays["maxrss"][i, j] = result.get("maxrss", np.nan) * mib
        if not result.get("ok"):
            arrays["success"][i, j] = 0
            message[i, j] = result.get("error", "failed")
            continue
        arrays["wall_time"][i, j] = result["first_run_time"]
        arrays["cpu_time"][i, j] = result.get("first_run_cpu", np.nan)
        arrays["success"][i, j] = int(result["success"])
        message[i, j] = result["message"]
        linear[i, j] = result.get("linear_solver", "")
        for key in ("newton_iters", "finish_newton_iters", "steps", "jacobian_evals",
                    "effective_tolerance"):
            arrays[key][i, j] = result["stats"].get(key, np.nan)
        if result["success"]:
            positions[i, j] = np.asarray(result["positions"]) / result["length"]
    for (i, j), p in positions.items():
        if (0, j) in positions:
            arrays["error"][i, j] = float(np.max(np.linalg.norm(p - positions[0, j], axis=1)))
    fixed = base.get("maxrss", np.nan) if base.get("ok") else np.nan
    assembly = np.array([(b.get("maxrss", np.nan) - fixed) * mib if b.get("ok") else np.nan
                         for b in builds])
    unknowns = np.array([b.get("unknowns", -1) if b.get("ok") else -1 for b in builds])
    units = {"wall_time": "s", "cpu_time": "s", "maxrss": "MiB", "effective_tolerance": "1",
             "error": "1"}
    long_names = {
        "wall_time": "wall time of rodsim.solve on a built model (one run, fresh process)",
        "cpu_time": "CPU time of the same solve (the process's; on a shared machine the "
                    "wall time also counts the other processes' turns)",
        "success": "1 if the run reached equilibrium, 0 if it failed",
        "error": "largest control-point distance to static's equilibrium at the same N, / L",
        "newton_iters": "Newton iterations (static, paper; NaN for SUNDIALS' own)",
        "finish_newton_iters": "Newton iterations of the CVODE/IDA finish",
        "steps": "steps (load steps, time steps)",
        "jacobian_evals": "analytic Jacobian evaluations",
        "effective_tolerance": "residual tolerance used (raised to the round-off floor)",
        "maxrss": "peak resident set size of the run's process",
    }
    dims = ("integrator", "nodes")
    data_vars = {key: (dims, value, {"units": units.get(key, "1"), "long_name": long_names[key]})
                 for key, value in arrays.items()}
    data_vars["message"] = (dims, message.astype(str), {"long_name": "the solver's message"})
    data_vars["linear_solver"] = (dims, linear.astype(str),
                                  {"long_name": "SUNDIALS linear solver (cvode, ida)"})
    data_vars["assembly_memory"] = ("nodes", assembly, {
        "units": "MiB", "long_name": "peak RSS of importing rodsim and building the model, "
                                     "minus that of building the N = 10 model"})
    data_vars["unknowns"] = ("nodes", unknowns, {"units": "1", "long_name": "free coordinates"})
    ds = xr.Dataset(data_vars, coords={
        "integrator": ("integrator", np.array(INTEGRATORS, dtype=str)),
        "nodes": ("nodes", np.array(nodes), {"units": "1", "long_name": "control points N"})})
    ds.attrs.update({"title": "rodsim large-N benchmark", "benchmark": "large-n",
                     "size": size, "scene": SCENE, **machine_attributes()})
    return ds


def _fmt(value: float, spec: str = ".3g") -> str:
    return "–" if not np.isfinite(value) else format(value, spec)


def _markdown(ds) -> str:
    nodes = [int(n) for n in ds["nodes"].values]
    lines = [f"# Large-N benchmark ({ds.attrs['size']})", "", machine_line(ds.attrs), "",
             f"Scene `{ds.attrs['scene']}`; one solve per fresh process, one at a time.", ""]
    rows = []
    for integrator in ds["integrator"].values:
        for n in nodes:
            point = ds.sel(integrator=integrator, nodes=n)
            if not np.isfinite(float(point["success"])):
                continue
            ok = float(point["success"]) == 1
            iterations = float(point["newton_iters"])
            if not np.isfinite(iterations):
                iterations = float(point["finish_newton_iters"])
            rows.append([str(integrator), str(n), _fmt(float(point["wall_time"])),
                         _fmt(float(point["cpu_time"])),
                         "yes" if ok else "no", _fmt(float(point["error"]), ".2g"),
                         _fmt(iterations, ".0f"), _fmt(float(point["steps"]), ".0f"),
                         str(point["linear_solver"].values) or "–",
                         _fmt(float(point["maxrss"]), ".0f"),
                         "" if ok else str(point["message"].values)[:160]])
    lines += markdown_table(["integrator", "N", "time [s]", "CPU [s]", "success", "to static / L",
                             "Newton iterations", "steps", "linear solver", "peak RSS [MiB]",
                             "message"], rows)
    lines += ["", "Ratios (aims: t(100 000)/t(10 000) ≤ 12; Newton iterations at 100 000 "
              "within 2× of 4 000):", ""]
    for integrator in ("static", "cvode"):
        if 100000 in nodes and 10000 in nodes:
            ratios = [_fmt(float(t.sel(nodes=100000) / t.sel(nodes=10000))) for t in (
                ds[key].sel(integrator=integrator) for key in ("wall_time", "cpu_time"))]
            lines.append(f"- {integrator}: t(100 000)/t(10 000) = {ratios[0]} (wall), "
                         f"{ratios[1]} (CPU)")
    if 100000 in nodes:
        it = ds["newton_iters"].sel(integrator="static")
        lines.append(f"- static Newton iterations 100 000 / 4 000 = "
                     f"{_fmt(float(it.sel(nodes=100000) / it.sel(nodes=4000)))}")
    lines += ["", "Model assembly (import + build, minus the N = 10 build's process):", ""]
    memory_rows = [[str(n), str(int(u)), _fmt(float(m), ".0f"),
                    _fmt(float(m) * 2**20 / n / 1024, ".1f")]
                   for n, u, m in zip(nodes, ds["unknowns"].values,
                                      ds["assembly_memory"].values, strict=True)]
    lines += markdown_table(["N", "unknowns", "assembly [MiB]", "per node [KiB]"], memory_rows)
    return "\n".join(lines) + "\n"
