"""A movie of a track or trajectory archive (``rodsim plot --movie``): one frame per step
of a track (``rodsim track``), or per output time of a trajectory (``rodsim simulate``;
at most ``MAX_FRAMES``, evenly spaced, the first and the last among them), each the run
figure's drawing of that state (rods, tendons, obstacles, loads, contact forces:
``rodsim.app.figures.scene_drawing``) in x–y, and in x–z and y–z when the motion leaves
the x–y plane, with fixed limits around every frame; the title gives the ramped value or
the time. A track's loads are drawn with the step's values, a trajectory's with its
programs' values at the frame's time (``rodsim.app.figures.state_scene``). ``colour``
colours every frame's lines on one scale shared by all frames, with one colour bar;
``hide`` leaves layers out (as ``rodsim plot --colour`` and ``--hide`` do the run
figure). It is written as an animated GIF with Pillow (which matplotlib requires; a
missing Pillow is a one-line PlotError before any file is written), atomically."""

from __future__ import annotations

import io
import json
import textwrap
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from rodsim.app.figures.inverse import short_key
from rodsim.app.figures.projections import projections
from rodsim.app.figures.scene_drawing import draw_parts
from rodsim.app.figures.state_series import MAX_FRAMES, colour_bar, coloured_states, evenly
from rodsim.app.figures.style import style
from rodsim.app.figures.writer import PlotError
from rodsim.io.atomic import write_atomic
from rodsim.io.cf_layout import key_variable

__all__ = ["write_movie", "check_movie", "FRAME_SECONDS", "MAX_FRAMES"]

#: How long each frame shows [s].
FRAME_SECONDS = 0.15


def _encoder() -> Any:
    """Pillow's Image module (the GIF encoder), or a one-line PlotError saying how to get
    it."""
    try:
        from PIL import Image
    except ImportError:
        raise PlotError("a movie is written as a GIF by Pillow, which is not installed: "
                        "pip install pillow") from None
    return Image


def _dimension(ds: xr.Dataset) -> str:
    """The archive's frame dimension: ``step`` (track) or ``time`` (trajectory)."""
    kind = ds.attrs.get("kind")
    dimension = {"track": "step", "trajectory": "time"}.get(str(kind), "")
    if not dimension or dimension not in ds["position"].dims:
        raise PlotError("a movie is drawn from a track archive (rodsim track: one frame per "
                        "step) or a trajectory archive (rodsim simulate: one frame per "
                        "output time)")
    return dimension


def check_movie(ds: xr.Dataset) -> None:
    """PlotError unless ``ds`` is a track or trajectory archive with a state to draw and
    the GIF encoder is there."""
    dimension = _dimension(ds)
    if int(ds.sizes[dimension]) == 0:
        raise PlotError(f"the {ds.attrs['kind']} archive has no {dimension} to draw")
    _encoder()


def frames(ds: xr.Dataset) -> tuple[list[int], list[str]]:
    """The indices along the frame dimension drawn, and each frame's caption."""
    dimension = _dimension(ds)
    count = int(ds.sizes[dimension])
    if dimension == "step":
        ramp = next(iter(json.loads(ds.attrs["ramp_json"])))
        values = key_variable(ds, ramp).values
        unit = key_variable(ds, ramp).attrs.get("units", "")
        return list(range(count)), [f"step {k + 1} of {count}: {short_key(ramp)} = "
                                    f"{values[k]:.4g} {unit}" for k in range(count)]
    picked = evenly(count, MAX_FRAMES)
    times = ds["time"].values
    return picked, [f"t = {times[k]:.4g} s (output {k + 1} of {count})" for k in picked]


def write_movie(ds: xr.Dataset, path: str | Path, colour: str | None = None,
                hide: frozenset[str] = frozenset()) -> Path:
    """Write the GIF of track or trajectory archive ``ds`` to ``path`` (PlotError for
    another kind); ``colour`` and ``hide``: see the module docstring."""
    check_movie(ds)
    image = _encoder()
    picked, captions = frames(ds)
    every = ds["position"].values
    states, colourings, scale = coloured_states(ds, picked, colour)
    extent = np.concatenate([s.points() for s in states])
    views = projections(extent)
    title = textwrap.fill(str(ds.attrs.get("title", "")), 44 * len(views))  # the frame's width
    pictures = []
    with style():
        figure, axes = plt.subplots(1, len(views), figsize=(4.2 * len(views) + 0.6, 4.6),
                                    squeeze=False, dpi=100, layout="constrained")
        try:
            if colour:
                assert scale is not None and colourings[0] is not None
                colour_bar(figure, list(axes[0]), colourings[0], scale, shrink=0.8)
            for k, parts, caption, colours in zip(picked, states, captions, colourings,
                                                  strict=True):
                for panel, view in zip(axes[0], views, strict=True):
                    panel.clear()
                    draw_parts(panel, parts, view, extent=np.concatenate([extent, every[k]]),
                               hide=hide, colours=colours, scale=scale)
                figure.suptitle(f"{title}\n{caption}")
                buffer = io.BytesIO()  # through PNG: any backend, a notebook's too
                figure.savefig(buffer, format="png")
                buffer.seek(0)
                with image.open(buffer) as picture:
                    pictures.append(picture.convert("RGB").convert(
                        "P", palette=image.Palette.ADAPTIVE))
        finally:
            plt.close(figure)
    path = Path(path)
    write_atomic(path, lambda temporary: pictures[0].save(
        temporary, format="GIF", save_all=True, append_images=pictures[1:],
        duration=int(1000 * FRAME_SECONDS), loop=0), follow_umask=True)
    return path
