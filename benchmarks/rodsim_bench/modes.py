"""Benchmark ``modes``: the natural frequencies of a bent, tendon-loaded robot (issue 33's
aim: "the natural frequencies of tdcr-two-segment about a bent equilibrium: ≤ 20 ms").

Per scene, the equilibrium is solved once (``static``, not timed); then
``rodsim.modes(result, count)`` is timed as a user calls it — the model built for the
equilibrium's scene, its stiffness K and the physical mass factor assembled, K factored in
band storage, ARPACK on C = Lᵀ K⁻¹ L (docs/dynamics.md) — CPU time
(``time.process_time``), best of the repeats after one warm-up call. Then the same with
the scene's rods damped (Kelvin–Voigt τ = 1 ms and a drag of 0.1 N·s/m²): the damped
roots of the quadratic eigenproblem besides (rodsim/core/damped_vibration.py).

Writes ``modes-<size>.json`` and ``modes-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import copy
import time
from pathlib import Path

import rodsim
from rodsim.core.scene import Scene
from rodsim.solvers.base import Progress
from rodsim_bench.machine import machine, write_report

__all__ = ["run"]

#: The aim of issue 33 [s].
AIM = 0.020
#: The damping of the damped variant of each scene (every rod).
DAMPING = {"retardation_time": 1e-3, "drag": 0.1}


def _best(result: object, count: int, repeats: int) -> tuple[float, object]:
    """The least CPU time of ``rodsim.modes(result, count)`` over ``repeats`` calls after a
    warm-up, and the modes."""
    modes = rodsim.modes(result, count=count)  # warm-up
    best = float("inf")
    for _ in range(repeats):
        start = time.process_time()
        modes = rodsim.modes(result, count=count)
        best = min(best, time.process_time() - start)
    return best, modes
SIZES = {"small": {"scenes": ("tdcr-two-segment",), "repeats": 3, "count": 6},
         "full": {"scenes": ("tdcr-two-segment", "catheter-pull-ring", "table3-catheter1"),
                  "repeats": 20, "count": 6}}


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    config = SIZES[size]
    rows = []
    for k, name in enumerate(config["scenes"]):
        progress(k / len(config["scenes"]), f"modes: {name}")
        result = rodsim.solve(name, "static")
        best, modes = _best(result, config["count"], config["repeats"])
        data = copy.deepcopy(rodsim.load_scene(name).data)
        for table in data["rods"].values():
            table["damping"] = dict(DAMPING)
        damped_result = rodsim.solve(Scene.from_dict(data), "static")
        damped_best, damped = _best(damped_result, config["count"], config["repeats"])
        rows.append({"scene": name, "unknowns": len(result.state), "count": config["count"],
                     "modes_s": best, "damped_modes_s": damped_best,
                     "symmetric": modes.symmetric,
                     "frequencies_hz": [float(f) for f in modes.frequencies],
                     "damping_ratios": [float(z) for z in damped.damping_ratios]})
    report = {"benchmark": "modes", "size": size, "machine": machine(), "aim_s": AIM,
              "rows": rows}
    m = report["machine"]
    lines = [f"# Natural frequencies about an equilibrium ({size})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. CPU of "
             "`rodsim.modes(result)`, the equilibrium solved before; best of "
             f"{config['repeats']}. Aim: ≤ {AIM * 1e3:.0f} ms on tdcr-two-segment. Damped: "
             f"every rod with τ = {DAMPING['retardation_time']:g} s and drag "
             f"{DAMPING['drag']:g} N·s/m², the damped roots besides.", "",
             "| scene | unknowns | modes | K symmetric | time [ms] | damped [ms] | lowest "
             "frequencies [Hz] | damping ratios |",
             "|---|--:|--:|---|--:|--:|---|---|"]
    for row in rows:
        lines.append(f"| {row['scene']} | {row['unknowns']} | {row['count']} | "
                     f"{'yes' if row['symmetric'] else 'no'} | {row['modes_s'] * 1e3:.2f} | "
                     f"{row['damped_modes_s'] * 1e3:.2f} | "
                     + ", ".join(f"{f:.4g}" for f in row["frequencies_hz"][:4]) + " | "
                     + ", ".join(f"{z:.3g}" for z in row["damping_ratios"][:4]) + " |")
    lines.append("")
    return write_report(report, "\n".join(lines), output_dir / f"modes-{size}")
