"""Where a warm static solve's own work goes (issue 35 item 4: "a tdcr-two-segment static
solve within 1.3× its floor"; the floor is its evaluations and linear solves at their raw
costs, benchmarks/tendon_kernel.py).

In this process, with the model built once: the solver's functions wrapped, each wrapper
timing its call (``time.perf_counter``) less the wrapped calls inside it (exclusive time),
the cost of a wrapper itself measured on a function that does nothing and half of it
subtracted per call; the rows of the fastest of ``--solves`` solves (the one least
disturbed by the machine). The primitives of the floor (``Model._evaluate``: the kernels,
``LinearSolver.solve``) come first; every other row is the solve's own work, or the part
of the floor's raw costs that ``Model.evaluate``'s memory adds. Wall time of one process:
on a loaded machine the rows are noisy, each at least the work it measures.

Writes ``static-own-work.json`` and ``static-own-work.md`` into ``--output-dir`` (default
``runs/bench``). Nothing is asserted.

    python benchmarks/static_own_work.py --scene tdcr-two-segment --solves 300
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: (module or class path, attribute, label) of each wrapped function, in the solve's order.
WRAPPED = (
    ("rodsim.core.model:Model", "_evaluate", "floor: Model._evaluate (the kernels)"),
    ("rodsim.solvers.linear:LinearSolver", "solve", "floor: LinearSolver.solve"),
    ("rodsim.core.model:Model", "evaluate", "Model.evaluate (its memory, around _evaluate)"),
    ("rodsim.app.api", "load_scene", "api.load_scene (the solver options checked)"),
    ("rodsim.app.api", "solve", "api.solve"),
    ("rodsim.solvers.static:Static", "for_scene", "Integrator.for_scene (options)"),
    ("rodsim.solvers.run_state:RunState", "new", "RunState.new"),
    ("rodsim.solvers.base:Integrator", "init", "Integrator.init"),
    ("rodsim.solvers.base:Integrator", "run", "Integrator.run"),
    ("rodsim.solvers.base:Integrator", "settle", "Integrator.settle"),
    ("rodsim.solvers.base:Integrator", "ended", "Integrator.ended"),
    ("rodsim.solvers.static:Static", "advance", "Static.advance"),
    ("rodsim.solvers.static", "rest_imbalance", "rest_imbalance"),
    ("rodsim.solvers.static", "secant_predicted", "secant_predicted"),
    ("rodsim.solvers.static", "penalty_scales", "penalty_scales"),
    ("rodsim.solvers.static:Static", "_load_continuation", "Static._load_continuation"),
    ("rodsim.solvers.static", "load_continuation", "load_continuation"),
    ("rodsim.solvers.static:Static", "_newton", "Static._newton"),
    ("rodsim.solvers.base:Integrator", "newton_equilibrium", "newton_equilibrium"),
    ("rodsim.solvers.base", "newton", "newton (the loop)"),
    ("rodsim.core.model:Model", "turned_step", "Model.turned_step (the retraction)"),
    ("rodsim.core.model:Model", "force_residual", "Model.force_residual"),
    ("rodsim.solvers.run_state:RunState", "force", "RunState.force (counted, finite)"),
    ("rodsim.solvers.run_state:RunState", "jacobian_data",
     "RunState.jacobian_data (counted, finite)"),
    ("rodsim.solvers.newton", "_descent", "newton._descent"),
    ("rodsim.solvers.newton", "_trial", "newton._trial"),
    ("rodsim.solvers.newton:_Jacobians", "step", "newton._Jacobians.step"),
    ("rodsim.solvers.newton", "_accepted", "newton._accepted"),
    ("rodsim.solvers.run_state:RunState", "reregister", "RunState.reregister"),
    ("rodsim.solvers.run_state:RunState", "settled", "RunState.settled"),
    ("rodsim.solvers.run_state:RunState", "residual_at", "RunState.residual_at"),
    ("rodsim.solvers.run_state:RunState", "record", "RunState.record"),
    ("rodsim.solvers.stops:Equilibrium", "verdict", "Equilibrium.verdict"),
    ("rodsim.solvers.stops", "contact_failure", "contact_failure"),
    ("rodsim.solvers.base:Integrator", "verified_residual", "verified_residual"),
    ("rodsim.solvers.base", "equilibrium_factor", "equilibrium_factor"),
    ("rodsim.solvers.linear:LinearSolver", "factorized", "LinearSolver.factorized"),
    ("rodsim.solvers.base", "correction_residual", "correction_residual"),
    ("rodsim.solvers.linear:BandCholeskySolve", "__call__",
     "BandCholeskySolve (dpbtrs, the correction residual)"),
    ("rodsim.solvers.run_state:RunState", "full_model", "RunState.full_model"),
    ("rodsim.solvers.run_state:RunState", "stability", "RunState.stability"),
    ("rodsim.solvers.run_state", "assess", "stability.assess"),
    ("rodsim.core.stability_band:BandStiffness", "certified",
     "BandStiffness.certified (the verdict's shifted dpbtrf)"),
    ("rodsim.solvers.result:Result", "from_model", "Result.from_model"),
)


def _owner(path: str) -> Any:
    import importlib

    module, _, name = path.partition(":")
    owner = importlib.import_module(module)
    return getattr(owner, name) if name else owner


def measure(scene_name: str, solves: int) -> dict[str, Any]:
    """The exclusive time of each wrapped function in the fastest of ``solves`` warm
    static solves of ``scene_name`` [s], its calls, and that solve's time."""
    import rodsim.app.api as api

    totals: Counter = Counter()
    calls: Counter = Counter()
    stack: list[float] = []

    def wrapped(function: Callable[..., Any], label: str) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            stack.append(0.0)
            try:
                return function(*args, **kwargs)
            finally:
                spent = time.perf_counter() - start
                inner = stack.pop()
                totals[label] += spent - inner
                calls[label] += 1
                if stack:
                    stack[-1] += spent
        return timed

    for path, attribute, label in WRAPPED:
        owner = _owner(path)
        setattr(owner, attribute, wrapped(getattr(owner, attribute), label))

    def nothing() -> None:
        return None

    empty = wrapped(nothing, "empty")
    start = time.perf_counter()
    for _ in range(20_000):
        empty()
    per_wrapper = (time.perf_counter() - start) / 20_000
    scene = api.load_scene(scene_name)
    model = api.build_model(scene)
    for _ in range(30):
        api.solve(scene, "static", model=model)
    best, rows = float("inf"), {}
    for _ in range(solves):
        totals.clear()
        calls.clear()
        start = time.perf_counter()
        api.solve(scene, "static", model=model)
        spent = time.perf_counter() - start
        if spent < best:
            best = spent
            rows = {label: (max(totals[label] - 0.5 * per_wrapper * calls[label], 0.0),
                            calls[label]) for label in totals}
    return {"scene": scene_name, "solve_s": best, "per_wrapper_s": per_wrapper,
            "rows": rows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default="tdcr-two-segment")
    parser.add_argument("--solves", type=int, default=300)
    parser.add_argument("--output-dir", type=Path, default=Path("runs/bench"))
    args = parser.parse_args(argv)
    report = measure(args.scene, args.solves)
    rows = sorted(report["rows"].items(), key=lambda item: -item[1][0])
    floor = sum(spent for label, (spent, _) in rows if label.startswith("floor:"))
    lines = [f"# Where a warm static solve of {args.scene} goes", "",
             f"Wall time, the fastest of {args.solves} solves, model built once: "
             f"{report['solve_s'] * 1e6:.0f} µs with its wrappers, the floor's primitives "
             f"{floor * 1e6:.0f} µs; each wrapper ~{report['per_wrapper_s'] * 1e6:.2f} µs, "
             "half of it subtracted per call. Exclusive time (less the wrapped calls "
             "inside).", "", "| function | calls a solve | µs a solve |", "|---|--:|--:|"]
    lines += [f"| {label} | {count} | {spent * 1e6:.0f} |" for label, (spent, count) in rows]
    lines.append("")
    args.output_dir.mkdir(parents=True, exist_ok=True)
    (args.output_dir / "static-own-work.json").write_text(json.dumps(report, indent=1) + "\n")
    (args.output_dir / "static-own-work.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
