"""Benchmark ``cvode-scaling``: CPU per simulated period of physical time against the
number of nodes N, CVODE with its dense Jacobian against CVODE with the banded, mass-scaled
Newton matrix (GMRES preconditioned by its band LU, rodsim/solvers/physical/ode_newton.py)
and IDA (docs/dynamics.md, "CVODE").

The steel rod of tests/test_simulate.py (L 0.4 m, r 1.2 mm, E 207 GPa, ρ 8000, clamped)
released from a 0.1 N tip force, one period of its first mode, the tip at 20 output times,
each integrator at rtol = atol = 1e-5 (BDF order ≤ 2). The reference of each N is the
implicit midpoint rule at 1600 steps a period (not timed; its phase error (ωh)²/12 moves the
tip by about 1e-7 L; IDA at 1e-7 takes over 200 000 steps a period from N = 81: it resolves
the highest bending modes). CPU seconds (``time.process_time``) of
``rodsim.simulate`` with its start's static solve, once per run, after one untimed warm-up
run of each integrator; the dense CVODE is the solver rodsim used before the banded Newton
matrix and now below ``ode_newton.DENSE_LIMIT`` (each CVODE run is given its solver, whatever
the size rule says). The growth exponent is the slope of
log CPU per step against log N between successive sizes (the step count itself grows with N:
the high bending modes the release excites are resolved to the body rates' tolerance; IDA's
jump at N = 161 is a step held where BDF2 hardly damps them: docs/dynamics.md, "IDA",
"Why the steps jump at large N").

Writes ``cvode-scaling-<size>.json`` and ``cvode-scaling-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

import rodsim
import rodsim.solvers.physical.ode_newton as ode_newton
from rodsim.solvers.base import Progress
from rodsim_bench.dynamics import STEEL, steel_period, steel_scene
from rodsim_bench.machine import machine, write_report

__all__ = ["run"]

#: Per size: the rod's nodes (small: a smoke run of the same code in seconds); the largest
#: N the dense CVODE is run at (its cost is cubic).
SIZES: dict[str, dict[str, Any]] = {"small": {"nodes": (5, 9), "dense_up_to": 9},
                                    "full": {"nodes": (11, 21, 41, 81, 161), "dense_up_to": 161}}
TOLERANCE, REFERENCE_STEPS = 1e-5, 1600
SOLVERS = ("ida", "cvode-dense", "cvode-banded")


def _simulate(solver: str, scene: dict, period: float, options: dict
              ) -> rodsim.app.simulate.Simulation:
    integrator = "ida" if solver == "ida" else "cvode"
    kept = ode_newton.DENSE_LIMIT
    if solver != "ida":  # each CVODE run on its own solver, whatever the size rule says
        ode_newton.DENSE_LIMIT = 10**12 if solver == "cvode-dense" else 0
    try:
        return rodsim.simulate(scene, period, integrator=integrator, rtol=TOLERANCE,
                               atol=TOLERANCE, max_order=2, **options)
    finally:
        ode_newton.DENSE_LIMIT = kept


def _exponents(rows: list[dict], solver: str, key: str) -> list[float]:
    mine = [row for row in rows if row["solver"] == solver and row["success"]]
    return [math.log(b[key] / a[key]) / math.log(b["nodes"] / a["nodes"])
            for a, b in zip(mine, mine[1:], strict=False)]


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    config = SIZES[size]
    period = steel_period()
    options = {"output_dt": period / 20, "initial": {"tip_load.force": [0.0, -0.1, 0.0]}}
    for solver in SOLVERS:  # warm-up: SUNDIALS and the kernels loaded outside the timings
        _simulate(solver, steel_scene(5), period / 10, options)
    rows = []
    cases = [(n, s) for n in config["nodes"] for s in SOLVERS
             if s != "cvode-dense" or n <= config["dense_up_to"]]
    reference: dict[int, Any] = {}
    for k, (nodes, solver) in enumerate(cases):
        scene = steel_scene(nodes)
        if nodes not in reference:
            progress(k / len(cases), f"cvode-scaling: N = {nodes}, the reference")
            reference[nodes] = rodsim.simulate(scene, period, step=period / REFERENCE_STEPS,
                                               **options)
        progress(k / len(cases), f"cvode-scaling: N = {nodes}, {solver}")
        start = time.process_time()
        result = _simulate(solver, scene, period, options)
        cpu = time.process_time() - start
        error = float(np.max(np.abs(result.positions[:, -1]
                                    - reference[nodes].positions[:, -1])))
        rows.append({"nodes": nodes, "solver": solver, "success": result.success,
                     "steps": result.steps, "cpu_s": cpu, "cpu_per_step_s":
                     cpu / max(result.steps, 1), "tip_error_over_L": error / STEEL["length"],
                     "reference_steps": reference[nodes].steps})
    exponents = {s: {"cpu": _exponents(rows, s, "cpu_s"),
                     "cpu_per_step": _exponents(rows, s, "cpu_per_step_s")} for s in SOLVERS}
    report = {"benchmark": "cvode-scaling", "size": size, "machine": machine(),
              "period_s": period, "tolerance": TOLERANCE, "reference_steps": REFERENCE_STEPS,
              "dense_limit": ode_newton.DENSE_LIMIT, "rows": rows, "exponents": exponents}
    m = report["machine"]
    lines = [f"# Physical time: CVODE's dense and banded Newton matrix and IDA against N "
             f"({size})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. The steel rod "
             f"released from a 0.1 N tip force, one period ({period * 1e3:.2f} ms), "
             f"rtol = atol = {TOLERANCE:g}, BDF order ≤ 2; the tip's largest error at 20 "
             f"output times against the midpoint rule at {REFERENCE_STEPS} steps a period; "
             "CPU of `rodsim.simulate` (one run each). cvode-dense: the dense Jacobian "
             "(before); cvode-banded: GMRES with the "
             "band LU of the mass-scaled Newton matrix (rodsim's CVODE above "
             f"{ode_newton.DENSE_LIMIT} unknowns, 13 a free node).", "",
             "| N | solver | steps | tip error / L | CPU / period [s] | CPU / step [ms] |",
             "|--:|---|--:|--:|--:|--:|"]
    for row in rows:
        lines.append(f"| {row['nodes']} | {row['solver']} | {row['steps']} | "
                     f"{row['tip_error_over_L']:.2e} | {row['cpu_s']:.3f} | "
                     f"{1e3 * row['cpu_per_step_s']:.3f} |")
    lines += ["", "Growth exponent d log CPU / d log N between successive N (per period; "
              "per step):", ""]
    for solver in SOLVERS:
        e = exponents[solver]
        lines.append(f"- {solver}: " + ", ".join(f"{a:.2f}" for a in e["cpu"]) + "; "
                     + ", ".join(f"{a:.2f}" for a in e["cpu_per_step"]))
    lines.append("")
    return write_report(report, "\n".join(lines), output_dir / f"cvode-scaling-{size}")
