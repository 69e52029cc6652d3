"""Benchmark ``modes``: the natural frequencies of a bent, tendon-loaded robot (issue 33's
aim: "the natural frequencies of tdcr-two-segment about a bent equilibrium: ≤ 20 ms").

Per scene, the equilibrium is solved once (``static``, not timed); then
``rodsim.modes(result, count)`` is timed as a user calls it — the model built for the
equilibrium's scene, its stiffness K and the physical mass factor assembled, K factored in
band storage, ARPACK on C = Lᵀ K⁻¹ L (docs/dynamics.md) — CPU time
(``time.process_time``), best of the repeats after one warm-up call.

Writes ``modes-<size>.json`` and ``modes-<size>.md``. Nothing is asserted.
"""

from __future__ import annotations

import time
from pathlib import Path

import rodsim
from rodsim.solvers.base import Progress
from rodsim_bench.machine import machine, write_report

__all__ = ["run"]

#: The aim of issue 33 [s].
AIM = 0.020
SIZES = {"small": {"scenes": ("tdcr-two-segment",), "repeats": 3, "count": 6},
         "full": {"scenes": ("tdcr-two-segment", "catheter-pull-ring", "table3-catheter1"),
                  "repeats": 20, "count": 6}}


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    config = SIZES[size]
    rows = []
    for k, name in enumerate(config["scenes"]):
        progress(k / len(config["scenes"]), f"modes: {name}")
        result = rodsim.solve(name, "static")
        modes = rodsim.modes(result, count=config["count"])  # warm-up
        best = float("inf")
        for _ in range(config["repeats"]):
            start = time.process_time()
            modes = rodsim.modes(result, count=config["count"])
            best = min(best, time.process_time() - start)
        rows.append({"scene": name, "unknowns": len(result.state), "count": config["count"],
                     "modes_s": best, "symmetric": modes.symmetric,
                     "frequencies_hz": [float(f) for f in modes.frequencies]})
    report = {"benchmark": "modes", "size": size, "machine": machine(), "aim_s": AIM,
              "rows": rows}
    m = report["machine"]
    lines = [f"# Natural frequencies about an equilibrium ({size})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. CPU of "
             "`rodsim.modes(result)`, the equilibrium solved before; best of "
             f"{config['repeats']}. Aim: ≤ {AIM * 1e3:.0f} ms on tdcr-two-segment.", "",
             "| scene | unknowns | modes | K symmetric | time [ms] | lowest frequencies [Hz] |",
             "|---|--:|--:|---|--:|---|"]
    for row in rows:
        lines.append(f"| {row['scene']} | {row['unknowns']} | {row['count']} | "
                     f"{'yes' if row['symmetric'] else 'no'} | {row['modes_s'] * 1e3:.2f} | "
                     + ", ".join(f"{f:.4g}" for f in row["frequencies_hz"][:4]) + " |")
    lines.append("")
    return write_report(report, "\n".join(lines), output_dir / f"modes-{size}")
