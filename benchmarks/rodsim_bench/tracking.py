"""Tracking at control-loop rates (``rodsim bench tracking``): steps per second of CPU of
``rodsim.track`` over 201 steps (static) on table3-catheter1 (tendon force 0 → 4 N) and on
tdcr-two-segment (segment 1's tendon s1a 0 → 3 N: string tendons, a conservative model),
each measured in one run against the same track with every step's model re-assembled
(:meth:`Model.with_scene`, what every step did before :meth:`Model.with_values`).

CPU time (``time.process_time``) of the whole track after a warm-up (kernels loaded), the
best of the repeats, the variants interleaved; the equilibria of the two variants are
compared (largest difference of any coordinate, every step). The stability verdict's share
(``rodsim.core.stability.assess``, every step's) is measured in the best repeat of the shared
model. Outputs ``tracking-<size>.nc`` and ``tracking-<size>.md``.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import xarray as xr

import rodsim
import rodsim.core.stability as stability
from rodsim.core.model import Model
from rodsim.io.archive import write_dataset
from rodsim_bench.machine import machine

__all__ = ["run", "VARIANTS", "CASES"]

SIZES = {"small": {"repeats": 1, "steps": 21}, "full": {"repeats": 5, "steps": 201}}
#: (scene, ramped key, start, stop [N]).
CASES = (("table3-catheter1", "tendons.tendon.tendon_actuation.force", 0.0, 4.0),
         ("tdcr-two-segment", "tendons.s1a.tendon_string.tension", 0.0, 3.0))
VARIANTS = ("shared model (with_values)", "re-assembled model (with_scene)")


def _track(scene_name: str, ramp: dict, variant: str):
    """(CPU of the whole track, CPU of its verdicts, the track)."""
    scene = rodsim.load_scene(scene_name)
    original, assess = Model.with_values, stability.assess
    spent = [0.0]

    def timed(*args, **kwargs):
        start = time.process_time()
        try:
            return assess(*args, **kwargs)
        finally:
            spent[0] += time.process_time() - start

    if variant == VARIANTS[1]:
        Model.with_values = Model.with_scene  # type: ignore[method-assign]
    stability.assess = timed  # type: ignore[assignment]
    try:
        start = time.process_time()
        path = rodsim.track(scene, ramp)
        return time.process_time() - start, spent[0], path
    finally:
        Model.with_values = original  # type: ignore[method-assign]
        stability.assess = assess  # type: ignore[assignment]


def run(size: str, output_dir: str | Path, progress=None) -> list[Path]:
    setting = SIZES[size]
    steps, repeats = setting["steps"], setting["repeats"]
    names = [case[0] for case in CASES]
    cpu = {(c, v): [] for c in names for v in VARIANTS}
    verdict = {c: np.inf for c in names}
    paths = {}
    for scene_name, key, start, stop in CASES:
        _track(scene_name, {key: np.linspace(start, stop, 3)}, VARIANTS[0])  # warm-up
    for repeat in range(repeats):
        for scene_name, key, start, stop in CASES:
            ramp = {key: np.linspace(start, stop, steps)}
            for variant in VARIANTS:
                if progress is not None:
                    progress(repeat / repeats, f"tracking: {scene_name}, {variant} "
                             f"({repeat + 1}/{repeats})")
                seconds, judged, path = _track(scene_name, ramp, variant)
                if not path.success:
                    raise RuntimeError(f"{scene_name}, {variant}: {path.message}")
                if variant == VARIANTS[0] and seconds <= min(cpu[scene_name, variant],
                                                             default=np.inf):
                    verdict[scene_name] = judged
                cpu[scene_name, variant].append(seconds)
                paths[scene_name, variant] = path
    best = {k: min(v) for k, v in cpu.items()}
    rate = {k: (steps - 1) / v for k, v in best.items()}
    difference = {c: float(np.max(np.abs(np.array(paths[c, VARIANTS[0]].states)
                                          - np.array(paths[c, VARIANTS[1]].states))))
                  for c in names}
    iterations = {k: int(sum(p.iterations)) for k, p in paths.items()}
    ds = xr.Dataset(
        {"cpu": (("scene", "variant", "repeat"),
                 np.array([[cpu[c, v] for v in VARIANTS] for c in names]),
                 {"units": "s", "long_name": "CPU time of the whole track (cold step "
                  "included)"}),
         "steps_per_second": (("scene", "variant"),
                              np.array([[rate[c, v] for v in VARIANTS] for c in names]),
                              {"units": "1/s", "long_name": "steps per CPU second (best "
                               "repeat, the cold step included)"}),
         "verdict_cpu": ("scene", np.array([verdict[c] for c in names]),
                         {"units": "s", "long_name": "CPU time of the stability verdicts in "
                          "the best repeat of the shared model"}),
         "newton_iterations": (("scene", "variant"),
                               np.array([[float(iterations[c, v]) for v in VARIANTS]
                                         for c in names]),
                               {"units": "1", "long_name": "Newton and chord iterations "
                                "of the whole track"}),
         "largest_state_difference": ("scene", np.array([difference[c] for c in names]),
                                      {"units": "1", "long_name": "largest difference of a "
                                       "coordinate between the two variants' tracks"})},
        coords={"scene": ("scene", names, {"long_name": "scene tracked"}),
                "variant": ("variant", list(VARIANTS), {"long_name": "how each step's "
                                                         "model is made"}),
                "repeat": ("repeat", np.arange(repeats), {"long_name": "repeat"})})
    ds.attrs = {"title": "rodsim: tracking rate", "benchmark": "tracking", "size": size,
                "ramps": "; ".join(f"{c[0]}: {c[1]} {c[2]} -> {c[3]}, {steps} values"
                                   for c in CASES),
                **{f"machine_{k}": v for k, v in machine().items()}}
    output = Path(output_dir) / f"tracking-{size}.nc"
    write_dataset(ds, output)
    lines = [f"# Tracking, {steps} steps ({size}, best of {repeats}, CPU)", "",
             "| scene, ramp | each step's model | CPU [s] | steps/s | ms/step | verdict "
             "ms/step | iterations |", "|---|---|--:|--:|--:|--:|--:|"]
    for scene_name, key, start, stop in CASES:
        for v in VARIANTS:
            share = (f"{1e3 * verdict[scene_name] / (steps - 1):.2f}" if v == VARIANTS[0]
                     else "")
            lines.append(f"| {scene_name}, {key} {start:g} → {stop:g} N | {v} | "
                         f"{best[scene_name, v]:.3f} | {rate[scene_name, v]:.0f} | "
                         f"{1e3 / rate[scene_name, v]:.2f} | {share} | "
                         f"{iterations[scene_name, v]} |")
    lines += [""] + [f"{c}: ratio {rate[c, VARIANTS[0]] / rate[c, VARIANTS[1]]:.2f}×; "
                     f"largest difference between the two tracks' states: "
                     f"{difference[c]:.1e}." for c in names]
    lines += ["", "Machine: " + ", ".join(f"{k} {v}" for k, v in machine().items())]
    table = output.with_suffix(".md")
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return [output, table]
