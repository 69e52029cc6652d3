"""Benchmark ``floor``: one ``static`` solve against its own floor (issue 24: "four-tendons
static within 3× of its floor — F, F+J and factor counts at their measured raw costs").

Per scene, with the model built once (kernels loaded; assembly is not part of a solve):

- the solve's CPU time (``time.process_time``, minimum of the repeats, the model given);
- what it called, counted in one more solve with the model's and the linear solver's methods
  wrapped: evaluations of F alone, of ∂F/∂x (with or without F), of the energy (the line
  search), and band or sparse solves (factor and solve). An evaluation is one the model
  makes (``Model._evaluate``): a call ``Model.evaluate`` answers from its memory of the last
  two states costs a copy, is counted apart (``remembered``) and is not part of the floor;
- each primitive's raw cost near the solution, best of many calls on a copy of the model
  (an empty memory), cycling through more nearby states than the model remembers, none of
  them the solution itself, so that no remembered evaluation is timed (until 2026-11-26 the
  first state was the solution, which ``raw_costs`` had just evaluated: F's "raw cost" was
  the memory's answer, 10–17 µs where four-tendons' F costs ~145 µs);
- the floor Σ count × raw cost, and the ratio solve / floor: what the solver's own work
  (Python between the calls, load and penalty continuation bookkeeping, the checks after
  convergence) adds to the arithmetic it cannot avoid.

Writes ``floor-<size>.json`` and ``floor-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import copy
import time
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

import rodsim
from rodsim.core.model import Model
from rodsim.solvers.base import Progress
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.run_state import linear_solver_of
from rodsim_bench.machine import machine, write_report

__all__ = ["run", "counted_calls", "counted_solve", "floor_of", "raw_costs"]

SIZES = {"small": {"scenes": ("table1-50g", "four-tendons"), "repeats": 2, "calls": 20},
         "full": {"scenes": ("table1-50g", "table3-catheter1", "tendon-conserving",
                             "four-tendons", "tdcr-two-segment", "catheter-pull-ring"),
                  "repeats": 7, "calls": 200}}


def best_cpu(call: Callable[[], Any], calls: int) -> float:
    """Smallest CPU time of one ``call`` over ``calls`` calls [s]."""
    best = float("inf")
    for _ in range(calls):
        start = time.process_time()
        call()
        best = min(best, time.process_time() - start)
    return best


@contextmanager
def counted_calls() -> Iterator[Counter]:
    """Within the block, count what every model and linear solver does: evaluations of F
    alone (``force``), of F and ∂F/∂x in one pass (``jacobian``), of ∂F/∂x alone where F
    was known (``jacobian_alone``), of the energy, and band or
    sparse solves and factorisations (``linear``); ``remembered`` counts the calls
    ``Model.evaluate`` answered from its memory (a copy: not an evaluation)."""
    counts: Counter = Counter()
    evaluate, evaluated, energy = Model.evaluate, Model._evaluate, Model.energy
    solve, factorized = LinearSolver.solve, LinearSolver.factorized

    def counted_evaluate(self: Model, x: np.ndarray, load: float = 1.0, *,
                         force: bool = True, jacobian: bool = True) -> Any:
        counts["remembered"] += 1  # less the evaluations made, below
        return evaluate(self, x, load, force=force, jacobian=jacobian)

    def counted_evaluated(self: Model, x: np.ndarray, load: float, force: bool,
                          jacobian: bool) -> Any:
        counts["remembered"] -= 1
        counts[("jacobian" if force else "jacobian_alone") if jacobian else "force"] += 1
        return evaluated(self, x, load, force, jacobian)

    def counted_energy(self: Model, *args: Any, **kwargs: Any) -> float:
        counts["energy"] += 1
        return energy(self, *args, **kwargs)

    def counted_solve_(self: LinearSolver, *args: Any, **kwargs: Any) -> np.ndarray:
        counts["linear"] += 1
        return solve(self, *args, **kwargs)

    def counted_factorized(self: LinearSolver, *args: Any, **kwargs: Any) -> Any:
        counts["linear"] += 1
        return factorized(self, *args, **kwargs)

    # Model inherits these: they are set on Model for the block and deleted after it (not
    # assigned back, which would leave Model its own copies that hide any later
    # replacement on the class that defines them)
    own = {name: Model.__dict__.get(name) for name in ("evaluate", "_evaluate", "energy")}
    Model.evaluate, Model.energy = counted_evaluate, counted_energy  # type: ignore[method-assign]
    Model._evaluate = counted_evaluated  # type: ignore[method-assign]
    LinearSolver.solve, LinearSolver.factorized = (  # type: ignore[method-assign]
        counted_solve_, counted_factorized)
    try:
        yield counts
    finally:
        for name, value in own.items():
            if value is None:
                delattr(Model, name)
            else:
                setattr(Model, name, value)
        LinearSolver.solve, LinearSolver.factorized = (  # type: ignore[method-assign]
            solve, factorized)


def counted_solve(scene: Any, model: Model) -> tuple[Any, Counter]:
    """One static solve of ``scene`` on ``model`` with its calls counted
    (``counted_calls``)."""
    with counted_calls() as counts:
        result = rodsim.solve(scene, "static", model=model)
    return result, counts


def floor_of(counts: Counter, costs: dict[str, float]) -> float:
    """Σ count × raw cost [s] of the counted calls (not the remembered ones)."""
    return sum(counts[key] * costs[key] for key in costs)


#: Distinct states the raw costs cycle through: more than the model remembers (two), so
#: that every timed call evaluates.
STATES = 5


def raw_costs(model: Model, x: np.ndarray, calls: int) -> dict[str, float]:
    """Best CPU time [s] of each primitive at states 1e-9 … 5e-9 L from ``x``, in turn, on a
    copy of ``model`` (nothing remembered); the linear solve at ``x``."""
    model = copy.copy(model)
    wiggle = np.sin(np.arange(len(x)))
    states = [x + k * 1e-9 * model.length_scale * wiggle for k in range(1, STATES + 1)]
    turn = iter(range(10**9))

    def state() -> np.ndarray:
        return states[next(turn) % STATES]

    linear = linear_solver_of(model)
    data = model.jacobian_data(x)
    rhs = model.force(x)
    costs = {"force": best_cpu(lambda: model.evaluate(state(), jacobian=False), calls),
             "jacobian": best_cpu(lambda: model.evaluate(state()), calls),
             "jacobian_alone": best_cpu(lambda: model._evaluate(state(), 1.0, False, True),
                                        calls),
             "linear": best_cpu(lambda: linear.solve(data, rhs), calls)}
    try:
        model.energy(x)
        costs["energy"] = best_cpu(lambda: model.energy(state()), calls)
    except (TypeError, ValueError, NotImplementedError):  # a non-conservative model
        costs["energy"] = 0.0
    return costs


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    config = SIZES[size]
    rows = []
    for k, name in enumerate(config["scenes"]):
        progress(k / len(config["scenes"]), f"floor: {name}")
        scene = rodsim.load_scene(name)
        model = rodsim.build_model(scene)
        rodsim.solve(scene, "static", model=model)  # warm-up
        times = []
        for _ in range(config["repeats"]):
            start = time.process_time()
            result = rodsim.solve(scene, "static", model=model)
            times.append(time.process_time() - start)
        counted, counts = counted_solve(scene, model)
        assert np.array_equal(counted.state, result.state)
        costs = raw_costs(model, result.state, config["calls"])
        floor = floor_of(counts, costs)
        rows.append({"scene": name, "unknowns": model.n, "solve_s": min(times),
                     "counts": dict(counts), "raw_s": costs, "floor_s": floor,
                     "ratio": min(times) / floor if floor > 0 else float("nan"),
                     "newton_iters": result.stats.get("newton_iters")})
    report = {"benchmark": "floor", "size": size, "machine": machine(), "rows": rows}
    m = report["machine"]
    lines = [f"# A static solve against its floor ({size})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. CPU, model built "
             "once; floor = Σ evaluations × raw cost of each (calls answered from the "
             "model's memory of its last two states are not evaluations).", "",
             "| scene | unknowns | solve [ms] | F / F+∂F / ∂F alone / energy / linear "
             "evaluations | remembered | raw F / F+∂F / ∂F alone / energy / linear [µs] | "
             "floor [ms] | "
             "solve / floor |",
             "|---|--:|--:|---|--:|---|--:|--:|"]
    for row in rows:
        c, r = row["counts"], row["raw_s"]
        lines.append(
            f"| {row['scene']} | {row['unknowns']} | {row['solve_s'] * 1e3:.2f} | "
            f"{c.get('force', 0)} / {c.get('jacobian', 0)} / {c.get('jacobian_alone', 0)} / "
            f"{c.get('energy', 0)} / {c.get('linear', 0)} | {c.get('remembered', 0)} | "
            f"{r['force'] * 1e6:.0f} / {r['jacobian'] * 1e6:.0f} / "
            f"{r['jacobian_alone'] * 1e6:.0f} / "
            f"{r['energy'] * 1e6:.0f} / {r['linear'] * 1e6:.0f} | {row['floor_s'] * 1e3:.2f} | "
            f"{row['ratio']:.2f} |")
    lines.append("")
    return write_report(report, "\n".join(lines), output_dir / f"floor-{size}")
