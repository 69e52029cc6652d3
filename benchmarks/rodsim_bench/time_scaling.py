"""Benchmark ``time-scaling``: issue 33's aim "cost linear in simulated time", measured in
one run (docs/dynamics.md, "What a step costs").

The scene and its program are the ``real-time`` benchmark's (tdcr-two-segment as shipped,
N = 61, undamped, from its equilibrium at s1a = 3 N, s1a ramped 3 → 3.5 N over 20 ms and
held, outputs every 10 ms). Each integrator of ``INTEGRATORS`` simulates it to each end time
of the size's ``t_end`` (one run each, ``time.process_time`` around ``rodsim.simulate``,
after a warm-up run that compiles the kernels). Each run's CPU includes the start's static
solve, the same for every end time: its share is the intercept of CPU against time.

What is reported per integrator: CPU, steps and CPU per simulated second at each end time,
and the growth exponent d log CPU / d log t_end between successive end times (1 for a cost
proportional to the time simulated; below 1 while the fixed start's share is large).

Writes ``time-scaling-<size>.json`` and ``time-scaling-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from rodsim_bench.real_time import scenario

__all__ = ["run", "SIZES", "INTEGRATORS"]

#: (label, keyword arguments of ``rodsim.simulate``): the midpoint rule at fixed 0.5 ms steps
#: and under error control, IDA and CVODE (BDF order ≤ 2: the rod is undamped).
INTEGRATORS: tuple[tuple[str, dict], ...] = (
    ("midpoint, h = 0.5 ms", {"step": 5e-4}),
    ("midpoint, rtol = atol = 1e-5", {"rtol": 1e-5, "atol": 1e-5}),
    ("ida, rtol = atol = 1e-4", {"integrator": "ida", "rtol": 1e-4, "atol": 1e-4,
                                 "max_order": 2}),
    ("cvode, rtol = atol = 1e-4", {"integrator": "cvode", "rtol": 1e-4, "atol": 1e-4,
                                   "max_order": 2}),
)
#: Per size: the end times [s] (small: a smoke run of the same code in seconds).
SIZES: dict[str, tuple[float, ...]] = {"small": (0.01, 0.02),
                                       "full": (0.125, 0.25, 0.5, 1.0)}


def _timed(t_end: float, options: dict) -> tuple[object, float]:
    import rodsim

    start = time.process_time()
    result = rodsim.simulate("tdcr-two-segment", t_end, **scenario(), **options)
    return result, time.process_time() - start


def run(size: str, output_dir: Path, progress) -> list[Path]:
    from rodsim_bench.machine import machine, write_report

    ends = SIZES[size]
    progress(0.0, "time-scaling: warm-up")
    for _, options in INTEGRATORS:  # compiles the kernels, loads SUNDIALS
        _timed(0.002, options)
    rows: list[dict] = []
    cases = [(label, options, t_end) for label, options in INTEGRATORS for t_end in ends]
    for k, (label, options, t_end) in enumerate(cases):
        progress(k / len(cases), f"time-scaling: {label}, {t_end:g} s")
        result, cpu = _timed(t_end, options)
        rows.append({"integrator": label, "t_end_s": t_end,
                     "success": bool(result.success), "steps": int(result.steps),
                     "cpu_s": cpu, "cpu_per_simulated_s": cpu / t_end,
                     "steps_per_simulated_s": int(result.steps) / t_end})
    exponents = {label: _exponents([r for r in rows if r["integrator"] == label])
                 for label, _ in INTEGRATORS}
    report = {"benchmark": "time-scaling", "size": size, "machine": machine(),
              "t_ends_s": list(ends), "rows": rows, "exponents": exponents}
    return write_report(report, _markdown(report), output_dir / f"time-scaling-{size}")


def _exponents(rows: list[dict]) -> list[float]:
    """d log CPU / d log t_end between successive end times of one integrator's runs."""
    done = [r for r in rows if r["success"]]
    return [math.log(b["cpu_s"] / a["cpu_s"]) / math.log(b["t_end_s"] / a["t_end_s"])
            for a, b in zip(done, done[1:], strict=False)]


def _markdown(report: dict) -> str:
    m = report["machine"]
    lines = [f"# Physical time: CPU against the time simulated ({report['size']})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. tdcr-two-segment "
             "(N = 61, undamped) from its equilibrium at s1a = 3 N, s1a ramped to 3.5 N over "
             "20 ms and held, outputs every 10 ms; CPU of `rodsim.simulate` "
             "(`time.process_time`, one run each after a warm-up), its start's static solve "
             "included.", "",
             "| integrator | simulated [s] | steps | CPU [s] | CPU per simulated s | "
             "steps per simulated s |", "|---|--:|--:|--:|--:|--:|"]
    for r in report["rows"]:
        lines.append(f"| {r['integrator']} | {r['t_end_s']:g} | {r['steps']} | "
                     f"{r['cpu_s']:.2f} | {r['cpu_per_simulated_s']:.2f} | "
                     f"{r['steps_per_simulated_s']:.0f}"
                     f"{'' if r['success'] else ' (failed)'} |")
    lines += ["", "Growth exponent d log CPU / d log t_end between successive end times "
              "(1: proportional):", ""]
    for label, values in report["exponents"].items():
        lines.append(f"- {label}: " + ", ".join(f"{v:.2f}" for v in values))
    lines.append("")
    return "\n".join(lines)
