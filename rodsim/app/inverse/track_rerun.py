"""A stored track run again (``rodsim rerun`` of a track archive): its scene, ramps,
integrator and integrator options read from the archive alone, and the recomputed shapes
compared with the stored ones (docs/inverse.md)."""

from __future__ import annotations

import dataclasses
import json
from typing import TYPE_CHECKING

import numpy as np

from rodsim.app.inverse.track import Track, track
from rodsim.solvers import registered_integrators

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["rerun_track"]


def rerun_track(dataset: xr.Dataset) -> tuple[Track, float]:
    """Re-run a stored track (its scene, ramps, integrator and integrator options) from the
    archive alone, over the steps it stores (a track stopped at an unstable step stores
    fewer than its ramps plan); returns the new track and the largest distance [m] between
    the stored and the recomputed control points over every stored step (infinite if the
    step counts differ, or if the integrator options the stored scene gives today are not
    the stored ones). Unstable steps are allowed: they are compared, not stopped at."""
    from rodsim.io.archive import ArchiveError, scene_of
    from rodsim.io.archive_schema import parse_json_object
    from rodsim.io.compare import largest_rod_distance

    ramps = parse_json_object(dataset.attrs["ramp_json"], "attribute 'ramp_json'")
    stored = dataset["position"].values
    steps = stored.shape[0]
    ramps = {key: list(values)[:max(steps, 2)] for key, values in ramps.items()}
    scene = scene_of(dataset)
    integrator = str(dataset.attrs["integrator"])
    options = parse_json_object(dataset.attrs["integrator_options"],
                                "attribute 'integrator_options'")
    today = json.loads(json.dumps(dataclasses.asdict(
        registered_integrators()[integrator].options_of(scene))))
    if options != today:
        changed = sorted(str(k) for k in set(options) | set(today)
                         if options.get(k) != today.get(k))
        raise ArchiveError("archive is inconsistent: integrator_options differ from the "
                           f"scene's solver options ({', '.join(changed)[:60]})")
    again = track(scene, ramps, integrator, allow_unstable=True)
    if again.steps < steps:
        return again, float("inf")
    rods = np.concatenate([[name] * rod.nodes for name, rod in again.model.rods.items()])
    return again, largest_rod_distance(stored, dataset["rod"].values,
                                       again.positions[:steps], rods)
