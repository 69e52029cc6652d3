"""Where a batch case's time goes (issue 35 item 1): ``rodsim.solve_many`` on ``--cases``
random tdcr-two-segment cases of ``rodsim bench batch`` in this process, cold and warm
(``warm=True``), each function's own CPU time per case, and a case's floor: its
evaluations of F and ∂F/∂x and its linear solves and factorisations, counted in one more
batch (``rodsim_bench.floor.counted_calls``), each at its raw cost at the first case's
equilibrium (``raw_costs``).

The functions below are wrapped with ``time.process_time`` counters; each wrapper's time
is its function's less that of the wrapped functions it calls (its own share), so the
shares add up to the batch's CPU time (the wrappers add ~1 µs a call, so the batch runs
~10 % slower than unwrapped; the unwrapped rate is measured first, best of 2). Prints a
markdown table per mode; writes ``batch-profile.md`` into ``--output-dir`` if given.
Nothing is asserted.

    python benchmarks/batch_profile.py --cases 200 --output-dir benchmarks/results
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE)]

import rodsim.app.api as api  # noqa: E402
import rodsim.app.batch as batch  # noqa: E402
import rodsim.app.batch_warm as batch_warm  # noqa: E402
import rodsim.app.study_points as study_points  # noqa: E402
import rodsim.io.batch_dataset as batch_dataset  # noqa: E402
import rodsim.solvers.base as base  # noqa: E402
import rodsim.solvers.linear as linear  # noqa: E402
import rodsim.solvers.result as result  # noqa: E402
import rodsim.solvers.run_state as run_state  # noqa: E402
import rodsim.solvers.static as static  # noqa: E402
import rodsim.solvers.stops as stops  # noqa: E402
from rodsim.core.model import Model  # noqa: E402
from rodsim_bench.batch import KEYS, SCENE, random_cases  # noqa: E402
from rodsim_bench.floor import counted_calls, floor_of, raw_costs  # noqa: E402

_OWN: dict[str, float] = {}
_CALLS: dict[str, int] = {}
_STACK: list[float] = []


def _wrap(owner: Any, attribute: str, label: str) -> None:
    """Count ``owner.attribute``'s own CPU time under ``label``."""
    for holder in getattr(owner, "__mro__", (owner,)):
        if attribute in vars(holder):
            owner = holder
            break
    function = getattr(owner, attribute)

    @functools.wraps(function)
    def counted(*args: Any, **kwargs: Any) -> Any:
        _STACK.append(0.0)
        start = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            spent = time.process_time() - start
            inner = _STACK.pop()
            _OWN[label] = _OWN.get(label, 0.0) + spent - inner
            _CALLS[label] = _CALLS.get(label, 0) + 1
            if _STACK:
                _STACK[-1] += spent

    setattr(owner, attribute, counted)


#: (owner, attribute, label): what each row counts.
WRAPPED = (
    (Model, "evaluate", "F and ∂F/∂x evaluations (kernels, memo)"),
    (Model, "force", "F evaluations (kernels, memo)"),
    (Model, "jacobian_data", "F + ∂F/∂x evaluations"),
    (Model, "energy", "energy (the line search's merit)"),
    (Model, "force_residual", "the residual max|F| w"),
    (Model, "turned_step", "the retraction (turned_step)"),
    (linear.LinearSolver, "solve", "linear solves (band)"),
    (Model, "with_values", "Model.with_values (the case's values)"),
    (batch, "scene_with", "the case's scene (scene_with)"),
    (batch_warm, "scene_with", "the case's scene (scene_with)"),
    (batch_warm, "_predicted", "the tangent predictor (less its F)"),
    (base, "newton", "Newton's loop, line search"),
    (base.Integrator, "newton_equilibrium", "Newton's problem set-up"),
    (static.Static, "advance", "static: advance, load continuation"),
    (static, "load_continuation", "static: advance, load continuation"),
    (base.Integrator, "verified_residual", "verification: F, J factored, correction"),
    (stops.Equilibrium, "verdict", "verification: F, J factored, correction"),
    (run_state.RunState, "stability", "stability verdict"),
    (result.Result, "from_model", "Result.from_model"),
    (base.Integrator, "init", "run state (init)"),
    (base.Integrator, "run", "run, ended, for_scene, solve"),
    (base.Integrator, "ended", "run, ended, for_scene, solve"),
    (api, "solve", "run, ended, for_scene, solve"),
    (api, "load_scene", "run, ended, for_scene, solve"),
    (study_points, "solved_record", "the case's record, chunks"),
    (batch, "solve_chunk", "the case's record, chunks"),
    (batch_dataset, "batch_dataset", "the archive (batch_dataset)"),
)


def _rates(cases: dict, warm: bool) -> float:
    best = float("inf")
    for _ in range(2):
        start = time.process_time()
        batch.solve_many(SCENE, cases, warm=warm)
        best = min(best, time.process_time() - start)
    return best


def _floors(cases: dict) -> dict[bool, tuple[float, dict[str, float]]]:
    """Per mode (warm or not), a case's floor [s] and its counted calls a case (module
    docstring)."""
    from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with

    scene = api.load_scene(SCENE)
    keys = numeric_keys(scene, list(KEYS))
    first = scene_with(scene, keys, [float(cases[key][0]) for key in KEYS])
    model = api.build_model(first)
    costs = raw_costs(model, api.solve(first, "static", model=model).state, 200)
    count = len(next(iter(cases.values())))
    floors = {}
    for warm in (False, True):
        with counted_calls() as counts:
            batch.solve_many(SCENE, cases, warm=warm)
        floors[warm] = (floor_of(counts, costs) / count,
                        {key: value / count for key, value in counts.items()})
    return floors


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=200)
    parser.add_argument("--output-dir", type=Path)
    args = parser.parse_args()
    cases = random_cases(args.cases)
    batch.solve_many(SCENE, {k: v[:2] for k, v in cases.items()})  # kernels loaded
    unwrapped = {warm: _rates(cases, warm) for warm in (False, True)}
    floors = _floors(cases)
    for owner, attribute, label in WRAPPED:
        _wrap(owner, attribute, label)
    lines = [f"# Where a batch case's time goes: {args.cases} random {SCENE} cases, one "
             "process", ""]
    for warm in (False, True):
        _OWN.clear()
        _CALLS.clear()
        start = time.process_time()
        dataset = batch.solve_many(SCENE, cases, warm=warm)
        spent = time.process_time() - start
        count = args.cases
        iterations = float(dataset["newton_iters"].values.mean())
        lines += [f"## {'warm' if warm else 'cold'}: {count / unwrapped[warm]:.0f} "
                  f"equilibria per CPU second unwrapped ({1e3 * unwrapped[warm] / count:.2f} "
                  f"ms a case), {1e3 * spent / count:.2f} ms wrapped; {iterations:.2f} "
                  "Newton iterations a case", "",
                  f"Floor: {1e3 * floors[warm][0]:.2f} ms a case (unwrapped / floor "
                  f"{unwrapped[warm] / count / floors[warm][0]:.2f}): "
                  + ", ".join(f"{name} {number:.2f}" for name, number
                              in sorted(floors[warm][1].items())) + " a case", "",
                  "| where | calls a case | µs a case | share |", "|---|--:|--:|--:|"]
        for label, own in sorted(_OWN.items(), key=lambda item: -item[1]):
            lines.append(f"| {label} | {_CALLS[label] / count:.2f} | "
                         f"{1e6 * own / count:.0f} | {100 * own / spent:.1f} % |")
        rest = spent - sum(_OWN.values())
        lines += [f"| not wrapped | | {1e6 * rest / count:.0f} | {100 * rest / spent:.1f} % |",
                  ""]
    text = "\n".join(lines)
    print(text)
    if args.output_dir is not None:
        (args.output_dir / "batch-profile.md").write_text(text + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
