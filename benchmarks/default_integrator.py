"""Benchmark: which integrator should a scene that names none get? (`rodsim run` on user
scenes with `cvode`, `static` and `ida`).

    python benchmarks/default_integrator.py [--user-scenes DIR] [--output-dir DIR]
                                            [--max-wall-time S] [--group all|user|robots]

Each case is one `rodsim run SCENE --integrator NAME` in a fresh process, as a user runs it
(so the tiered kernels, the error estimates and the stability verdict are included), in the
scene's own folder. Measured: the child's CPU time (user + system, from `getrusage`), the
exit code and outcome, the solver's own wall time (the summary's `wall time` line) and the
first rod's tip. The cases: the user scenes of `--user-scenes` (scenes written from
docs/scenes.md by users, see its README; skipped if the folder is absent) and the robots of
benchmarks/default_integrator/ (written from docs/ only, no integrator named), some with a
second load given by `--set`. Every run is given `solver.max_wall_time` (default 300 s) so a
slow integrator ends with its own message.

Writes `default-integrator[-GROUP].json` and `.md` to the output directory (default
benchmarks/results), after every case. A benchmark, not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import re
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from rodsim_bench.machine import machine, write_report  # noqa: E402

HERE = Path(__file__).resolve().parent
ROBOTS = HERE / "default_integrator"
INTEGRATORS = ("cvode", "static", "ida")

#: (label, scene file name, --set values): the user scenes (in --user-scenes) ...
USER_CASES = (
    ("ablation", "ablation.toml", ()),
    ("tdcr3", "tdcr3.toml", ()),
    ("tdcr3, 1 mN tip", "tdcr3.toml", ("tip_load.force=[0,0,0.001]",)),
    ("guidewire", "guidewire.toml", ()),
    ("guidewire2", "guidewire2.toml", ()),
    ("guidewire2, inserted 20 mm", "guidewire2.toml", ("rods.wire.base.insertion=0.02",)),
    ("user-two-tendon", "user-two-tendon.toml", ()),
)
#: ... and the robots written for this benchmark (in benchmarks/default_integrator/).
ROBOT_CASES = (
    ("steel wire, 10 mN tip", "steel-wire.toml", ()),
    ("steel wire, 1 N tip", "steel-wire.toml", ("tip_load.force=[0,-1,0]",)),
    ("nitinol TDCR, 1.5/1 N + 5 mN", "nitinol-tdcr.toml", ()),
    ("polymer catheter, 0.4 N", "polymer-catheter.toml", ()),
    ("polymer catheter, 2 N", "polymer-catheter.toml", ("tension=2.0",)),
    ("wire in an arc vessel", "wire-in-arc.toml", ()),
    ("wire in an arc vessel, 5 mm deeper", "wire-in-arc.toml", ("rods.wire.base.insertion=0.005",)),
)

_TIP = re.compile(r"^tip of (\S+)\s+x =\s*(\S+) m\s+y =\s*(\S+) m\s+z =\s*(\S+) m", re.M)
_WALL = re.compile(r"^wall time\s+(\S+) s", re.M)
_OUTCOME = re.compile(r"^integrator\s+\S+\s+\((.*)\)$", re.M)


def run_case(scene: Path, integrator: str, sets: tuple[str, ...], max_wall: float) -> dict:
    """One `rodsim run` in a child process: its CPU time, exit code, outcome and tip."""
    with tempfile.TemporaryDirectory() as tmp:
        command = [sys.executable, "-m", "rodsim", "run", scene.name, "--integrator", integrator,
                   "-o", str(Path(tmp) / "out.nc"), "--set", f"max_wall_time={max_wall}"]
        for value in sets:
            command += ["--set", value]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        try:
            done = subprocess.run(command, cwd=scene.parent, capture_output=True, text=True,
                                  timeout=4 * max_wall + 300)
            code, out, err = done.returncode, done.stdout, done.stderr
        except subprocess.TimeoutExpired:
            code, out, err = -1, "", "killed: no end after the timeout"
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    tip = _TIP.search(out)
    wall = _WALL.search(out)
    outcome = _OUTCOME.search(out)
    message = outcome.group(1) if outcome else (err.strip().splitlines() or [""])[-1]
    return {"integrator": integrator, "exit": code, "cpu": cpu,
            "solver_wall": float(wall.group(1)) if wall else None,
            "tip": [float(tip.group(i)) for i in (2, 3, 4)] if tip else None,
            "outcome": message[:300]}


def _distance(a: list[float] | None, b: list[float] | None) -> float | None:
    if a is None or b is None:
        return None
    return sum((x - y) ** 2 for x, y in zip(a, b, strict=True)) ** 0.5


def markdown(report: dict) -> str:
    """The table: one row per case and integrator."""
    m = report["machine"]
    lines = ["# Which integrator for a scene that names none", "",
             f"Machine: {m.get('cpu', '?')}, {m.get('cores', '?')} cores; "
             + ", ".join(f"{k} {v}" for k, v in m.items() if k not in ("cpu", "cores")),
             "", f"`python benchmarks/default_integrator.py` (max_wall_time "
             f"{report['max_wall_time']:g} s per run). CPU: the whole `rodsim run` process "
             "(kernels, solve, error estimates, stability); solve: the summary's wall time; "
             "Δtip: distance of the first rod's tip from static's, from the printed six "
             "decimals (resolution 1e-6 m).", "",
             "| case | integrator | exit | CPU [s] | solve [s] | tip [m] | Δtip vs static [m] "
             "| outcome |", "|---|---|--:|--:|--:|---|--:|---|"]
    for case in report["cases"]:
        static = next((r["tip"] for r in case["runs"] if r["integrator"] == "static"), None)
        for run in case["runs"]:
            tip = ("(" + ", ".join(f"{v:.6f}" for v in run["tip"]) + ")") if run["tip"] else "—"
            delta = _distance(run["tip"], static) if run["exit"] == 0 else None
            wall = f"{run['solver_wall']:.3f}" if run["solver_wall"] is not None else "—"
            lines.append(f"| {case['label']} | {run['integrator']} | {run['exit']} | "
                         f"{run['cpu']:.1f} | {wall} | {tip} | "
                         f"{'—' if delta is None else f'{delta:.1e}'} | "
                         f"{run['outcome'].replace('|', '/')[:160]} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--user-scenes", type=Path, default=Path("/work/shared/user-scenes"))
    parser.add_argument("--output-dir", type=Path, default=HERE / "results")
    parser.add_argument("--max-wall-time", type=float, default=300.0)
    parser.add_argument("--group", choices=("all", "user", "robots"), default="all",
                        help="the user scenes, the robots written from the docs, or both")
    parser.add_argument("--merge", nargs="+", type=Path, default=[], metavar="JSON",
                        help="only write default-integrator.md/.json from these reports "
                        "(the groups run apart, one per core)")
    args = parser.parse_args(argv)
    if args.merge:
        reports = [json.loads(path.read_text()) for path in args.merge]
        merged = reports[0] | {"cases": [case for r in reports for case in r["cases"]]}
        write_report(merged, markdown(merged), args.output_dir / "default-integrator")
        return 0
    cases = []
    if args.group != "robots" and args.user_scenes.is_dir():
        cases += [(label, args.user_scenes / name, sets) for label, name, sets in USER_CASES]
    if args.group != "user":
        cases += [(label, ROBOTS / name, sets) for label, name, sets in ROBOT_CASES]
    report = {"machine": machine(), "max_wall_time": args.max_wall_time, "cases": []}
    run_case(cases[0][1], "static", cases[0][2], args.max_wall_time)  # compile the kernels
    stem = args.output_dir / ("default-integrator"
                              + (f"-{args.group}" if args.group != "all" else ""))
    for label, scene, sets in cases:
        runs = [run_case(scene, name, sets, args.max_wall_time) for name in INTEGRATORS]
        report["cases"].append({"label": label, "scene": scene.name, "set": list(sets),
                                "runs": runs})
        for run in runs:
            print(f"{label:32s} {run['integrator']:6s} exit {run['exit']} "
                  f"cpu {run['cpu']:7.1f} s  {run['tip']}  {run['outcome'][:90]}", flush=True)
        write_report(report, markdown(report), stem)  # after every case: nothing lost
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
