"""A movie of a track archive (``rodsim plot --movie``): one frame per step, each the run
figure's drawing of that step (rods, tendons, obstacles, loads, contact forces:
``rodsim.app.figures.scene_drawing``) in x–y, and in x–z and y–z when the track leaves
the x–y plane, with fixed limits around every step; the title gives the ramped value. It is
written as an animated GIF with Pillow (which matplotlib requires), atomically."""

from __future__ import annotations

import io
import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from rodsim.app.figures.inverse import PROJECTIONS, out_of_plane, short_key
from rodsim.app.figures.scene_drawing import draw_parts
from rodsim.app.figures.scene_parts import scene_parts
from rodsim.app.figures.style import style
from rodsim.app.figures.writer import PlotError
from rodsim.io.atomic import write_atomic
from rodsim.io.cf_layout import key_variable

__all__ = ["write_movie", "check_movie", "FRAME_SECONDS"]

#: How long each frame shows [s].
FRAME_SECONDS = 0.15


def check_movie(ds: xr.Dataset) -> None:
    """PlotError unless ``ds`` is a track archive with a step to draw."""
    if ds.attrs.get("kind") != "track" or "step" not in ds["position"].dims:
        raise PlotError("a movie is drawn from a track archive (rodsim track): one frame "
                        "per step")
    if int(ds.sizes["step"]) == 0:
        raise PlotError("the track archive has no step to draw")


def write_movie(ds: xr.Dataset, path: str | Path) -> Path:
    """Write the GIF of track archive ``ds`` to ``path`` (PlotError for another kind)."""
    from PIL import Image

    check_movie(ds)
    steps = int(ds.sizes["step"])
    every = ds["position"].values
    states = [scene_parts(ds, step) for step in range(steps)]
    extent = np.concatenate([s.points() for s in states])
    views = PROJECTIONS if out_of_plane(extent) else PROJECTIONS[:1]
    ramp = next(iter(json.loads(ds.attrs["ramp_json"])))
    values = key_variable(ds, ramp).values
    unit = key_variable(ds, ramp).attrs.get("units", "")
    frames = []
    with style():
        figure, axes = plt.subplots(1, len(views), figsize=(4.2 * len(views) + 0.6, 4.6),
                                    squeeze=False, dpi=100, layout="constrained")
        try:
            for step, parts in enumerate(states):
                for panel, view in zip(axes[0], views, strict=True):
                    panel.clear()
                    draw_parts(panel, parts, view, extent=np.concatenate([extent, every[
                        step]]))
                figure.suptitle(f"{ds.attrs.get('title', '')}\nstep {step + 1} of {steps}: "
                                f"{short_key(ramp)} = {values[step]:.4g} {unit}")
                buffer = io.BytesIO()  # through PNG: any backend, a notebook's too
                figure.savefig(buffer, format="png")
                buffer.seek(0)
                with Image.open(buffer) as image:
                    frames.append(image.convert("RGB").convert(
                        "P", palette=Image.Palette.ADAPTIVE))
        finally:
            plt.close(figure)
    path = Path(path)
    write_atomic(path, lambda temporary: frames[0].save(
        temporary, format="GIF", save_all=True, append_images=frames[1:],
        duration=int(1000 * FRAME_SECONDS), loop=0), follow_umask=True)
    return path
