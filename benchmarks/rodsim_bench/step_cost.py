"""Benchmark ``step-cost``: CPU per step of physical time (docs/dynamics.md, "What a step
costs"), before and after a change in one run.

The scenes: the steel rod of the ``dynamics`` benchmark (N = 11) released from a 0.1 N tip
force for half a period at 100 steps a period — undamped, Kelvin–Voigt damped (τ = 0.2
ms), with a drag (0.5 N·s/m²) — and the paper's semi-implicit Euler on the damped rod at
200 steps a period; tdcr-two-segment under a tension ramp of s1a, 3 → 3.5 N over 20 ms at
0.5 ms steps. A step's CPU (``time.process_time``) is timed around the run loop's step
(``trajectory.advance``: the step, its Newton iterations and the programs' models), per
step, the best of ``repeats`` runs after a warm-up run (the kernels compiled).

With ``RODSIM_BENCH_BASELINE=<revision>`` the same worker runs that revision's code
(``baseline.BaselineTree``), alternating with this checkout's, and the report says whether
every trajectory (positions, quaternions, the four energies at the output times) is
bit-identical to the baseline's.

Writes ``step-cost-<size>.json`` and ``step-cost-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

__all__ = ["run"]

#: Per size: the alternating rounds (each a fresh process per code), repeats per scene.
SIZES = {"small": {"rounds": 1, "repeats": 1}, "full": {"rounds": 3, "repeats": 3}}
SCENES = ("wire, undamped", "wire, Kelvin–Voigt", "wire, drag", "wire, paper's Euler",
          "tdcr-two-segment, ramp")
STEEL = {"length": 0.4, "radius": 1.2e-3, "youngs_modulus": 207e9, "density": 8000.0,
         "poisson_ratio": 0.3}
#: The steel rod's first period [s] (the ``dynamics`` benchmark's).
PERIOD = 0.0936768


def _wire(damping: dict | None) -> dict:
    table = {**STEEL, "nodes": 11, "terms": ["stretch", "bend_twist", "centerline",
                                             "tip_load"],
             "tip_load": {"force": [0.0, 0.0, 0.0], "mass": 0.0}}
    if damping:
        table["damping"] = damping
    return {"name": "steel-wire", "rods": {"wire": table}}


def _runs():
    import rodsim

    wire = {"output_dt": PERIOD / 20, "initial": {"tip_load.force": [0.0, -0.1, 0.0]}}
    kelvin = {"retardation_time": 2e-4}
    tension = "s1a.tendon_string.tension"
    return {
        SCENES[0]: lambda: rodsim.simulate(_wire(None), PERIOD / 2, step=PERIOD / 100, **wire),
        SCENES[1]: lambda: rodsim.simulate(_wire(kelvin), PERIOD / 2, step=PERIOD / 100,
                                           **wire),
        SCENES[2]: lambda: rodsim.simulate(_wire({"drag": 0.5}), PERIOD / 2,
                                           step=PERIOD / 100, **wire),
        SCENES[3]: lambda: rodsim.simulate(_wire(kelvin), PERIOD / 2, step=PERIOD / 200,
                                           integrator="paper", **wire),
        SCENES[4]: lambda: rodsim.simulate("tdcr-two-segment", 0.02, output_dt=0.002,
                                           step=5e-4, initial={tension: 3.0},
                                           program={tension: ([0.0, 0.02], [3.0, 3.5])}),
    }


def _worker(repeats: int) -> dict:
    """In a process of the code under test: each scene's best CPU per step [ms], its steps
    and a digest of its trajectory."""
    import numpy as np

    import rodsim.solvers.physical.trajectory as trajectory

    clock = {"depth": 0, "cpu": 0.0, "steps": 0}
    advance = trajectory.advance

    def timed(*args, **kwargs):
        if clock["depth"]:  # a halved step's halves: inside the step timed
            return advance(*args, **kwargs)
        clock["depth"] += 1
        start = time.process_time()
        try:
            return advance(*args, **kwargs)
        finally:
            clock["cpu"] += time.process_time() - start
            clock["steps"] += 1
            clock["depth"] -= 1

    trajectory.advance = timed
    out = {}
    for name, simulate in _runs().items():
        result = simulate()  # warm-up
        costs = []
        for _ in range(repeats):
            clock.update(cpu=0.0, steps=0)
            result = simulate()
            costs.append(1e3 * clock["cpu"] / clock["steps"])
        digest = hashlib.sha256()
        for field in ("positions", "quaternions", "kinetic_energy", "potential_energy",
                      "dissipated_energy", "work"):
            digest.update(np.ascontiguousarray(getattr(result, field)).tobytes())
        out[name] = {"ms_per_step": min(costs), "steps": int(clock["steps"]),
                     "digest": digest.hexdigest()}
    return out


def _measure(env: dict | None, repeats: int) -> dict:
    done = subprocess.run([sys.executable, __file__, str(repeats)], env=env,
                          capture_output=True, text=True, check=False, timeout=3600)
    if done.returncode != 0:
        raise RuntimeError(f"step-cost worker: {done.stderr.strip()[-500:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def run(size: str, output_dir: Path, progress) -> list[Path]:
    import os

    from rodsim_bench.baseline import BaselineTree, baseline_revision
    from rodsim_bench.machine import machine, write_report

    config = SIZES[size]
    root = Path(__file__).resolve().parents[2]
    ours_env = {**os.environ, "PYTHONPATH": str(root)}
    revision = baseline_revision()
    ours: list[dict] = []
    theirs: list[dict] = []
    with tempfile.TemporaryDirectory() as folder:
        tree = BaselineTree(revision, Path(folder)) if revision else None
        for k in range(config["rounds"]):
            progress(k / config["rounds"], f"step-cost: round {k + 1}")
            if tree is not None:
                theirs.append(_measure(tree.env(), config["repeats"]))
            ours.append(_measure(ours_env, config["repeats"]))
        baseline_commit = tree.commit if tree is not None else None
    rows = []
    for name in SCENES:
        row = {"scene": name, "steps": ours[0][name]["steps"],
               "ms_per_step": min(r[name]["ms_per_step"] for r in ours)}
        if theirs:
            row["baseline_ms_per_step"] = min(r[name]["ms_per_step"] for r in theirs)
            row["ratio"] = row["ms_per_step"] / row["baseline_ms_per_step"]
            row["bit_identical"] = all(r[name]["digest"] == ours[0][name]["digest"]
                                       for r in ours + theirs)
        rows.append(row)
    report = {"benchmark": "step-cost", "size": size, "machine": machine(),
              "rounds": config["rounds"], "repeats": config["repeats"],
              "baseline_commit": baseline_commit, "rows": rows}
    m = report["machine"]
    against = (f" against {baseline_commit[:10]} (RODSIM_BENCH_BASELINE), the two codes "
               "alternating in one run" if baseline_commit else "")
    lines = [f"# Physical time: CPU per step ({size})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}{against}. CPU per "
             f"step (the run loop's step, Newton and the programs' models), best of "
             f"{config['rounds']} processes × {config['repeats']} runs after a warm-up.", ""]
    if baseline_commit:
        lines += ["| scene | steps | baseline [ms/step] | this [ms/step] | this / baseline "
                  "| trajectories bit-identical |", "|---|--:|--:|--:|--:|---|"]
        lines += [f"| {r['scene']} | {r['steps']} | {r['baseline_ms_per_step']:.2f} | "
                  f"{r['ms_per_step']:.2f} | {r['ratio']:.2f} | "
                  f"{'yes' if r['bit_identical'] else 'NO'} |" for r in rows]
    else:
        lines += ["| scene | steps | ms/step |", "|---|--:|--:|"]
        lines += [f"| {r['scene']} | {r['steps']} | {r['ms_per_step']:.2f} |" for r in rows]
    lines.append("")
    return write_report(report, "\n".join(lines), output_dir / f"step-cost-{size}")


if __name__ == "__main__":
    print(json.dumps(_worker(int(sys.argv[1]))))
