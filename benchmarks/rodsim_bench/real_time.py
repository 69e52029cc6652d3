"""Benchmark ``real-time``: issue 33's speed aim "tdcr-two-segment, 1 s of physical time at
1e-4 L accuracy: ≤ 0.5 s CPU (twice real time)", measured in one run (docs/dynamics.md,
"What a step costs").

The scene: tdcr-two-segment as shipped (N = 61, no damping), from its equilibrium with
tendon s1a at 3 N, s1a's tension ramped 3 → 3.5 N over the first 20 ms (the ``step-cost``
benchmark's ramp) and held, outputs every 10 ms to ``T_END``. The accuracy: the tip's
largest distance over the output times from a reference run, over L = 0.4 m. The
reference is the fourth-order composition of midpoint steps (integrator ``midpoint4``,
rodsim/solvers/physical/composition.py) at ``reference`` steps per output interval (five
midpoint solves each); a run at half as many is also made, and their difference bounds
the reference's own error at any order ≥ 1 (reported). The runs under test: the midpoint
rule at ``midpoint`` steps per output interval and its composition at ``composed`` (fixed
steps: the step counts are exact; "solves" counts midpoint steps), the midpoint rule under
error control
at the tolerances of ``controlled`` (rtol = atol; its steps count every midpoint step
solved, the rejected ones included), IDA and CVODE at the tolerances of
``sundials`` (order cap 2, the default: the rod is undamped), each timed once
(``time.process_time`` around ``rodsim.simulate``) after a warm-up run that compiles the
kernels.

The floor: what one midpoint step at h = 1/3 ms costs at least, one residual with its
Newton matrix (the model's force and Jacobian at both Gauss points, mapped to the step's
unknowns) and one band factorisation, and what an iteration with a kept matrix costs (a
residual and a solve), each the minimum of ``FLOOR_REPEATS`` timings after the run's first
step; and for each fixed-step scheme the midpoint solves that 1e-4 L needs, from its row
nearest the aim (the error scaled as h² for the midpoint rule, h⁴ for its composition).
Their product is the CPU a simulated second of that scheme costs with one fresh Newton
matrix a solve; with a matrix kept across solves, a solve still takes at least two
iterations (a change, and the one that shows it converged), also reported.

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
#: Midpoint steps in a step of ``midpoint4`` (Suzuki's composition), and the timings of
#: each part of the floor (module docstring).
COMPOSED_PARTS = 5
FLOOR_REPEATS = 30
#: Per size: the time simulated [s], the reference's steps per output interval, the
#: midpoint rule's, the error-controlled midpoint rule's rtol (= atol), and IDA's and
#: CVODE's (integrator, rtol = atol).
SIZES = {
    "small": {"t_end": 0.03, "reference": 8, "midpoint": (5, 10), "composed": (2,),
              "controlled": (1e-5,), "sundials": (("ida", 1e-4), ("cvode", 1e-4))},
    "full": {"t_end": 1.0, "reference": 20, "midpoint": (10, 20, 30), "composed": (3, 4, 5),
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
    parts = COMPOSED_PARTS if name == "midpoint4" else 1
    return {"integrator": name, "setting": setting, "success": bool(result.success),
            "time_s": span, "steps": int(result.steps), "solves": parts * int(result.steps),
            "iterations": int(result.iterations),
            "halvings": int(result.halvings), "tip_error_over_L": error, "cpu_s": cpu,
            "ms_per_step": 1e3 * cpu / max(1, int(result.steps)),
            "cpu_per_simulated_s": cpu / span, "aim_budget_s": budget,
            "meets_aim": bool(result.success and error <= AIM_ERROR and cpu <= budget)}


def step_floor(h: float = OUTPUT_DT / 30) -> dict:
    """The parts of one midpoint step on the scene (module docstring, "The floor") [ms]:
    ``fresh`` a residual with its Newton matrix, ``factor`` its band factorisation,
    ``residual`` a residual alone, ``solve`` a solve with the factors; the minimum of
    ``FLOOR_REPEATS`` timings each, at the first Newton iterate of the run's first step."""
    import rodsim
    from rodsim.solvers.physical import fixed_step

    caught: dict = {}
    newton, factor = fixed_step._newton, fixed_step.factor_matrix

    def spy_newton(evaluate, r1, w, h, *args, **kwargs):
        caught.setdefault("evaluate", (evaluate, r1.copy(), w.copy()))
        return newton(evaluate, r1, w, h, *args, **kwargs)

    def spy_factor(matrix, order):
        caught.setdefault("matrix", (matrix, order))
        return factor(matrix, order)

    fixed_step._newton, fixed_step.factor_matrix = spy_newton, spy_factor
    try:
        rodsim.simulate("tdcr-two-segment", h, **scenario(), step=h)
    finally:
        fixed_step._newton, fixed_step.factor_matrix = newton, factor
    evaluate, r1, w = caught["evaluate"]
    matrix, order = caught["matrix"]
    solve = factor(matrix, order)
    rhs = np.ones(matrix.shape[0])

    def best(work) -> float:
        least = np.inf
        for _ in range(FLOOR_REPEATS):
            start = time.process_time()
            work()
            least = min(least, time.process_time() - start)
        return 1e3 * least

    return {"unknowns": int(matrix.shape[0]), "fresh_ms": best(lambda: evaluate(r1, w, True)),
            "factor_ms": best(lambda: factor(matrix, order)),
            "residual_ms": best(lambda: evaluate(r1, w, False)),
            "solve_ms": best(lambda: solve(rhs))}


def solves_needed(rows: list[dict]) -> dict[str, dict]:
    """Per fixed-step scheme, the midpoint solves for 1e-4 L (module docstring): from its
    row nearest the aim, its solves × (error / aim)^(1/order)."""
    out = {}
    for name, order in (("midpoint", 2), ("midpoint4", 4)):
        fixed = [r for r in rows if r["integrator"] == name and "steps /" in r["setting"]
                 and r["success"] and r["tip_error_over_L"] > 0.0]
        if not fixed:
            continue
        near = min(fixed, key=lambda r: abs(np.log(r["tip_error_over_L"] / AIM_ERROR)))
        needed = near["solves"] * (near["tip_error_over_L"] / AIM_ERROR) ** (1.0 / order)
        out[name] = {"from": near["setting"], "order": order,
                     "solves_per_s": needed / near["time_s"]}
    return out


def run(size: str, output_dir: Path, progress) -> list[Path]:
    from rodsim_bench.machine import machine, write_report

    config = SIZES[size]
    t_end = float(config["t_end"])
    progress(0.0, "real-time: warm-up")
    _timed(2 * OUTPUT_DT, step=OUTPUT_DT / 2)  # compiles the kernels
    floor = step_floor()
    progress(0.05, "real-time: reference")
    fine = int(config["reference"])
    reference, reference_cpu = _timed(t_end, step=OUTPUT_DT / fine, integrator="midpoint4")
    check, _ = _timed(t_end, step=OUTPUT_DT / (fine // 2), integrator="midpoint4")
    reference_bound = _error(check, reference)
    rows = [_row("midpoint4", f"reference, {fine} steps / {OUTPUT_DT * 1e3:g} ms", reference,
                 reference_cpu, t_end, reference)]
    fixed = [("midpoint", per) for per in config["midpoint"]]
    fixed += [("midpoint4", per) for per in config["composed"]]
    todo = len(fixed) + len(config["controlled"]) + len(config["sundials"])
    for k, (name, per) in enumerate(fixed):
        progress(0.3 + 0.7 * k / todo, f"real-time: {name}, {per} steps an output")
        result, cpu = _timed(t_end, step=OUTPUT_DT / per, integrator=name)
        rows.append(_row(name, f"{per} steps / {OUTPUT_DT * 1e3:g} ms "
                         f"(h = {OUTPUT_DT / per * 1e3:.3g} ms)", result, cpu, t_end,
                         reference))
    done = len(fixed)
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
    needed = solves_needed(rows)
    per_solve = floor["fresh_ms"] + floor["factor_ms"]
    for entry in needed.values():
        entry["floor_cpu_per_s"] = 1e-3 * per_solve * entry["solves_per_s"]
    report = {"benchmark": "real-time", "size": size, "machine": machine(), "t_end": t_end,
              "output_dt": OUTPUT_DT, "ramp": RAMP, "aim_cpu_per_s": AIM_CPU,
              "aim_error_over_L": AIM_ERROR, "reference_bound_over_L": reference_bound,
              "floor": floor, "needed": needed, "rows": rows}
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
             f"fourth-order composition's reference (its own error below "
             f"{report['reference_bound_over_L']:.1e} L: the difference from half its "
             f"steps). CPU of `rodsim.simulate` (`time.process_time`, one run each after a "
             f"warm-up). The aim: ≤ {report['aim_cpu_per_s']:g} s CPU per simulated second "
             f"at ≤ {report['aim_error_over_L']:g} L. midpoint4: Suzuki's composition, five "
             f"midpoint steps a step (solves).", "",
             "| integrator | setting | simulated [s] | steps | solves | Newton its / "
             "residuals | tip error / L | CPU [s] | ms/solve | CPU per simulated s | "
             "meets aim |",
             "|---|---|--:|--:|--:|--:|--:|--:|--:|--:|---|"]
    for r in report["rows"]:
        solves = r.get("solves", r["steps"])
        lines.append(f"| {r['integrator']} | {r['setting']} | {r['time_s']:g} | "
                     f"{r['steps']} | {solves} | {r['iterations']} | "
                     f"{r['tip_error_over_L']:.2e} | {r['cpu_s']:.2f} | "
                     f"{1e3 * r['cpu_s'] / max(1, solves):.2f} | "
                     f"{r['cpu_per_simulated_s']:.1f} | "
                     f"{'yes' if r['meets_aim'] else 'no'}"
                     f"{'' if r['success'] else ' (failed)'} |")
    floor = report.get("floor")
    if floor:
        per_solve = floor["fresh_ms"] + floor["factor_ms"]
        lines += ["", f"The floor ({floor['unknowns']} unknowns, h = 1/3 ms, min of "
                  f"{FLOOR_REPEATS}): a residual with its Newton matrix "
                  f"{floor['fresh_ms']:.3f} ms, its band factorisation "
                  f"{floor['factor_ms']:.3f} ms (together {per_solve:.3f} ms); a residual "
                  f"alone {floor['residual_ms']:.3f} ms, a solve {floor['solve_ms']:.4f} ms. "
                  f"The aim's {report['aim_cpu_per_s']:g} s a simulated second buys "
                  f"{1e3 * report['aim_cpu_per_s'] / per_solve:.0f} such solves.", "",
                  "| scheme | from the row | order | midpoint solves a second at 1e-4 L | "
                  "floor: CPU per simulated s | two kept-matrix iterations a solve |",
                  "|---|---|--:|--:|--:|--:|"]
        kept = 2e-3 * (floor["residual_ms"] + floor["solve_ms"])
        for name, entry in report["needed"].items():
            lines.append(f"| {name} | {entry['from']} | {entry['order']} | "
                         f"{entry['solves_per_s']:.0f} | {entry['floor_cpu_per_s']:.2f} | "
                         f"{kept * entry['solves_per_s']:.2f} |")
    lines.append("")
    return "\n".join(lines)
