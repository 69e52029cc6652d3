"""Tracking at control-loop rates (``rodsim bench tracking``): steps per second of CPU of
``rodsim.track`` on table3-catheter1, tendon force 0 → 4 N in 201 steps (static), measured
in one run against the same track with every step's model re-assembled
(:meth:`Model.with_scene`, what every step did before :meth:`Model.with_values`).

CPU time (``time.process_time``) of the whole track after a warm-up (kernels loaded), the
best of the repeats, both variants interleaved; the equilibria of the two are compared
(largest difference of any coordinate, every step). Outputs ``tracking-<size>.nc`` and
``tracking-<size>.md``.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import xarray as xr

import rodsim
from rodsim.core.model import Model
from rodsim.io.archive import write_dataset
from rodsim_bench.machine import machine

__all__ = ["run", "VARIANTS"]

SIZES = {"small": {"repeats": 1, "steps": 21}, "full": {"repeats": 5, "steps": 201}}
SCENE, KEY, START, STOP = "table3-catheter1", "tendons.tendon.tendon_actuation.force", 0.0, 4.0
VARIANTS = ("shared model (with_values)", "re-assembled model (with_scene)")


def _track(ramp: dict, variant: str):
    scene = rodsim.load_scene(SCENE)
    original = Model.with_values
    if variant == VARIANTS[1]:
        Model.with_values = Model.with_scene  # type: ignore[method-assign]
    try:
        start = time.process_time()
        path = rodsim.track(scene, ramp)
        return time.process_time() - start, path
    finally:
        Model.with_values = original  # type: ignore[method-assign]


def run(size: str, output_dir: str | Path, progress=None) -> list[Path]:
    setting = SIZES[size]
    steps, repeats = setting["steps"], setting["repeats"]
    ramp = {KEY: np.linspace(START, STOP, steps)}
    _track({KEY: ramp[KEY][:3]}, VARIANTS[0])  # warm-up: kernels loaded
    cpu = {variant: [] for variant in VARIANTS}
    paths = {}
    for repeat in range(repeats):
        for variant in VARIANTS:
            if progress is not None:
                progress(repeat / repeats, f"tracking: {variant} ({repeat + 1}/{repeats})")
            seconds, path = _track(ramp, variant)
            if not path.success:
                raise RuntimeError(f"{variant}: {path.message}")
            cpu[variant].append(seconds)
            paths[variant] = path
    best = {variant: min(values) for variant, values in cpu.items()}
    rate = {variant: (steps - 1) / best[variant] for variant in VARIANTS}
    difference = float(np.max(np.abs(np.array(paths[VARIANTS[0]].states)
                                      - np.array(paths[VARIANTS[1]].states))))
    iterations = {variant: int(sum(paths[variant].iterations)) for variant in VARIANTS}
    ds = xr.Dataset(
        {"cpu": (("variant", "repeat"), np.array([cpu[v] for v in VARIANTS]),
                 {"units": "s", "long_name": "CPU time of the whole track (cold step "
                  "included)"}),
         "steps_per_second": ("variant", [rate[v] for v in VARIANTS],
                              {"units": "1/s", "long_name": "steps per CPU second (best "
                               "repeat, the cold step included)"}),
         "newton_iterations": ("variant", [float(iterations[v]) for v in VARIANTS],
                               {"units": "1", "long_name": "Newton and chord iterations "
                                "of the whole track"})},
        coords={"variant": ("variant", list(VARIANTS), {"long_name": "how each step's "
                                                         "model is made"}),
                "repeat": ("repeat", np.arange(repeats), {"long_name": "repeat"})})
    ds.attrs = {"title": "rodsim: tracking rate", "benchmark": "tracking", "size": size,
                "scene": SCENE, "ramp": f"{KEY} {START} -> {STOP}, {steps} values",
                "largest_state_difference": difference,
                **{f"machine_{k}": v for k, v in machine().items()}}
    output = Path(output_dir) / f"tracking-{size}.nc"
    write_dataset(ds, output)
    lines = [f"# Tracking {SCENE}, {KEY} {START:g} → {STOP:g} N in {steps} steps ({size}, "
             f"best of {repeats}, CPU)", "",
             "| each step's model | CPU [s] | steps/s | ms/step | iterations |",
             "|---|--:|--:|--:|--:|"]
    lines += [f"| {v} | {best[v]:.3f} | {rate[v]:.0f} | {1e3 / rate[v]:.2f} | "
              f"{iterations[v]} |" for v in VARIANTS]
    lines += ["", f"Ratio: {rate[VARIANTS[0]] / rate[VARIANTS[1]]:.2f}×; largest difference "
              f"between the two tracks' states: {difference:.1e}.", "",
              "Machine: " + ", ".join(f"{k} {v}" for k, v in machine().items())]
    table = output.with_suffix(".md")
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return [output, table]
