"""Benchmark ``contact``: insertion of the shipped ``vessel-insertion`` catheter along its
csv vessel with ``track`` (warm-started static steps), and the share of one evaluation that
contact takes (docs/contact.md).

- steps per second: CPU (process) time of ``track`` over the insertion ramp 0 → 60 mm in
  201 steps (``full``; 51 in ``small``), model assembly included, kernels compiled and
  cached by a warm-up; minimum over the repeats;
- contact share: CPU time of the compiled force + Jacobian evaluation of the model at the
  last step's state, with the contact term and without it (the same model with its contact
  term dropped), each the mean over many calls; the contact term includes its search (the
  warm-started nearest-point walk along the centerline).

Writes ``contact-<size>.json`` and ``contact-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import rodsim
from rodsim.app.inverse.track import track
from rodsim.core.model import Model
from rodsim.solvers.base import Progress
from rodsim_bench.machine import machine, write_report

__all__ = ["run"]

SIZES = {"small": {"steps": 51, "repeats": 1, "calls": 200},
         "full": {"steps": 201, "repeats": 3, "calls": 2000}}
KEY = "rods.catheter.base.insertion"


def _evaluation_time(model: Model, x: np.ndarray, calls: int) -> float:
    model.evaluate(x)  # warm-up
    start = time.process_time()
    for _ in range(calls):
        model.evaluate(x)
    return (time.process_time() - start) / calls


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    config = SIZES[size]
    scene = rodsim.load_scene("vessel-insertion")
    values = np.linspace(0.0, 0.06, config["steps"])
    track(scene, {KEY: values[:3]})  # warm-up: kernels compiled or loaded
    best = np.inf
    for k in range(config["repeats"]):
        progress(k / (config["repeats"] + 1), "contact: insertion track")
        start = time.process_time()
        path = track(scene, {KEY: values})
        best = min(best, time.process_time() - start)
    progress(config["repeats"] / (config["repeats"] + 1), "contact: evaluation share")
    end = Model(scene.with_values({KEY: float(values[-1])}))
    x = end.state_of(path.states[-1])
    with_contact = _evaluation_time(end, x, config["calls"])
    without = end.with_terms([t for t in end.terms if t.name != "contact"])
    without_contact = _evaluation_time(without, x, config["calls"])
    report = {"benchmark": "contact", "size": size, "machine": machine(),
              "steps": config["steps"], "success": bool(path.success),
              "track_cpu_s": best, "steps_per_s": config["steps"] / best,
              "nodes": scene.rods["catheter"].nodes,
              "evaluation_s": with_contact, "evaluation_without_contact_s": without_contact,
              "contact_share": (with_contact - without_contact) / with_contact}
    m = report["machine"]
    status = "all converged" if report["success"] else "FAILED"
    text = "\n".join([
        f"# Contact: insertion along a csv vessel ({size})", "",
        f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy {m['numpy']}, "
        f"commit {m['git_commit'][:10]}, {m['date']}.", "",
        "| quantity | value |", "|---|---|",
        f"| track steps (0 → 60 mm) | {report['steps']} ({status}) |",
        f"| track CPU time (min of {config['repeats']}) | {best:.3f} s |",
        f"| steps per second | {report['steps_per_s']:.0f} |",
        f"| one force + Jacobian evaluation, N = {report['nodes']} | "
        f"{with_contact * 1e6:.1f} µs |",
        f"| the same without the contact term | {without_contact * 1e6:.1f} µs |",
        f"| contact's share of an evaluation (search included) | "
        f"{100 * report['contact_share']:.0f} % |",
        ""])
    return write_report(report, text, output_dir / f"contact-{size}")
