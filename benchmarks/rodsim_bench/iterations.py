"""Benchmark ``iterations``: the exact Newton-iteration and step counts of the solves whose
cost the tests bound.

A count is deterministic on one machine with one set of library releases, but it moves with
round-off: table3-catheter3's static solve took 29 Newton iterations at 27422c4 on one
machine and 30 on a fresh machine with the same releases (numpy 2.4.6, scipy 1.17.1). So the
tests bound each count with a stated margin (tests/counts.py) and this benchmark records the
exact ones, with the machine they were counted on, for a reader comparing two commits.

Each case is a shipped scene, an integrator and ``--set`` overrides; each is solved once (a
count needs no repeat) and its ``newton_iters``, ``steps``, ``finish_attempts`` and
``finish_newton_iters`` (whichever the integrator reports) are written to
``iterations-<size>.json`` and ``iterations-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import rodsim
from rodsim.solvers.base import Progress
from rodsim_bench.machine import machine, write_report

__all__ = ["run", "CASES", "COUNTERS"]

_TDCR_TENDONS = ("s1a", "s1b", "s1c", "s2a", "s2b", "s2c")
_TDCR_ONE_TENDON = [*(f"{t}.tendon_string.tension=0" for t in _TDCR_TENDONS[1:]),
                    "tip_load.force=[0, 0, 0]", "s1a.tendon_string.tension=3"]
_LARGE = ["rods.catheter.nodes=1000"]

#: label -> (scene, integrator, overrides): the solves tests/test_static_tendon.py,
#: tests/test_tendon_integrators.py, tests/test_retraction_frames.py and tests/test_robots.py
#: bound.
CASES: dict[str, tuple[str, str, list[str]]] = {
    "table3-catheter1 static": ("table3-catheter1", "static", []),
    "table3-catheter2 static": ("table3-catheter2", "static", []),
    "table3-catheter3 static": ("table3-catheter3", "static", []),
    "tendon-conserving static": ("tendon-conserving", "static", []),
    "tdcr-two-segment static": ("tdcr-two-segment", "static", []),
    "tdcr-two-segment static, one tendon": ("tdcr-two-segment", "static", _TDCR_ONE_TENDON),
    "tdcr-two-segment cvode, one tendon": ("tdcr-two-segment", "cvode", _TDCR_ONE_TENDON),
    "table3-catheter1 cvode": ("table3-catheter1", "cvode", []),
    "table3-catheter1 cvode, load ramp": ("table3-catheter1", "cvode",
                                          ["solver.cvode.load_ramp=1"]),
    "table3-catheter2 cvode": ("table3-catheter2", "cvode", []),
    "table3-catheter3 cvode": ("table3-catheter3", "cvode", []),
    "tendon-conserving cvode": ("tendon-conserving", "cvode", []),
    "table3-catheter1 ida": ("table3-catheter1", "ida", []),
    "table3-catheter2 ida": ("table3-catheter2", "ida", []),
    "table3-catheter3 ida": ("table3-catheter3", "ida", []),
    "tendon-conserving ida": ("tendon-conserving", "ida", []),
    "four-tendons ida": ("four-tendons", "ida", []),
    "table1-50g N = 1000 cvode": ("table1-50g", "cvode", _LARGE),
    "table1-50g N = 1000 ida": ("table1-50g", "ida", _LARGE),
    "table1-50g N = 1000 paper": ("table1-50g", "paper", _LARGE),
}
SIZES = {"small": 3, "full": len(CASES)}

#: The statistics recorded, where the integrator reports them.
COUNTERS = ("newton_iters", "steps", "finish_attempts", "finish_newton_iters")


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    cases = list(CASES.items())[:SIZES[size]]
    rows = []
    for k, (label, (scene, integrator, overrides)) in enumerate(cases):
        progress(k / len(cases), f"iterations: {label}")
        result = rodsim.solve(scene, integrator, overrides=overrides)
        rows.append({"case": label, "scene": scene, "integrator": integrator,
                     "overrides": overrides, "success": bool(result.success),
                     **{name: float(result.stats.get(name, np.nan)) for name in COUNTERS}})
    report = {"benchmark": "iterations", "size": size, "machine": machine(), "cases": rows}
    return write_report(report, markdown(report), output_dir / f"iterations-{size}")


def _count(value: float) -> str:
    return "–" if np.isnan(value) else f"{value:.0f}"


def markdown(report: dict) -> str:
    m = report["machine"]
    lines = [f"# Iteration and step counts ({report['size']})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, scipy {m['scipy']}, commit {m['git_commit'][:10]}, {m['date']}. "
             "Exact counts of one solve each: deterministic on one machine, they move with "
             "round-off between machines and library releases (the tests bound them with a "
             "margin, tests/counts.py).", "",
             "| case | success | Newton iterations | steps | finish attempts | finish Newton |",
             "|---|---|--:|--:|--:|--:|"]
    for row in report["cases"]:
        lines.append(f"| {row['case']} | {'yes' if row['success'] else 'no'} | "
                     + " | ".join(_count(row[name]) for name in COUNTERS) + " |")
    return "\n".join(lines) + "\n"
