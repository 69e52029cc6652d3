"""The scene of one state of an archive, with the values it was solved with: a track's
ramped values at its step (``ramp_json``), a trajectory's programmed values at its output
time (``program_json``, each program evaluated at that time: rodsim/core/program.py);
the stored ``scene_json`` of any other archive. A figure draws a state's loads and
tendon tensions from it (``rodsim.app.figures.scene_parts``,
``rodsim.app.figures.colouring``)."""

from __future__ import annotations

import json

import xarray as xr

from rodsim.app.figures.errors import PlotError
from rodsim.app.inverse.parameter_keys import numeric_key, scene_with
from rodsim.core.program import program_entry
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.io.archive_schema import stored_scene

__all__ = ["state_scene"]


def state_scene(ds: xr.Dataset, step: int | None = None) -> Scene:
    """The scene of state ``step`` of ``ds`` (a track's step or a trajectory's output time
    of that index, the last by default; see the module docstring). ``PlotError`` (one
    line) when the ramp or the program does not fit the scene (a damaged archive)."""
    scene = stored_scene(ds.attrs["scene_json"], "attribute 'scene_json'")
    kind = ds.attrs.get("kind")
    index = -1 if step is None else step
    try:
        if kind == "track" and "ramp_json" in ds.attrs:
            what = "ramp_json"
            values = {name: float(row[index])
                      for name, row in json.loads(ds.attrs[what]).items()}
        elif kind == "trajectory" and "program_json" in ds.attrs and ds.sizes.get("time"):
            what = "program_json"
            t = float(ds["time"].values[index])
            values = {name: program_entry(name, raw).value(t)
                      for name, raw in json.loads(ds.attrs[what]).items()}
        else:
            return scene
        if not values:
            return scene
        keys = [numeric_key(scene, name) for name in values]
        return scene_with(scene, keys, list(values.values()))
    except (SceneError, IndexError, TypeError, ValueError) as exc:
        raise PlotError(f"the archive's {what} does not fit its scene: {exc}") from None
