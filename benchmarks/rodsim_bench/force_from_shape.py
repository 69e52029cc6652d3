"""Benchmark ``force-from-shape``: how accurately `rodsim.fit` recovers a contact force from
the catheter's shape alone (issue 25; docs/inverse.md, "Force from shape").

The shipped scene ``tip-on-tissue`` (a catheter bent by a tip moment presses its tip on a
rigid frictionless plane) is solved with its plane: that gives the measured shape (every
control point with its rest arc length) and the true force, the contact term's force summed
over the nodes. The fit model is the same scene without the plane and with an unknown tip
force (``tip_load.force``, x and y, started at 0). Per noise level (Gaussian, standard
deviation sigma on x and y of every point; seeded draws): the RMS error of each component,
the mean standard error the fit reports, and the spread (standard deviation) of the
normalised errors (fit − truth)/SE, near 1 when the standard errors are right; fits that
raised are counted, not hidden. This is an accuracy benchmark: CPU time per fit is given
for scale only.

Writes ``force-from-shape-<size>.json`` and ``force-from-shape-<size>.md``. Nothing is
asserted (tests/test_force_from_shape.py checks the claims).
"""

from __future__ import annotations

import copy
import time
import tomllib
from pathlib import Path

import numpy as np

import rodsim
from rodsim.app.inverse.continuation import EquilibriumFailure
from rodsim.app.inverse.fit import FitError, Points
from rodsim.core.model import Model
from rodsim.core.scene import Scene, scene_paths
from rodsim.core.schema import SceneError
from rodsim.solvers.base import Progress
from rodsim_bench.machine import machine, write_report

__all__ = ["PARAMS", "force_model", "measured_shape", "run"]

#: Noise levels [m] (the catheter is 0.1 m long) and seeded draws per level.
SIZES = {"small": {"sigmas": (0.0, 5e-5), "draws": 2},
         "full": {"sigmas": (0.0, 1e-5, 5e-5, 1e-4, 2e-4, 5e-4), "draws": 8}}
PARAMS = ["tip_load.force[0]", "tip_load.force[1]"]
SEED = 2025


def measured_shape() -> tuple[dict, np.ndarray, np.ndarray, np.ndarray]:
    """The scene's table; the control points and their rest arc lengths at the equilibrium
    with the plane; the plane's force on the catheter, summed over the nodes [N]."""
    table = tomllib.loads(scene_paths()["tip-on-tissue"].read_text(encoding="utf-8"))
    scene = Scene.from_dict(copy.deepcopy(table))
    result = rodsim.solve(scene, "static")
    if not result.success:
        raise RuntimeError(f"tip-on-tissue did not solve: {result.message}")
    model = Model(scene, "numpy")
    full = model.full(result.state)
    contact = next(term for term in model.terms if term.name == "contact")
    rod = model.rods["catheter"]
    points = full[rod.layout.position_index].reshape(-1, 3)
    return table, points, rod.geometry.node_s, contact.nodal_forces(full).sum(axis=0)


def force_model(table: dict) -> Scene:
    """The fit model: the scene without its plane, with an unknown tip force started at 0."""
    table = copy.deepcopy(table)
    del table["obstacles"]
    rod = table["rods"]["catheter"]
    rod["terms"] = [*rod["terms"], "tip_load"]
    rod["tip_load"] = {"force": [0.0, 0.0, 0.0]}
    return Scene.from_dict(table)


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    config = SIZES[size]
    table, points, s, truth = measured_shape()
    scene = force_model(table)
    rng = np.random.default_rng(SEED)
    rows = []
    for level, sigma in enumerate(config["sigmas"]):
        progress(level / len(config["sigmas"]), f"force-from-shape: noise {sigma:g} m")
        errors, standard, failed, cpu = [], [], 0, []
        for _ in range(config["draws"] if sigma else 1):
            noisy = points + sigma * rng.standard_normal(points.shape) * [1.0, 1.0, 0.0]
            start = time.process_time()
            try:
                fit = rodsim.fit(scene, Points(noisy, s), PARAMS)
            except (FitError, SceneError, EquilibriumFailure):
                failed += 1
                continue
            cpu.append(time.process_time() - start)
            errors.append(fit.values - truth[:2])
            standard.append(fit.errors)
        e, se = np.array(errors), np.array(standard)
        rows.append({"sigma_m": sigma, "fits": len(errors), "failed": failed,
                     "rms_error_N": np.sqrt(np.mean(e**2, axis=0)).tolist(),
                     "mean_standard_error_N": se.mean(axis=0).tolist(),
                     "normalised_spread": (np.std(e / se, axis=0).tolist()
                                           if sigma and len(e) > 1 else None),
                     "cpu_per_fit_s": float(np.mean(cpu)) if cpu else None})
    report = {"benchmark": "force-from-shape", "size": size, "machine": machine(),
              "scene": "tip-on-tissue", "params": PARAMS, "seed": SEED,
              "true_force_N": truth[:2].tolist(), "rows": rows}
    m = report["machine"]
    lines = [
        f"# Force from shape: a contact force fitted to the catheter's shape ({size})", "",
        f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy {m['numpy']}, "
        f"commit {m['git_commit'][:10]}, {m['date']}.", "",
        f"tip-on-tissue (L = 0.1 m): true force on the tip ({truth[0]:.3g}, {truth[1]:.6g}) N "
        "(the plane's, normal to it); fitted: tip force x and y from 0, noise on x and y.", "",
        "| noise σ [mm] | σ / L | fits | RMS error F_x [mN] | RMS error F_y [mN] | "
        "mean SE F_x, F_y [mN] | spread of (fit − truth)/SE | CPU per fit [s] |",
        "|---|---|---|---|---|---|---|---|"]
    for row in rows:
        rms, se = np.array(row["rms_error_N"]) * 1e3, np.array(row["mean_standard_error_N"]) * 1e3
        spread = row["normalised_spread"]
        failed = f" ({row['failed']} failed)" if row["failed"] else ""
        lines.append(
            f"| {row['sigma_m'] * 1e3:g} | {row['sigma_m'] / 0.1:.0e} | {row['fits']}{failed} | "
            f"{rms[0]:.3g} | {rms[1]:.3g} | {se[0]:.3g}, {se[1]:.3g} | "
            + (f"{spread[0]:.2f}, {spread[1]:.2f}" if spread else "–")
            + f" | {row['cpu_per_fit_s']:.2f} |")
    lines.append("")
    return write_report(report, "\n".join(lines), output_dir / f"force-from-shape-{size}")
