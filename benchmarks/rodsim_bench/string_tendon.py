"""Benchmark ``string-tendon``: static (and CVODE) solves of ``tdcr-two-segment`` and
``catheter-helical`` — string tendons — timed, and scored against the Rucker–Webster
reference (rodsim/core/analytic/tendon_bvp.py).

For each load case (scene overrides of the shipped scene), the CPU time (process time) of
``rodsim.solve`` — model assembly included, kernels compiled and cached by a warm-up — is
the minimum over the repeats; the tip error is |tip − reference tip| / L. The reference's
own time is reported once per case. Writes ``string-tendon-<size>.json`` and
``string-tendon-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import rodsim
from rodsim.core.analytic.tendon_bvp import scene_reference
from rodsim.solvers.base import Progress
from rodsim_bench.machine import machine, write_report

__all__ = ["run"]

_OFF = [f"{t}.tendon_string.tension=0" for t in ("s1a", "s1b", "s1c", "s2a", "s2b", "s2c")]
_NO_TIP = ["tip_load.force=[0, 0, 0]"]

#: name -> (scene, overrides).
CASES = {
    "default (S-shape, pretension, tip force out of plane)": ("tdcr-two-segment", []),
    "one tendon (s1a 3 N)": ("tdcr-two-segment",
                             [*_OFF, *_NO_TIP, "s1a.tendon_string.tension=3"]),
    "two tendons of segment 1 (s1a, s1b 2 N)": (
        "tdcr-two-segment", [*_OFF, *_NO_TIP, "s1a.tendon_string.tension=2",
                             "s1b.tendon_string.tension=2"]),
    "S-shape (s1a 3 N, s2b 2 N)": ("tdcr-two-segment",
                                   [*_OFF, *_NO_TIP, "s1a.tendon_string.tension=3",
                                    "s2b.tendon_string.tension=2"]),
    "tip force in plane (s1a 2 N, -0.05 N y)": (
        "tdcr-two-segment", [*_OFF, "s1a.tendon_string.tension=2",
                             "tip_load.force=[0, -0.05, 0]"]),
    "tip force out of plane (s1a 2 N, 0.05 N z)": (
        "tdcr-two-segment", [*_OFF, "s1a.tendon_string.tension=2",
                             "tip_load.force=[0, 0, 0.05]"]),
    "helical tendon (catheter-helical)": ("catheter-helical", []),
}
SIZES = {"small": {"repeats": 1, "cases": 2, "integrators": ("static",)},
         "full": {"repeats": 5, "cases": len(CASES),
                  "integrators": ("static", "static-lengths", "cvode")}}
#: Column names that are an integrator with options: (integrator, overrides).
#: (The default retraction, "auto", is "frames" on these scenes: "static-lengths" is the one
#: it replaced, kept for comparison.)
VARIANTS = {"static-lengths": ("static", ["solver.static.retraction=lengths"])}


def _solve(scene, integrator: str, repeats: int) -> tuple[float, object]:
    if integrator in VARIANTS:
        integrator, overrides = VARIANTS[integrator]
        scene = scene.with_overrides(overrides)
    result = rodsim.solve(scene, integrator)  # warm-up (kernels compiled or loaded)
    best = np.inf
    for _ in range(repeats):
        start = time.process_time()
        result = rodsim.solve(scene, integrator)
        best = min(best, time.process_time() - start)
    return best, result


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    config = SIZES[size]
    rows = []
    cases = list(CASES.items())[:config["cases"]]
    for k, (label, (name, overrides)) in enumerate(cases):
        progress(k / len(cases), f"string-tendon: {label}")
        scene = rodsim.load_scene(name, overrides)
        rod = next(iter(scene.rods))
        length = scene.rods[rod].length
        started = time.process_time()
        reference = scene_reference(scene, load_steps=2)
        reference_s = time.process_time() - started
        row = {"case": label, "scene": name, "overrides": overrides,
               "nodes": scene.rods[rod].nodes, "reference_s": reference_s, "solves": {}}
        for integrator in config["integrators"]:
            best, result = _solve(scene, integrator, config["repeats"])
            tip = result.rods[rod].positions[-1]
            row["solves"][integrator] = {
                "cpu_s": best, "success": bool(result.success),
                "error_over_L": float(np.linalg.norm(tip - reference.tip) / length),
                "newton_iters": float(result.stats.get("newton_iters", np.nan)),
                "steps": float(result.stats.get("steps", np.nan))}
        rows.append(row)
    report = {"benchmark": "string-tendon", "size": size, "machine": machine(),
              "repeats": config["repeats"], "cases": rows}
    return write_report(report, markdown(report), output_dir / f"string-tendon-{size}")


def markdown(report: dict) -> str:
    m = report["machine"]
    integrators = list(report["cases"][0]["solves"]) if report["cases"] else []
    lines = [f"# String tendons: static solves against the Rucker–Webster reference "
             f"({report['size']})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. CPU (process) time "
             f"of rodsim.solve, model assembly included, minimum of {report['repeats']} "
             "after a warm-up.", "",
             "| case | N | " + " | ".join(f"{i} [ms] | {i} error / L" for i in integrators)
             + " | Newton (" + ", ".join(i for i in integrators if i.startswith("static"))
             + ") | reference [s] |",
             "|---|---|" + "---|---|" * len(integrators) + "---|---|"]
    for row in report["cases"]:
        cells = []
        for name in integrators:
            solve = row["solves"][name]
            status = "" if solve["success"] else " (failed)"
            cells += [f"{solve['cpu_s'] * 1e3:.1f}{status}", f"{solve['error_over_L']:.1e}"]
        lines.append(f"| {row['case']} | {row['nodes']} | " + " | ".join(cells)
                     + " | " + ", ".join(f"{row['solves'][i]['newton_iters']:.0f}"
                                         for i in integrators if i.startswith("static"))
                     + " | "
                       f"{row['reference_s']:.1f} |")
    return "\n".join(lines) + "\n"
