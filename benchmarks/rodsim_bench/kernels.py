"""Benchmark ``kernels``: the fast core, measured as ratios in one run.

For each scene (``table1-50g`` at N = 40, ``table3-catheter1``; ``small``: table1-50g only)
and each evaluation path (``solver.kernels`` = ``numpy``, the reference, and ``compiled``):

- the cost of one evaluation of F and of F with ∂F/∂x (best of several batches);
- every integrator to equilibrium: the model is built once per path, then each
  configuration is solved R times round-robin (so a burst of load hits all alike) and the
  minimum is kept; error = largest node distance to ``static`` (compiled) / L;
- at N = 4000 (full size), the evaluation costs only;
- the first-compile and cache-load times of the kernels (two fresh processes sharing an
  empty numba cache folder);
- a profile (cProfile, top functions by own time) of the default CVODE run;
- the ratio to the previous single-rod results file (``single_rod.json``, solve-only times
  of the same scene before the fast core) when it is in the output folder;
- tracking (rodsim/app/inverse/track.py, static): a ramp of the tip load (table1-50g) or the
  tendon force (table3-catheter1) in equal steps; per step of the best of the repeats, the
  warm step's wall time and Newton iterations against a cold static solve of the same
  equilibrium (model assembly included in both), and the tracking rate.

Writes ``kernels-<size>.json`` and ``kernels-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import cProfile
import io
import json
import os
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import rodsim
from rodsim.core.model import EVALUATION_PATHS, Model
from rodsim.solvers.base import Progress
from rodsim_bench.machine import machine, write_report

INTEGRATORS = ("static", "paper", "cvode", "ida")
SIZES = {"small": {"scenes": ("table1-50g",), "repeats": 2, "calls": 50, "large": False,
                   "track_steps": 21},
         "full": {"scenes": ("table1-50g", "table3-catheter1"), "repeats": 7, "calls": 400,
                  "large": True, "track_steps": 201}}
#: The ramp each scene is tracked along: (key, start, stop).
TRACKS = {"table1-50g": ("rods.catheter.tip_load.mass", 0.0, 0.1),
          "table3-catheter1": ("tendons.tendon.tendon_actuation.force", 0.0, 4.0)}
LARGE_NODES = 4000

_COMPILE_SCRIPT = """
import time
t0 = time.perf_counter()
import rodsim
from rodsim.core.model import Model
model = Model(rodsim.load_scene("table1-50g"), "compiled")  # evaluates J at rest
model.evaluate(model.x0)
print(time.perf_counter() - t0)
"""


def evaluation_cost(model: Model, calls: int) -> dict[str, float]:
    """Seconds per call of F and of (F, ∂F/∂x), best of 5 batches, at a perturbed state."""
    x = model.x0 + 1e-4 * model.length_scale * np.random.default_rng(0).standard_normal(model.n)
    model.evaluate(x)
    out = {}
    for label, jacobian in (("force", False), ("force_and_jacobian", True)):
        best = np.inf
        for _ in range(5):
            start = time.perf_counter()
            for _ in range(calls):
                model.evaluate(x, jacobian=jacobian)
            best = min(best, (time.perf_counter() - start) / calls)
        out[label] = best
    return out


def compile_times() -> dict[str, float]:
    """Seconds from start-up to the first evaluation (import, assembly, compile or cache
    load) of the single-rod kernels, in two fresh processes sharing an empty cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        times = []
        for _ in range(2):
            done = subprocess.run([sys.executable, "-c", _COMPILE_SCRIPT], env=env,
                                  capture_output=True, text=True, check=True, timeout=600)
            times.append(float(done.stdout.strip().splitlines()[-1]))
    return {"first_compile_s": times[0], "cache_load_s": times[1]}


def solve_times(scene_name: str, repeats: int, progress: Progress) -> list[dict]:
    scene = rodsim.load_scene(scene_name)
    models = {kernels: Model(scene, kernels) for kernels in EVALUATION_PATHS}
    runs = {(k, name): [] for k in EVALUATION_PATHS for name in INTEGRATORS}
    results = {}
    for repeat in range(repeats + 1):  # the first round warms up (and compiles)
        for (kernels, name), times in runs.items():
            progress((repeat + 1) / (repeats + 1), f"kernels: {scene_name} {name} {kernels}")
            start = time.perf_counter()
            result = rodsim.solve(scene, name, model=models[kernels])
            elapsed = time.perf_counter() - start
            if repeat:
                times.append(elapsed)
            results[kernels, name] = result
    reference = results["compiled", "static"]
    length = max(r["length"] for r in scene.data["rods"].values())
    rows = []
    for (kernels, name), times in runs.items():
        result = results[kernels, name]
        error = max(float(np.max(np.linalg.norm(a.positions - b.positions, axis=1)))
                    for a, b in zip(result.rods.values(), reference.rods.values(),
                                    strict=True)) / length
        rows.append({"scene": scene_name, "integrator": name, "kernels": kernels,
                     "success": result.success, "message": result.message,
                     "best_s": min(times), "all_s": times, "error_over_L": error,
                     "stats": {k: float(v) for k, v in result.stats.items()}})
    return rows


def cvode_profile(scene_name: str) -> list[dict]:
    """Top functions by own time of the default CVODE run (compiled kernels)."""
    scene = rodsim.load_scene(scene_name)
    model = Model(scene, "compiled")
    rodsim.solve(scene, "cvode", model=model)
    profiler = cProfile.Profile()
    profiler.enable()
    for _ in range(5):
        rodsim.solve(scene, "cvode", model=model)
    profiler.disable()
    stats = pstats.Stats(profiler, stream=io.StringIO())
    total = stats.total_tt
    rows = []
    for (file, line, function), (_, calls, own, cumulative, _) in sorted(
            stats.stats.items(), key=lambda item: -item[1][2])[:15]:
        rows.append({"function": f"{Path(file).name}:{line}({function})", "calls": calls / 5,
                     "own_share": own / total, "cumulative_share": cumulative / total})
    return rows


def previous_single_rod(output_dir: Path) -> dict[str, float]:
    """Solve-only seconds per integrator from the previous single-rod results file."""
    path = output_dir / "single_rod.json"
    if not path.exists():
        return {}
    data = json.loads(path.read_text())
    wanted = {"static": "static", "paper (analytic Jacobian)": "paper",
              "cvode overdamped band": "cvode", "ida overdamped band": "ida"}
    return {wanted[r["label"]]: r["solve_only_s"] for r in data["results"]
            if r["label"] in wanted} | {"commit": data["machine"].get("git_commit", "?")}


def tracking_costs(scene_name: str, steps: int, repeats: int, progress: Progress) -> dict:
    """Best-of-``repeats`` tracking run along TRACKS[scene_name] in ``steps`` steps, and cold
    static solves of the last three steps' scenes (from rest, model assembly included)."""
    key, start, stop = TRACKS[scene_name]
    scene = rodsim.load_scene(scene_name)
    values = np.linspace(start, stop, steps)
    rodsim.track(scene, {key: values[:3]}, estimates=False)  # warm-up (kernels loaded)
    best = None
    for repeat in range(repeats):
        progress((repeat + 1) / repeats, f"kernels: tracking {scene_name}")
        started = time.perf_counter()
        path = rodsim.track(scene, {key: values}, estimates=False)
        total = time.perf_counter() - started
        if best is None or total < best[0]:
            best = total, path
    total, path = best
    cold_times, cold_iterations = [], []
    for value in values[-3:]:
        times = []
        for _ in range(repeats):
            started = time.perf_counter()
            result = rodsim.solve(scene.with_values({key: float(value)}), "static")
            times.append(time.perf_counter() - started)
        cold_times.append(min(times))
        cold_iterations.append(result.stats["newton_iters"])
    warm = np.asarray(path.times[1:])
    return {"scene": scene_name, "key": key, "start": start, "stop": stop, "steps": steps,
            "success": path.success, "total_s": total, "first_step_s": path.times[0],
            "warm_step_mean_s": float(warm.mean()), "warm_step_max_s": float(warm.max()),
            "warm_iterations_mean": float(np.mean(path.iterations[1:])),
            "halvings": float(np.sum(path.halvings)),
            "steps_per_s": float((steps - 1) / warm.sum()),
            "cold_solve_s": float(np.mean(cold_times)),
            "cold_newton_iterations": float(np.mean(cold_iterations))}


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    config = SIZES[size]
    report: dict = {"benchmark": "kernels", "size": size, "machine": machine(),
                    "repeats": config["repeats"]}
    progress(None, "kernels: first compile and cache load")
    report["compile"] = compile_times()
    costs = []
    scenes = [(name, []) for name in config["scenes"]]
    if config["large"]:
        scenes.append(("table1-50g", [f"nodes={LARGE_NODES}"]))
    for name, overrides in scenes:
        scene = rodsim.load_scene(name, overrides)
        for kernels in EVALUATION_PATHS:
            model = Model(scene, kernels)
            costs.append({"scene": name, "overrides": overrides, "n": model.n,
                          "kernels": kernels, **evaluation_cost(model, config["calls"])})
    report["evaluation_cost"] = costs
    report["solves"] = [row for name in config["scenes"]
                        for row in solve_times(name, config["repeats"], progress)]
    report["previous"] = previous_single_rod(output_dir)
    report["cvode_profile"] = cvode_profile("table1-50g")
    report["tracking"] = [tracking_costs(name, config["track_steps"], config["repeats"],
                                         progress) for name in config["scenes"]]
    return write_report(report, markdown(report), output_dir / f"kernels-{size}")


def markdown(report: dict) -> str:
    m = report["machine"]
    lines = [f"# Fast core: numpy reference against compiled kernels ({report['size']})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. Ratios within one "
             "run.", "",
             f"Start-up to the first compiled evaluation of table1-50g (import, assembly and "
             f"the kernels): {report['compile']['first_compile_s']:.2f} s with an empty "
             f"numba cache (compiling), {report['compile']['cache_load_s']:.2f} s in a second "
             "process (loading them from the disk cache).", "",
             "## One evaluation", "",
             "| scene | n | F numpy [µs] | F compiled [µs] | ratio | F+J numpy [µs] | "
             "F+J compiled [µs] | ratio |", "|---|---|---|---|---|---|---|---|"]
    costs = report["evaluation_cost"]
    for numpy_row, compiled_row in zip(
            [c for c in costs if c["kernels"] == "numpy"],
            [c for c in costs if c["kernels"] == "compiled"], strict=True):
        label = numpy_row["scene"] + (" " + " ".join(numpy_row["overrides"])
                                      if numpy_row["overrides"] else "")
        f0, f1 = numpy_row["force"], compiled_row["force"]
        j0, j1 = numpy_row["force_and_jacobian"], compiled_row["force_and_jacobian"]
        lines.append(f"| {label} | {numpy_row['n']} | {f0 * 1e6:.1f} | {f1 * 1e6:.1f} | "
                     f"{f0 / f1:.1f}× | {j0 * 1e6:.1f} | {j1 * 1e6:.1f} | {j0 / j1:.1f}× |")
    lines += ["", "## Solves to equilibrium (best of the repeats; model built once)", "",
              "| scene | integrator | numpy [ms] | compiled [ms] | numpy / compiled | "
              "compiled / static | steps | F | J | Newton | finish Newton | error / L |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    solves = {(r["scene"], r["integrator"], r["kernels"]): r for r in report["solves"]}
    for scene in dict.fromkeys(r["scene"] for r in report["solves"]):
        static = solves[scene, "static", "compiled"]["best_s"]
        for name in INTEGRATORS:
            a, b = solves[scene, name, "numpy"], solves[scene, name, "compiled"]
            s = b["stats"]
            status = "" if b["success"] else " (failed)"
            lines.append(
                f"| {scene} | {name}{status} | {a['best_s'] * 1e3:.1f} | "
                f"{b['best_s'] * 1e3:.1f} | {a['best_s'] / b['best_s']:.1f}× | "
                f"{b['best_s'] / static:.2f} | {s['steps']:.0f} | {s['force_evals']:.0f} | "
                f"{s['jacobian_evals']:.0f} | {s['newton_iters']:.0f} | "
                f"{s.get('finish_newton_iters', float('nan')):.0f} | {b['error_over_L']:.1e} |")
    previous = report["previous"]
    if previous:
        lines += ["", f"## Against the previous results file (single_rod.json, commit "
                  f"{previous['commit'][:10]}; table1-50g, N = 40)", "",
                  "| integrator | previous [ms] | compiled now [ms] | speed-up |",
                  "|---|---|---|---|"]
        for name in INTEGRATORS:
            if name in previous and ("table1-50g", name, "compiled") in solves:
                now = solves["table1-50g", name, "compiled"]["best_s"]
                lines.append(f"| {name} | {previous[name] * 1e3:.1f} | {now * 1e3:.1f} | "
                             f"{previous[name] / now:.1f}× |")
    lines += ["", "## Where the default CVODE run spends its time (table1-50g, compiled)", "",
              "| function | calls per run | own time | with callees |", "|---|---|---|---|"]
    for row in report["cvode_profile"]:
        lines.append(f"| `{row['function']}` | {row['calls']:.0f} | {row['own_share']:.1%} | "
                     f"{row['cumulative_share']:.1%} |")
    lines += ["", "## Tracking (static, warm-started steps; best of the repeats)", "",
              "| scene | ramp | steps | warm step [ms] | Newton / step | cold solve [ms] | "
              "cold Newton | warm / cold | steps/s |", "|---|---|---|---|---|---|---|---|---|"]
    for row in report["tracking"]:
        status = "" if row["success"] else " (failed)"
        lines.append(
            f"| {row['scene']}{status} | {row['key']} {row['start']:g} → {row['stop']:g} | "
            f"{row['steps']} | {row['warm_step_mean_s'] * 1e3:.2f} | "
            f"{row['warm_iterations_mean']:.2f} | {row['cold_solve_s'] * 1e3:.1f} | "
            f"{row['cold_newton_iterations']:.0f} | "
            f"{row['warm_step_mean_s'] / row['cold_solve_s']:.3f} | {row['steps_per_s']:.0f} |")
    return "\n".join(lines) + "\n"
