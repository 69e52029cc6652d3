"""Benchmark ``real-time``: issue 33's speed aim "tdcr-two-segment, 1 s of physical time at
1e-4 L accuracy: ≤ 0.5 s CPU (twice real time)", measured in one run (docs/dynamics.md,
"What a step costs").

The scene: tdcr-two-segment as shipped (N = 61, no damping), from its equilibrium with
tendon s1a at 3 N, s1a's tension ramped 3 → 3.5 N over the first 20 ms (the ``step-cost``
benchmark's ramp) and held, outputs every 10 ms to ``T_END``. The accuracy: the tip's
largest distance over the output times from a reference run, over L = 0.4 m. The
reference is the midpoint rule at ``REFERENCE`` steps per output interval; a run at half
as many is also made, and their difference bounds the reference's own error at any order
≥ 1 (reported). The runs under test: the midpoint rule at ``MIDPOINT`` steps per output
interval (fixed steps: the step counts are exact), the midpoint rule under error control
at the tolerances of ``controlled`` (rtol = atol; its steps count every midpoint step
solved, the rejected ones included), IDA and CVODE at the tolerances of
``sundials`` (order cap 2, the default: the rod is undamped), each timed once
(``time.process_time`` around ``rodsim.simulate``) after a warm-up run that compiles the
kernels.

Writes ``real-time-<size>.json`` and ``real-time-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

__all__ = ["run", "SIZES", "scenario"]

KEY = "s1a.tendon_string.tension"
#: The rod's length L [m] (tdcr-two-segment's backbone).
LENGTH = 0.4
#: The output spacing [s] and the ramp's end [s].
OUTPUT_DT = 0.01
RAMP = 0.02
#: The aim: CPU [s] per second of physical time, and the tip's accuracy over L.
AIM_CPU = 0.5
AIM_ERROR = 1e-4
#: Per size: the time simulated [s], the reference's steps per output interval, the
#: midpoint rule's, the error-controlled midpoint rule's rtol (= atol), and IDA's and
#: CVODE's (integrator, rtol = atol).
SIZES = {
    "small": {"t_end": 0.03, "reference": 40, "midpoint": (5, 10), "controlled": (1e-5,),
              "sundials": (("ida", 1e-4), ("cvode", 1e-4))},
    "full": {"t_end": 1.0, "reference": 100, "midpoint": (10, 20, 30),
             "controlled": (1e-5, 3e-6, 1e-6),
             "sundials": (("ida", 1e-4), ("ida", 1e-5), ("ida", 3e-6), ("cvode", 1e-4))},
}


def scenario() -> dict:
    """The keyword arguments of ``rodsim.simulate`` that define the run (module
    docstring), without the integrator's."""
    return {"output_dt": OUTPUT_DT, "initial": {KEY: 3.0},
            "program": {KEY: ([0.0, RAMP], [3.0, 3.5])}}


def _timed(t_end: float, **options) -> tuple[object, float]:
    import rodsim

    start = time.process_time()
    result = rodsim.simulate("tdcr-two-segment", t_end, **scenario(), **options)
    return result, time.process_time() - start


def _tip(result) -> np.ndarray:
    return np.asarray(result.positions)[:, -1]


def _error(result, reference) -> float:
    """The tip's largest distance from the reference's over the output times both reach,
    over L."""
    tip, ref = _tip(result), _tip(reference)
    count = min(len(tip), len(ref))
    return float(np.max(np.linalg.norm(tip[:count] - ref[:count], axis=1))) / LENGTH


def _row(name: str, setting: str, result, cpu: float, span: float, reference) -> dict:
    error = _error(result, reference)
    budget = AIM_CPU * span  # the aim's CPU for ``span`` seconds simulated
    return {"integrator": name, "setting": setting, "success": bool(result.success),
            "time_s": span, "steps": int(result.steps), "iterations": int(result.iterations),
            "halvings": int(result.halvings), "tip_error_over_L": error, "cpu_s": cpu,
            "ms_per_step": 1e3 * cpu / max(1, int(result.steps)),
            "cpu_per_simulated_s": cpu / span, "aim_budget_s": budget,
            "meets_aim": bool(result.success and error <= AIM_ERROR and cpu <= budget)}


def run(size: str, output_dir: Path, progress) -> list[Path]:
    from rodsim_bench.machine import machine, write_report

    config = SIZES[size]
    t_end = float(config["t_end"])
    progress(0.0, "real-time: warm-up")
    _timed(2 * OUTPUT_DT, step=OUTPUT_DT / 2)  # compiles the kernels
    progress(0.05, "real-time: reference")
    fine = int(config["reference"])
    reference, reference_cpu = _timed(t_end, step=OUTPUT_DT / fine)
    check, _ = _timed(t_end, step=OUTPUT_DT / (fine // 2))
    reference_bound = _error(check, reference)
    rows = [_row("midpoint", f"reference, {fine} steps / {OUTPUT_DT * 1e3:g} ms", reference,
                 reference_cpu, t_end, reference)]
    todo = len(config["midpoint"]) + len(config["controlled"]) + len(config["sundials"])
    for k, per in enumerate(config["midpoint"]):
        progress(0.3 + 0.7 * k / todo, f"real-time: midpoint, {per} steps an output")
        result, cpu = _timed(t_end, step=OUTPUT_DT / per)
        rows.append(_row("midpoint", f"{per} steps / {OUTPUT_DT * 1e3:g} ms "
                         f"(h = {OUTPUT_DT / per * 1e3:.3g} ms)", result, cpu, t_end,
                         reference))
    done = len(config["midpoint"])
    for k, tolerance in enumerate(config["controlled"]):
        progress(0.3 + 0.7 * (done + k) / todo, f"real-time: midpoint, rtol {tolerance:g}")
        result, cpu = _timed(t_end, rtol=tolerance, atol=tolerance)
        rows.append(_row("midpoint", f"error control, rtol = atol = {tolerance:g} "
                         f"({result.rejected} rejected)", result, cpu, t_end, reference))
    done += len(config["controlled"])
    for k, (name, tolerance) in enumerate(config["sundials"]):
        progress(0.3 + 0.7 * (done + k) / todo,
                 f"real-time: {name} at {tolerance:g}")
        result, cpu = _timed(t_end, integrator=name, rtol=tolerance, atol=tolerance,
                             max_order=2)
        rows.append(_row(name, f"rtol = atol = {tolerance:g}, max_order 2", result, cpu,
                         t_end, reference))
    report = {"benchmark": "real-time", "size": size, "machine": machine(), "t_end": t_end,
              "output_dt": OUTPUT_DT, "ramp": RAMP, "aim_cpu_per_s": AIM_CPU,
              "aim_error_over_L": AIM_ERROR, "reference_bound_over_L": reference_bound,
              "rows": rows}
    return write_report(report, _markdown(report), output_dir / f"real-time-{size}")


def _markdown(report: dict) -> str:
    m = report["machine"]
    lines = [f"# Physical time: tdcr-two-segment against the real-time aim ({report['size']})",
             "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. tdcr-two-segment "
             f"(N = 61, undamped) from its equilibrium at s1a = 3 N, s1a ramped to 3.5 N over "
             f"{report['ramp'] * 1e3:g} ms, {report['t_end']:g} s simulated, outputs every "
             f"{report['output_dt'] * 1e3:g} ms; the tip's largest error over L against the "
             f"midpoint rule's reference (its own error below "
             f"{report['reference_bound_over_L']:.1e} L: the difference from half its "
             f"steps). CPU of `rodsim.simulate` (`time.process_time`, one run each after a "
             f"warm-up). The aim: ≤ {report['aim_cpu_per_s']:g} s CPU per simulated second "
             f"at ≤ {report['aim_error_over_L']:g} L.", "",
             "| integrator | setting | simulated [s] | steps | Newton its / residuals | "
             "tip error / L | CPU [s] | ms/step | CPU per simulated s | meets aim |",
             "|---|---|--:|--:|--:|--:|--:|--:|--:|---|"]
    for r in report["rows"]:
        lines.append(f"| {r['integrator']} | {r['setting']} | {r['time_s']:g} | "
                     f"{r['steps']} | {r['iterations']} | {r['tip_error_over_L']:.2e} | "
                     f"{r['cpu_s']:.2f} | {r['ms_per_step']:.2f} | "
                     f"{r['cpu_per_simulated_s']:.1f} | "
                     f"{'yes' if r['meets_aim'] else 'no'}"
                     f"{'' if r['success'] else ' (failed)'} |")
    lines.append("")
    return "\n".join(lines)
