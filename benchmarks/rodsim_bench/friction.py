"""Benchmark ``friction``: tendon friction's cost (issue 34; docs/tendon.md, "Friction").

On ``tdcr-two-segment`` (ramping s1a, 3 N) and ``catheter-pull-ring`` (wire_up, 1 N), with
every tendon's ``tendon_string.friction`` = μ for μ in 0, 0.1, 0.3:

- a pull–release cycle by ``rodsim.track``: the ramped tension from 0.1 T_max up to T_max
  and back to 0.1 T_max (35 steps at ``--size full``), its steps per second of CPU and its
  Newton iterations per step;
- one cold ``static`` solve of the scene (the shipped tension), its CPU time and Newton
  iterations, and the ratio of its time to the frictionless solve's (μ = 0 is the
  frictionless tendon bitwise);
- the same with every tendon's ``tendon_string.exact_jacobian`` on (μ = 0.3, and 0.1 at
  ``--size full``): the Jacobian exact on the scenes' 3-D and S-shaped paths (one dense
  element per tendon), its Newton iterations against the default's.

CPU time (``time.process_time``) after a warm-up (kernels compiled or loaded), the best of
the repeats. Writes ``friction-<size>.json`` and ``friction-<size>.md``. Nothing is
asserted.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import rodsim
from rodsim.solvers.base import Progress
from rodsim_bench.machine import machine, write_report

__all__ = ["CASES", "SIZES", "run"]

#: scene -> (its tendons, the ramped tendon, T_max [N]).
CASES = {"tdcr-two-segment": (("s1a", "s1b", "s1c", "s2a", "s2b", "s2c"), "s1a", 3.0),
         "catheter-pull-ring": (("wire_up", "wire_down"), "wire_up", 1.0)}
SIZES = {"small": {"repeats": 1, "steps": 11, "frictions": (0.0, 0.3), "exact": (0.3,)},
         "full": {"repeats": 3, "steps": 35, "frictions": (0.0, 0.1, 0.3),
                  "exact": (0.1, 0.3)}}


def cycle(t_max: float, steps: int) -> np.ndarray:
    """The ramped tension: 0.1 T_max → T_max → 0.1 T_max in ``steps`` values."""
    up = (steps + 1) // 2
    rising = np.linspace(0.1 * t_max, t_max, up)
    return np.concatenate([rising, rising[::-1][1:steps - up + 1]])


def _best(job, repeats: int):
    """(least CPU seconds over ``repeats`` after a warm-up, the last outcome)."""
    outcome = job()
    best = np.inf
    for _ in range(repeats):
        start = time.process_time()
        outcome = job()
        best = min(best, time.process_time() - start)
    return best, outcome


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    config = SIZES[size]
    rows = []
    jobs = [(name, mu, False) for name in CASES for mu in config["frictions"]]
    jobs += [(name, mu, True) for name in CASES for mu in config["exact"]]
    for k, (name, mu, exact) in enumerate(jobs):
        progress(k / len(jobs), f"friction: {name}, mu = {mu:g}{', exact' * exact}")
        tendons, ramped, t_max = CASES[name]
        scene = rodsim.load_scene(
            name, [f"tendons.{t}.tendon_string.friction={mu!r}" for t in tendons]
            + [f"tendons.{t}.tendon_string.exact_jacobian=true" for t in tendons if exact])
        key = f"tendons.{ramped}.tendon_string.tension"
        values = cycle(t_max, config["steps"])
        track_cpu, track = _best(lambda scene=scene, key=key, values=values: rodsim.track(
            scene, {key: values}, estimates=False), config["repeats"])
        solve_cpu, result = _best(lambda scene=scene: rodsim.solve(scene, "static"),
                                  config["repeats"])
        rows.append({"scene": name, "friction": mu, "exact_jacobian": exact,
                     "steps": len(values),
                     "track_success": bool(track.success),
                     "track_cpu_s": track_cpu, "steps_per_second": len(values) / track_cpu,
                     "track_newton_per_step": float(np.mean(track.iterations)),
                     "solve_success": bool(result.success), "solve_cpu_s": solve_cpu,
                     "solve_newton": float(result.stats.get("newton_iters", np.nan)),
                     "track_newton": int(np.sum(track.iterations))})
    for row in rows:
        plain = next(r for r in rows if r["scene"] == row["scene"] and r["friction"] == 0.0)
        row["solve_ratio"] = row["solve_cpu_s"] / plain["solve_cpu_s"]
    report = {"benchmark": "friction", "size": size, "machine": machine(),
              "repeats": config["repeats"], "rows": rows}
    return write_report(report, markdown(report), output_dir / f"friction-{size}")


def markdown(report: dict) -> str:
    m = report["machine"]
    lines = [f"# Tendon friction: pull–release cycles and static solves ({report['size']})",
             "", f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. CPU (process) time, "
             f"the best of {report['repeats']} after a warm-up.", "",
             "| scene | μ | exact Jacobian | cycle steps | steps/s | Newton / step | "
             "static [ms] | static Newton | static / frictionless |",
             "|---|---|---|---|---|---|---|---|---|"]
    for row in report["rows"]:
        failed = "" if row["track_success"] and row["solve_success"] else " (failed)"
        exact = "yes" if row.get("exact_jacobian") else "no"
        lines.append(f"| {row['scene']}{failed} | {row['friction']:g} | {exact} | "
                     f"{row['steps']} | "
                     f"{row['steps_per_second']:.0f} | {row['track_newton_per_step']:.1f} | "
                     f"{row['solve_cpu_s'] * 1e3:.1f} | {row['solve_newton']:.0f} | "
                     f"{row['solve_ratio']:.2f} |")
    return "\n".join(lines) + "\n"
