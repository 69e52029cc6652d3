"""The PyElastica side of ``rodsim bench pyelastica-dynamics``, run in its own process.

``python -m rodsim_bench.pyelastica_dynamics_worker`` reads a JSON list of jobs on stdin and
writes a JSON list of results on stdout. It imports PyElastica (``elastica``) and never
rodsim, so PyElastica can live in a folder of its own on ``PYTHONPATH`` (``pip install
--target DIR pyelastica==1.0.0``) and rodsim's environment stays without it.

A job is a clamped straight rod along +x (``CosseratRod.straight_rod`` with ``n_elem``
elements, normal +y; ``OneEndFixedBC`` on node 0 and element 0, as PyElastica's examples
clamp) stepped by ``PositionVerlet`` at the fixed step ``dt`` to ``t_end``, undamped. It
starts either

- straight, with the node velocities ``velocity_z`` along z (PyElastica's dynamic-cantilever
  example starts so), or
- at rest at its own equilibrium under the tip force ``tip_force``, found beforehand (not
  timed) by a run with the force and ``AnalyticalLinearDamper`` at the constant
  ``settle_damping`` for ``settle_time`` of simulated time (once per element count: the
  equilibrium does not depend on dt); the positions and directors
  found are copied into the undamped rod without the force (a release).

The tip is recorded at each of ``outputs`` (s), linearly interpolated between the two steps
around it. CPU (``time.process_time``) counts the stepping to ``t_end`` only (the settling
and the building excluded), the minimum of ``repeats`` runs. A first small job compiles (or
loads) numba's kernels before anything is timed.
"""

from __future__ import annotations

import json
import math
import sys
import time
from typing import Any

import numpy as np


def _simulator(job: dict[str, Any], *, force: bool, damping: float, dt: float):
    import elastica as ea

    class Simulator(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping):
        pass

    simulator = Simulator()
    rod = ea.CosseratRod.straight_rod(
        int(job["n_elem"]), np.zeros(3), np.array([1.0, 0.0, 0.0]),
        np.array([0.0, 1.0, 0.0]), job["length"], job["radius"], job["density"],
        youngs_modulus=job["youngs_modulus"], shear_modulus=job["shear_modulus"])
    simulator.append(rod)
    simulator.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,),
                                   constrained_director_idx=(0,))
    if force:
        simulator.add_forcing_to(rod).using(ea.EndpointForces, np.zeros(3),
                                            np.asarray(job["tip_force"], float),
                                            ramp_up_time=dt)
    if damping > 0.0:
        simulator.dampen(rod).using(ea.AnalyticalLinearDamper,
                                    uniform_damping_constant=damping, time_step=dt)
    simulator.finalize()
    return simulator, rod


def settled(job: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, dict[str, float]]:
    """(positions, directors) of the rod at rest under ``tip_force``, and how it settled."""
    import elastica as ea

    dt = np.float64(job["settle_dt"])
    simulator, rod = _simulator(job, force=True, damping=job["settle_damping"], dt=float(dt))
    stepper = ea.PositionVerlet()
    t = np.float64(0.0)
    started = time.process_time()
    for _ in range(int(math.ceil(job["settle_time"] / dt))):
        t = stepper.step(simulator, t, dt)
    speed = float(np.max(np.linalg.norm(rod.velocity_collection, axis=0)))
    return (rod.position_collection.copy(), rod.director_collection.copy(),
            {"settle_cpu_s": time.process_time() - started, "settle_final_speed": speed})


def run_job(job: dict[str, Any], start: tuple[np.ndarray, np.ndarray] | None
            ) -> tuple[float, int, list[list[float]], bool]:
    """One timed run: (CPU [s], steps, tip at each output, finite throughout)."""
    import elastica as ea

    dt = np.float64(job["dt"])
    simulator, rod = _simulator(job, force=False, damping=0.0, dt=float(dt))
    if start is not None:
        rod.position_collection[...] = start[0]
        rod.director_collection[...] = start[1]
    if job.get("velocity_z") is not None:
        rod.velocity_collection[2, :] = np.asarray(job["velocity_z"], float)
    stepper = ea.PositionVerlet()
    t = np.float64(0.0)
    tips: list[list[float]] = []
    steps, finite = 0, True
    started = time.process_time()
    for target in job["outputs"]:
        if target <= 0.0:
            tips.append(rod.position_collection[:, -1].tolist())
            continue
        count = max(0, int(math.floor((target - t) / dt)))
        for _ in range(count):
            t = stepper.step(simulator, t, dt)
        before, t_before = rod.position_collection[:, -1].copy(), t
        t = stepper.step(simulator, t, dt)
        steps += count + 1
        weight = (target - t_before) / dt
        tip = (1.0 - weight) * before + weight * rod.position_collection[:, -1]
        tips.append(tip.tolist())
        if not np.all(np.isfinite(tip)) or np.max(np.abs(tip)) > 100.0 * job["length"]:
            finite = False
            break
    return time.process_time() - started, steps, tips, finite


def run_jobs(jobs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    from importlib import metadata

    import elastica  # noqa: F401  (fails here, before any work, when it is missing)

    version = metadata.version("pyelastica")
    warm = dict(jobs[0], n_elem=8, outputs=[jobs[0]["outputs"][1]], velocity_z=None)
    run_job(warm, None)  # numba compiles or loads its kernels
    results = []
    equilibria: dict[int, tuple] = {}  # the settled rod per element count (dt-independent)
    for job in jobs:
        start, settle = None, {}
        if job.get("tip_force") is not None:
            if job["n_elem"] not in equilibria:
                equilibria[job["n_elem"]] = settled(job)
            positions, directors, settle = equilibria[job["n_elem"]]
            start = (positions, directors)
        runs = [run_job(job, start) for _ in range(int(job["repeats"]))]
        cpu = [r[0] for r in runs]
        _, steps, tips, finite = runs[-1]
        results.append({"key": job["key"], "cpu_s": min(cpu), "all_cpu_s": cpu,
                        "steps": steps, "tips": tips, "finite": finite,
                        "pyelastica_version": version, **settle})
        print(f"pyelastica job {job['key']}: {min(cpu):.2f} s", file=sys.stderr, flush=True)
    return results


def main() -> None:
    json.dump(run_jobs(json.load(sys.stdin)), sys.stdout)


if __name__ == "__main__":
    main()
