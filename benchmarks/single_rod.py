"""Benchmark: every integrator to equilibrium on one single-rod scene (issue: foundation).

    python benchmarks/single_rod.py [--repeats R] [--output-dir DIR]

Scene: paper Table 1 with the 50 g mass (``table1-50g``), N = 40 control points. For each
configuration the scene is loaded and its model built once; then

- warm-up: one solve (its result gives the error and the statistics);
- "solve only": minimum over R repeats of ``rodsim.solve(scene, name, model=model)`` (the
  integrator's set-up and run; model assembly excluded);
- "build + solve": minimum over R repeats of ``rodsim.build_model`` + ``rodsim.solve``.

The repeats run round-robin over the configurations, so that a burst of load on the machine
hits every configuration alike rather than one of them.

Reference: ``static`` with ``solver.tolerance = 1e-12`` (raised by rodsim to the model's
round-off floor, then polished by Newton). Error = largest distance of a control point from
the reference / L. Ratios are solve-only times divided by the static and by the paper
(analytic Jacobian) solve-only times. A cProfile of the default CVODE run (overdamped, band)
shows where the time goes.

Writes ``single_rod.json`` and ``single_rod.md`` to the output directory (default:
``benchmarks/results``). This is a benchmark, not a test: nothing is asserted.
"""

from __future__ import annotations

import os

# Single-threaded BLAS/OpenMP, set before numpy is imported (docs/design.md §8).
os.environ["OMP_NUM_THREADS"] = "1"
os.environ["OPENBLAS_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import cProfile  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
import pstats  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import timeit  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import rodsim  # noqa: E402
from rodsim.core.model_evaluation import MEMO_STATES  # noqa: E402
from rodsim.solvers.result import count_text  # noqa: E402
from rodsim_bench.machine import machine  # noqa: E402

SCENE = "table1-50g"
NODES = 40
REFERENCE_TOLERANCE = 1e-12
STATS = ("steps", "force_evals", "jacobian_evals", "newton_iters")

#: (label, integrator, scene overrides)
CONFIGURATIONS: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("static", "static", ()),
    ("paper (analytic Jacobian)", "paper", ("solver.paper.jacobian=analytic",)),
    ("paper (finite-difference Jacobian)", "paper",
     ("solver.paper.jacobian=finite_difference",)),
    ("cvode inertial band", "cvode",
     ("solver.cvode.formulation=inertial", "solver.cvode.linear_solver=band")),
    ("cvode inertial sparse", "cvode",
     ("solver.cvode.formulation=inertial", "solver.cvode.linear_solver=sparse")),
    ("cvode overdamped band", "cvode",
     ("solver.cvode.formulation=overdamped", "solver.cvode.linear_solver=band")),
    ("cvode overdamped sparse", "cvode",
     ("solver.cvode.formulation=overdamped", "solver.cvode.linear_solver=sparse")),
    ("ida overdamped band", "ida",
     ("solver.ida.formulation=overdamped", "solver.ida.linear_solver=band")),
    ("ida inertial band", "ida",
     ("solver.ida.formulation=inertial", "solver.ida.linear_solver=band")),
)


def all_positions(result) -> np.ndarray:
    return np.concatenate([shape.positions for shape in result.rods.values()])


class Configuration:
    """One integrator configuration: its scene, its model built once, and its timings."""

    def __init__(self, label: str, integrator: str, overrides: tuple[str, ...]) -> None:
        self.label, self.integrator, self.overrides = label, integrator, overrides
        self.scene = rodsim.load_scene(SCENE, [f"nodes={NODES}", *overrides])
        self.model = rodsim.build_model(self.scene)
        self.solve_only: list[float] = []
        self.build_and_solve: list[float] = []

    def solve(self):
        return rodsim.solve(self.scene, self.integrator, model=self.model)

    def time_once(self) -> None:
        start = time.perf_counter()
        self.solve()
        self.solve_only.append(time.perf_counter() - start)
        start = time.perf_counter()
        rodsim.solve(self.scene, self.integrator, model=rodsim.build_model(self.scene))
        self.build_and_solve.append(time.perf_counter() - start)


def measure(repeats: int, reference: np.ndarray, length: float) -> list[dict[str, object]]:
    """Warm up every configuration, then time them round-robin (noise hits all alike)."""
    configurations = [Configuration(*c) for c in CONFIGURATIONS]
    warm = [c.solve() for c in configurations]  # warm-up, and the reported runs
    for _ in range(repeats):
        for configuration in configurations:
            configuration.time_once()
    rows = []
    for c, result in zip(configurations, warm, strict=True):
        error = float(np.max(np.linalg.norm(all_positions(result) - reference, axis=1))
                      / length)
        row = {
            "label": c.label,
            "integrator": c.integrator,
            "overrides": list(c.overrides),
            "success": result.success,
            "message": result.message,
            "solve_only_s": min(c.solve_only),
            "build_and_solve_s": min(c.build_and_solve),
            "solve_only_all_s": c.solve_only,
            "build_and_solve_all_s": c.build_and_solve,
            "integrator_wall_time_s": result.stats["wall_time"],
            "error_over_L": error,
            "residual": result.residual,
            "effective_tolerance": result.stats["effective_tolerance"],
        }
        row |= {key: count_text(result.stats[key]) for key in STATS}
        rows.append(row)
        print(f"{c.label:<36s} {1e3 * row['solve_only_s']:9.2f} ms  "
              f"{1e3 * row['build_and_solve_s']:9.2f} ms  error {error:.2e} L  "
              f"{'ok' if result.success else 'FAILED'}", file=sys.stderr)
    return rows


def evaluation_costs(repeats: int) -> dict[str, float]:
    """Wall time of one F(x) and one ∂F/∂x evaluation near the rest state [s] (min of
    R×200), at states 1e-9 … 4e-9 L from it in turn: more states than the model remembers
    (``MEMO_STATES``), so every call evaluates (one state asked again would time the memo's
    copy of its last answer)."""
    model = rodsim.build_model(rodsim.load_scene(SCENE, [f"nodes={NODES}"]))
    x = model.x0
    wiggle = np.sin(np.arange(len(x)))
    states = [x + k * 1e-9 * model.length_scale * wiggle
              for k in range(1, MEMO_STATES + 3)]
    turn = itertools.cycle(states)
    out = {"unknowns": model.n, "jacobian_nonzeros": model.nnz}
    for name, function in (("force_s", lambda: model.force(next(turn))),
                           ("jacobian_s", lambda: model.jacobian_data(next(turn)))):
        out[name] = min(timeit.repeat(function, number=200, repeat=repeats)) / 200
    return out


def profile_default_cvode(repeats: int) -> dict[str, object]:
    """cProfile of the default CVODE run (scene defaults: overdamped, band), per run."""
    scene = rodsim.load_scene(SCENE, [f"nodes={NODES}"])
    rodsim.solve(scene, "cvode")  # warm-up
    profiler = cProfile.Profile()
    profiler.enable()
    for _ in range(repeats):
        rodsim.solve(scene, "cvode")
    profiler.disable()
    stats = pstats.Stats(profiler)
    total = stats.total_tt / repeats
    rows = []
    for (filename, line, function), (_, calls, tottime, cumtime, _) in stats.stats.items():
        where = f"{filename}:{line}({function})"
        if "rodsim" not in where and "sksundae" not in where:
            continue
        if "site-packages/" in filename:
            filename = filename.split("site-packages/", 1)[1]
        elif "/rodsim/" in filename:
            filename = "rodsim/" + filename.rsplit("/rodsim/", 1)[1]
        rows.append({"function": f"{filename}:{line}({function})",
                     "calls": calls / repeats, "tottime_s": tottime / repeats,
                     "cumtime_s": cumtime / repeats})
    rows.sort(key=lambda r: r["cumtime_s"], reverse=True)
    return {"runs": repeats, "total_s_per_run": total, "top": rows[:15]}


def markdown(report: dict[str, object]) -> str:
    m = report["machine"]
    lines = [
        "# Single-rod benchmark",
        "",
        f"Scene `{report['scene']}`, N = {report['nodes']}; wall times are the minimum "
        f"over {report['repeats']} repeats after one warm-up. Reference: `static` with "
        f"tolerance {report['reference']['requested_tolerance']:g} (effective "
        f"{report['reference']['effective_tolerance']:.3g}). Ratios use solve-only times.",
        "",
        f"Machine: {m['cpu']}, {m['cores']} cores ({m['cores_available']} available), "
        f"{m['platform']}; Python {m['python']}, numpy {m['numpy']}, scipy {m['scipy']}, "
        f"scikit-sundae {m['scikit_sundae']}, rodsim {m['rodsim']}; "
        f"OMP_NUM_THREADS = OPENBLAS_NUM_THREADS = 1; {m['date']}; "
        f"commit {m['git_commit']}.",
        "",
        "| integrator | solve only [ms] | build + solve [ms] | × static | × paper "
        "| error / L | steps | force evals | Jacobian evals | Newton iters |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    for r in report["results"]:
        label = r["label"] if r["success"] else f"{r['label']} (FAILED)"
        lines.append(
            f"| {label} | {1e3 * r['solve_only_s']:.2f} | {1e3 * r['build_and_solve_s']:.2f} "
            f"| {r['ratio_to_static']:.2f} | {r['ratio_to_paper']:.2f} "
            f"| {r['error_over_L']:.1e} | {r['steps']} | {r['force_evals']} "
            f"| {r['jacobian_evals']} | {r['newton_iters']} |")
    e = report["evaluation_cost"]
    lines += [
        "",
        f"One evaluation at the rest state ({e['unknowns']} unknowns, "
        f"{e['jacobian_nonzeros']} Jacobian non-zeros): F(x) {1e6 * e['force_s']:.0f} µs, "
        f"∂F/∂x {1e6 * e['jacobian_s']:.0f} µs.",
    ]
    p = report["profile"]
    lines += [
        "",
        "## Profile of the default CVODE run (overdamped, band)",
        "",
        f"cProfile over {p['runs']} runs of `rodsim.solve(scene, \"cvode\")` (model build "
        f"included), per run; {1e3 * p['total_s_per_run']:.1f} ms per run under the "
        "profiler. Top 15 rodsim and scikit-sundae functions by cumulative time:",
        "",
        "| function | calls | own [ms] | cumulative [ms] |",
        "|---|--:|--:|--:|",
    ]
    for row in p["top"]:
        lines.append(f"| `{row['function']}` | {row['calls']:g} | {1e3 * row['tottime_s']:.2f} "
                     f"| {1e3 * row['cumtime_s']:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, metavar="R",
                        help="timed repeats per configuration (minimum is kept; default 5)")
    parser.add_argument("--output-dir", type=Path,
                        default=Path(__file__).resolve().parent / "results",
                        help="where to write single_rod.json and single_rod.md")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    args.output_dir.mkdir(parents=True, exist_ok=True)

    reference_scene = rodsim.load_scene(
        SCENE, [f"nodes={NODES}", f"solver.tolerance={REFERENCE_TOLERANCE}"])
    reference_result = rodsim.solve(reference_scene, "static")
    if not reference_result.success:
        print(f"reference failed: {reference_result.message}", file=sys.stderr)
        return 1
    reference = all_positions(reference_result)
    length = max(shape.s[-1] for shape in reference_result.rods.values())

    results = measure(args.repeats, reference, length)
    static_time = next(r["solve_only_s"] for r in results if r["label"] == "static")
    paper_time = next(r["solve_only_s"] for r in results
                      if r["label"] == "paper (analytic Jacobian)")
    for r in results:
        r["ratio_to_static"] = r["solve_only_s"] / static_time
        r["ratio_to_paper"] = r["solve_only_s"] / paper_time
    report = {
        "benchmark": "single_rod",
        "scene": SCENE,
        "nodes": NODES,
        "repeats": args.repeats,
        "machine": machine(),
        "reference": {"integrator": "static", "requested_tolerance": REFERENCE_TOLERANCE,
                      "effective_tolerance": reference_result.stats["effective_tolerance"],
                      "residual": reference_result.residual,
                      "tip": reference_result.tip().tolist()},
        "results": results,
        "evaluation_cost": evaluation_costs(args.repeats),
        "profile": profile_default_cvode(args.repeats),
    }
    (args.output_dir / "single_rod.json").write_text(json.dumps(report, indent=2) + "\n")
    text = markdown(report)
    (args.output_dir / "single_rod.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
