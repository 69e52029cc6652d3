"""Benchmark: which integrator should `track` use on a scene with obstacles? (`rodsim
track` with `static`, its default, and `ida`, the default of `rodsim run` on a scene with
obstacles that names none).

    python benchmarks/obstacle_track_integrator.py [--user-scenes DIR] [--output-dir DIR]
                                                   [--max-wall-time S]

Each case is one `rodsim track SCENE --ramp ... --integrator NAME` in a fresh process, as a
user runs it (error estimates, stability verdicts, archive and figure included), and one
`rodsim run SCENE --integrator ida` at the ramp's first value (its `--set`): the answer a
`run` of a scene that names no integrator gives, against which step 0 of each track (a cold
solve) is compared. Measured: the child's CPU time (user + system, from `getrusage`), the
exit code, the steps completed, the last step's tip and step 0's tip (from the archive).
The cases: the shipped contact scenes and the user scenes of `--user-scenes` (skipped if the
folder is absent). Every process is given `solver.max_wall_time` (default 300 s).

Writes `obstacle-track-integrator.json` and `.md` to the output directory (default
benchmarks/results), after every case. A benchmark, not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import re
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr

sys.path.insert(0, str(Path(__file__).resolve().parent))
from rodsim_bench.machine import machine, write_report  # noqa: E402

HERE = Path(__file__).resolve().parent
INTEGRATORS = ("static", "ida")

#: (label, scene: a shipped name or a file name in --user-scenes, the ramp, --set values,
#: whether the scene is a user scene).
CASES = (
    ("tip-on-tissue, E 60 → 30 MPa", "tip-on-tissue", "rods.catheter.youngs_modulus=6e7:3e7:11",
     (), False),
    ("vessel-insertion, 0 → 60 mm", "vessel-insertion",
     "rods.catheter.base.insertion=0:0.06:61", (), False),
    ("vessel-insertion, μ = 0.3, 0 → 30 mm", "vessel-insertion",
     "rods.catheter.base.insertion=0:0.03:16", ("obstacles.vessel.friction=0.3",), False),
    ("guidewire2, 0 → 120 mm", "guidewire2.toml", "rods.wire.base.insertion=0:0.12:121", (),
     True),
    ("guidewire (rest through the wall), 0 → 10 mm", "guidewire.toml",
     "rods.wire.base.insertion=0:0.01:2", (), True),
)

_FAILURE = re.compile(r"^rodsim: (.*)$", re.M)


def _child(command: list[str], cwd: Path, max_wall: float) -> tuple[int, str, str, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        done = subprocess.run(command, cwd=cwd, capture_output=True, text=True,
                              timeout=4 * max_wall + 300)
        code, out, err = done.returncode, done.stdout, done.stderr
    except subprocess.TimeoutExpired:
        code, out, err = -1, "", "killed: no end after the timeout"
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return code, out, err, cpu


def first_value(ramp: str) -> str:
    """`KEY=A:B:N` → `KEY=A`."""
    key, values = ramp.split("=", 1)
    return f"{key}={values.split(':')[0]}"


def run_case(scene: str, cwd: Path, ramp: str, sets: tuple[str, ...], integrator: str,
             max_wall: float) -> dict:
    """One `rodsim track` (integrator given) or, with ``ramp`` '', one `rodsim run` at the
    ramp's first value with ``integrator``."""
    with tempfile.TemporaryDirectory() as tmp:
        archive = Path(tmp) / "out.nc"
        command = [sys.executable, "-m", "rodsim", "track" if ramp else "run", scene,
                   "--integrator", integrator, "-o", str(archive),
                   "--set", f"max_wall_time={max_wall}"]
        command += ["--ramp", ramp] if ramp else []
        for value in sets:
            command += ["--set", value]
        code, _, err, cpu = _child(command, cwd, max_wall)
        steps, first, last = 0, None, None
        if archive.exists():
            with xr.open_dataset(archive) as ds:
                position = ds["position"].values
            if position.ndim == 3:  # a track: (step, node, axis)
                steps, first, last = len(position), position[0, -1], position[-1, -1]
            else:
                steps, first, last = 1, position[-1], position[-1]
    failure = _FAILURE.findall(err)
    return {"integrator": integrator, "command": "track" if ramp else "run", "exit": code,
            "cpu": cpu, "steps": steps,
            "first_tip": None if first is None else [float(v) for v in first],
            "last_tip": None if last is None else [float(v) for v in last],
            "message": (failure[-1] if failure else "")[:300]}


def _tip(values: list[float] | None) -> str:
    return "—" if values is None else "(" + ", ".join(f"{v:.6f}" for v in values) + ")"


def markdown(report: dict) -> str:
    m = report["machine"]
    lines = ["# Which integrator for `track` on a scene with obstacles", "",
             f"Machine: {m.get('cpu', '?')}, {m.get('cores', '?')} cores; "
             + ", ".join(f"{k} {v}" for k, v in m.items() if k not in ("cpu", "cores")),
             "", f"`python benchmarks/obstacle_track_integrator.py` (max_wall_time "
             f"{report['max_wall_time']:g} s per process). CPU: the whole process (kernels, "
             "solves, error estimates, stability, archive and figure). `run ida`: `rodsim "
             "run` at the ramp's first value with ida, the integrator `run` gives a scene "
             "with obstacles that names none; Δ step 0: distance of the track's step-0 tip "
             "from that run's tip.", "",
             "| case | command | integrator | exit | CPU [s] | steps | step-0 tip [m] | "
             "Δ step 0 vs run ida [m] | last tip [m] | message |",
             "|---|---|---|--:|--:|--:|---|--:|---|---|"]
    for case in report["cases"]:
        reference = next((r["first_tip"] for r in case["runs"] if r["command"] == "run"
                          and r["exit"] == 0), None)
        for run in case["runs"]:
            delta = "—"
            if run["command"] == "track" and reference is not None and run["first_tip"]:
                delta = f"{float(np.linalg.norm(np.subtract(run['first_tip'], reference))):.1e}"
            lines.append(f"| {case['label']} | {run['command']} | {run['integrator']} | "
                         f"{run['exit']} | {run['cpu']:.1f} | {run['steps']} | "
                         f"{_tip(run['first_tip'])} | {delta} | {_tip(run['last_tip'])} | "
                         f"{run['message'].replace('|', '/')[:160]} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--user-scenes", type=Path, default=Path("/work/shared/user-scenes"))
    parser.add_argument("--output-dir", type=Path, default=HERE / "results")
    parser.add_argument("--max-wall-time", type=float, default=300.0)
    args = parser.parse_args(argv)
    report = {"machine": machine(), "max_wall_time": args.max_wall_time, "cases": []}
    run_case("tip-on-tissue", HERE, "", (), "static", args.max_wall_time)  # compile kernels
    for label, scene, ramp, sets, user in CASES:
        if user and not args.user_scenes.is_dir():
            continue
        cwd = args.user_scenes if user else HERE
        runs = [run_case(scene, cwd, "", (*sets, first_value(ramp)), "ida",
                         args.max_wall_time)]
        runs += [run_case(scene, cwd, ramp, sets, name, args.max_wall_time)
                 for name in INTEGRATORS]
        report["cases"].append({"label": label, "scene": scene, "ramp": ramp,
                                "set": list(sets), "runs": runs})
        for run in runs:
            print(f"{label:40s} {run['command']:5s} {run['integrator']:6s} exit {run['exit']} "
                  f"cpu {run['cpu']:6.1f} s steps {run['steps']:3d} {run['message'][:80]}",
                  flush=True)
        write_report(report, markdown(report), args.output_dir / "obstacle-track-integrator")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
