"""The string-tendon kernel before and after a change, measured in one run (issue 35
item 4: "the six tendons are 93 % of each F+J on tdcr-two-segment").

For this checkout and a baseline revision (``--baseline``, default
``RODSIM_BENCH_BASELINE``; its tree extracted by ``git archive`` as in
``rodsim_bench.baseline``), each in its own process, the two sides interleaved over
``--rounds`` rounds, minimum over the rounds (CPU time, ``time.process_time``; the kernels
warm, loaded from each tree's own numba cache):

- µs per tendon of one F+J and of one F: the ``tendon_string`` kernel calls of
  tdcr-two-segment at its equilibrium, alone (one per tendon, or one for the six where the
  checkout groups a catheter's tendons, rodsim/core/kernel_group.py), best of 40 × 20;
- one whole F+J of the model (every term), and the tendons' share of it;
- the static solve (model built once, best of 9) against its floor, counted and costed by
  ``rodsim_bench.floor`` (``counted_solve``, ``raw_costs``);
- ``rodsim.solve_many`` on ``--cases`` random cases of ``rodsim_bench.batch`` in this
  process (1 worker), best of 2: equilibria per CPU second.

Writes ``tendon-kernel.json`` and ``tendon-kernel.md`` (``--stem``: another name, for a
second record beside the first) into ``--output-dir`` (default ``runs/bench``). Nothing is
asserted.

    python benchmarks/tendon_kernel.py --baseline b79a21a --output-dir benchmarks/results
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def measure(cases: int) -> dict:
    """The numbers of one side, in this process (with its rodsim)."""
    import numpy as np

    import rodsim
    from rodsim.app.batch import solve_many
    from rodsim.core.terms.tendon_string import TendonString
    from rodsim_bench.batch import random_cases
    from rodsim_bench.floor import best_cpu, counted_solve, floor_of, raw_costs

    scene = rodsim.load_scene("tdcr-two-segment")
    model = rodsim.build_model(scene)
    result = rodsim.solve(scene, "static", model=model)
    x = result.state
    model.evaluate(x)
    calls = [c for c in model._kernel_calls if isinstance(c.term, TendonString)]
    # What the compiled path calls for them: one call per tendon, or per group of tendons
    # where the checkout groups terms (rodsim/core/kernel_group.py).
    units = (model._kernel_unit_list() if hasattr(model, "_kernel_unit_list")
             else model._kernel_calls)
    units = [u for u in units if any(isinstance(c.term, TendonString)
                                     for c in getattr(u, "calls", (u,)))]
    full = model.full(x)
    force = np.zeros(model.n + 1)
    jacobian = np.zeros(model.nnz + 1)
    inner = 20

    def tendons(want_jacobian: bool) -> None:
        for _ in range(inner):
            for u in units:
                scale = np.ones(len(u.calls)) if hasattr(u, "calls") else 1.0
                u.evaluate(full, *u.arguments, scale, True, force, u.force_target,
                           want_jacobian, jacobian, u.jacobian_target)

    def whole() -> None:
        for _ in range(inner):
            model._evaluate(x, 1.0, True, True)

    tendons(True)
    out: dict = {
        "tendons": len(calls),
        "chords": [int(c.term.dofs.shape[0]) for c in calls],
        "tendon_fj_us": best_cpu(lambda: tendons(True), 40) / inner / len(calls) * 1e6,
        "tendon_f_us": best_cpu(lambda: tendons(False), 40) / inner / len(calls) * 1e6,
        "whole_fj_us": best_cpu(whole, 40) / inner * 1e6}
    out["tendon_share"] = out["tendon_fj_us"] * len(calls) / out["whole_fj_us"]
    out["static_ms"] = best_cpu(lambda: rodsim.solve(scene, "static", model=model), 9) * 1e3
    counted, counts = counted_solve(scene, model)
    costs = raw_costs(model, counted.state, 200)
    out["floor_ms"] = floor_of(counts, costs) * 1e3
    out["static_over_floor"] = out["static_ms"] / out["floor_ms"]
    out["counts"] = dict(counts)
    out["raw_us"] = {k: v * 1e6 for k, v in costs.items()}
    table = random_cases(cases)
    solve_many("tdcr-two-segment", {k: v[:2] for k, v in table.items()},
               log=lambda message: None)
    spent = best_cpu(lambda: solve_many("tdcr-two-segment", table, log=lambda message: None), 2)
    out["batch_cases"] = cases
    out["batch_per_cpu_second"] = cases / spent
    return out


def _side(tree: Path, cases: int) -> dict:
    env = {**os.environ, "PYTHONPATH": f"{tree}{os.pathsep}{HERE}",
           "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--measure",
                           str(cases)], env=env, capture_output=True, text=True, check=False,
                          cwd=str(tree))
    if done.returncode != 0:
        raise RuntimeError(f"{tree}: {done.stderr.strip()[-800:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _commit(revision: str) -> str:
    return subprocess.run(["git", "-C", str(ROOT), "rev-parse", revision], check=True,
                          capture_output=True, text=True).stdout.strip()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", default=os.environ.get("RODSIM_BENCH_BASELINE", ""),
                        help="git revision to compare with (default RODSIM_BENCH_BASELINE)")
    parser.add_argument("--cases", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--output-dir", type=Path, default=Path("runs/bench"))
    parser.add_argument("--stem", default="tendon-kernel",
                        help="name of the results files (STEM.json, STEM.md)")
    parser.add_argument("--measure", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.measure:
        print(json.dumps(measure(args.measure)))
        return 0
    sides = {"after": ROOT}
    with tempfile.TemporaryDirectory() as folder:
        if args.baseline:
            tree = Path(folder) / "tree"
            tree.mkdir()
            archive = subprocess.run(["git", "-C", str(ROOT), "archive",
                                      _commit(args.baseline)], capture_output=True,
                                     check=True).stdout
            subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
            sides = {"before": tree, "after": ROOT}
        rounds: dict[str, list[dict]] = {name: [] for name in sides}
        for _ in range(args.rounds):
            for name, tree in sides.items():
                rounds[name].append(_side(tree, args.cases))
    keys = ("tendon_fj_us", "tendon_f_us", "whole_fj_us", "static_ms", "floor_ms")
    best = {name: {**runs[0], **{k: min(r[k] for r in runs) for k in keys},
                   "batch_per_cpu_second": max(r["batch_per_cpu_second"] for r in runs)}
            for name, runs in rounds.items()}
    for row in best.values():
        row["tendon_share"] = row["tendon_fj_us"] * row["tendons"] / row["whole_fj_us"]
        row["static_over_floor"] = row["static_ms"] / row["floor_ms"]
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True,
                          text=True, check=False).stdout.strip()
    report = {"benchmark": "tendon-kernel", "head": head, "dirty": bool(subprocess.run(
        ["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
        capture_output=True, text=True, check=False).stdout.strip()),
        "baseline": _commit(args.baseline) if args.baseline else "", "cases": args.cases,
        "rounds": rounds, "best": best, "date": time.strftime("%Y-%m-%d %H:%M UTC",
                                                              time.gmtime()),
        "load_average": os.getloadavg()[0]}
    lines = [f"# The string-tendon kernel on tdcr-two-segment ({report['date']})", "",
             f"HEAD {head[:10]}" + (" (uncommitted changes)" if report["dirty"] else "")
             + (f" against {report['baseline'][:10]}" if args.baseline else "")
             + f"; CPU time, each side's minimum over {args.rounds} interleaved rounds; "
             f"load average {report['load_average']:.1f}.", "",
             "| | µs per tendon, F+J | µs per tendon, F | whole F+J [µs] | tendons' share | "
             "static [ms] | floor [ms] | static / floor | batch, equilibria per CPU s |",
             "|---|--:|--:|--:|--:|--:|--:|--:|--:|"]
    for name, row in best.items():
        lines.append(f"| {name} | {row['tendon_fj_us']:.1f} | {row['tendon_f_us']:.1f} | "
                     f"{row['whole_fj_us']:.0f} | {100 * row['tendon_share']:.0f} % | "
                     f"{row['static_ms']:.2f} | {row['floor_ms']:.2f} | "
                     f"{row['static_over_floor']:.2f} | {row['batch_per_cpu_second']:.0f} |")
    lines.append("")
    args.output_dir.mkdir(parents=True, exist_ok=True)
    (args.output_dir / f"{args.stem}.json").write_text(json.dumps(report, indent=1) + "\n")
    (args.output_dir / f"{args.stem}.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
