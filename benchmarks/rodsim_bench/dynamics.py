"""Benchmark ``dynamics``: CPU for equal tip accuracy in physical time, the implicit
midpoint rule against the paper's semi-implicit Euler and SUNDIALS IDA (docs/dynamics.md,
"IDA", "The paper's semi-implicit Euler").

The steel rod of tests/test_simulate.py (L 0.4 m, r 1.2 mm, E 207 GPa, ρ 8000, clamped)
released from a 0.1 N tip force, one period of its first mode, the tip at 20 output times.
The reference is IDA at rtol = atol = 1e-9 (1e-7 at the small size; not timed). Each run
is timed as a user calls it — ``rodsim.simulate`` with the start's static solve — in CPU
seconds
(``time.process_time``), once: the midpoint rule at 100 to 1600 steps a period, the
paper's Euler at 100 to 6400, the midpoint rule under error control ("midpoint-ec") at
rtol = atol = 1e-4 to 1e-7, IDA (BDF order ≤ 2) at rtol = atol = 1e-4 to 1e-7. For each
midpoint run, the cheapest IDA run at least as accurate gives the CPU ratio; for each paper
run and each midpoint-ec run, the cheapest fixed-step midpoint run at least as accurate.

Writes ``dynamics-<size>.json`` and ``dynamics-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

import rodsim
from rodsim.solvers.base import Progress
from rodsim_bench.machine import machine, write_report

__all__ = ["run"]

STEEL = {"length": 0.4, "radius": 1.2e-3, "youngs_modulus": 207e9, "density": 8000.0,
         "poisson_ratio": 0.3}
#: Euler–Bernoulli clamped–free first root β₁L.
BETA_1 = 1.87510407
#: Per size: the rod's nodes, the midpoint rule's and the paper's Euler's steps a period,
#: IDA's tolerances and the reference's (small: a smoke run of the same code in seconds).
SIZES = {"small": {"nodes": 5, "steps": (50, 100), "paper_steps": (50, 100),
                   "controlled": (1e-4, 1e-5), "tolerances": (1e-4, 1e-5), "reference": 1e-7},
         "full": {"nodes": 11, "steps": (100, 200, 400, 800, 1600),
                  "paper_steps": (100, 400, 1600, 6400),
                  "controlled": (1e-4, 1e-5, 1e-6, 1e-7),
                  "tolerances": (1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 1e-7), "reference": 1e-9}}


def steel_scene(nodes: int) -> dict:
    """The steel cantilever (STEEL) at ``nodes``, unloaded, with a tip_load term to hold a
    release force (also the CVODE scaling benchmark's rod)."""
    table = {**STEEL, "nodes": nodes, "terms": ["stretch", "bend_twist", "centerline",
                                                 "tip_load"],
             "tip_load": {"force": [0.0, 0.0, 0.0], "mass": 0.0}}
    return {"name": "steel-wire", "rods": {"wire": table}}


def steel_period() -> float:
    """The steel cantilever's first Euler–Bernoulli period [s] (β₁L = BETA_1)."""
    r = STEEL["radius"]
    omega = BETA_1**2 / STEEL["length"] ** 2 * math.sqrt(
        STEEL["youngs_modulus"] * math.pi * r**4 / 4.0 / (STEEL["density"] * math.pi * r**2))
    return 2.0 * math.pi / omega


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    config = SIZES[size]
    scene, period = steel_scene(config["nodes"]), steel_period()
    options = {"output_dt": period / 20, "initial": {"tip_load.force": [0.0, -0.1, 0.0]}}
    tight = config["reference"]
    progress(0.0, f"dynamics: the reference (IDA at {tight:g})")
    reference = rodsim.simulate(scene, period, integrator="ida", rtol=tight, atol=tight,
                                **options)
    cases = ([("midpoint", {"step": period / steps}, f"{steps} steps a period")
              for steps in config["steps"]]
             + [("paper", {"integrator": "paper", "step": period / steps},
                 f"{steps} steps a period") for steps in config["paper_steps"]]
             + [("midpoint-ec", {"rtol": tol, "atol": tol}, f"rtol = atol = {tol:g}")
                for tol in config["controlled"]]
             + [("ida", {"integrator": "ida", "rtol": tol, "atol": tol, "max_order": 2},
                 f"rtol = atol = {tol:g}") for tol in config["tolerances"]])
    rows = []
    for k, (name, settings, label) in enumerate(cases):
        progress((k + 1) / (len(cases) + 1), f"dynamics: {name}, {label}")
        start = time.process_time()
        result = rodsim.simulate(scene, period, **settings, **options)
        cpu = time.process_time() - start
        error = float(np.max(np.abs(result.positions[:, -1] - reference.positions[:, -1])))
        rows.append({"integrator": name, "setting": label, "success": result.success,
                     "steps": result.steps, "cpu_s": cpu,
                     "tip_error_over_L": error / STEEL["length"]})
    for row in rows:
        other_name = {"midpoint": "ida", "paper": "midpoint",
                      "midpoint-ec": "midpoint"}.get(row["integrator"])
        if other_name is None:
            continue
        matching = [other["cpu_s"] for other in rows if other["integrator"] == other_name
                    and other["tip_error_over_L"] <= row["tip_error_over_L"]]
        row[f"{other_name}_cpu_ratio"] = min(matching) / row["cpu_s"] if matching else None
    report = {"benchmark": "dynamics", "size": size, "machine": machine(),
              "nodes": config["nodes"], "period_s": period, "reference_steps":
              reference.steps, "rows": rows}
    m = report["machine"]
    lines = [f"# Physical time: midpoint rule, the paper's Euler and IDA at equal tip accuracy "
             f"({size})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. The steel rod "
             f"(N = {config['nodes']}) released from a 0.1 N tip force, one period "
             f"({period * 1e3:.2f} ms); the tip's largest error at 20 output times against "
             f"IDA at rtol = atol = {config['reference']:g}; CPU of `rodsim.simulate` (one run "
             "each). Ratio: the cheapest IDA run at least as accurate, over a midpoint run; "
             "the cheapest fixed-step midpoint run at least as accurate, over a paper or an "
             "error-controlled midpoint (midpoint-ec) run; midpoint-ec's steps count every "
             "midpoint step solved, the rejected ones included.", "",
             "| integrator | setting | steps | tip error / L | CPU [s] | CPU ratio |",
             "|---|---|--:|--:|--:|--:|"]
    for row in rows:
        key = {"midpoint": "ida_cpu_ratio", "paper": "midpoint_cpu_ratio",
               "midpoint-ec": "midpoint_cpu_ratio"}.get(row["integrator"])
        ratio = row.get(key) if key else None
        shown = "" if key is None else ("none as accurate" if ratio is None
                                        else f"{ratio:.2f} ({key.split('_')[0]})")
        lines.append(f"| {row['integrator']} | {row['setting']} | {row['steps']} | "
                     f"{row['tip_error_over_L']:.2e} | {row['cpu_s']:.3f} | {shown} |")
    lines.append("")
    return write_report(report, "\n".join(lines), output_dir / f"dynamics-{size}")
