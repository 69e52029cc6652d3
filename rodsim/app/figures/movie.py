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
figure; ``--show`` leaves out the layers it does not name:
``rodsim.app.figures.layers.layers_left_out``). Each frame shows for ``FRAME_SECONDS``.

It is written as an mp4 (H.264, yuv420p) by ffmpeg through matplotlib's animation writer
(``matplotlib.animation.FFMpegWriter``), or as an animated GIF by Pillow (one adaptive
palette per frame), as ``rodsim.app.figures.movie_encoder`` chooses; a missing encoder is
a one-line PlotError before anything is drawn. Both are written atomically (a failed
encode leaves no file and keeps an older one). The same archive gives the same frames: the
mp4 is muxed with ffmpeg's bitexact flags and no metadata, so the same ffmpeg writes the
same bytes."""

from __future__ import annotations

import contextlib
import io
import json
import logging
import subprocess
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib as mpl
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from rodsim.app.figures.inverse import short_key
from rodsim.app.figures.movie_encoder import GIF, Encoder, encoder_for
from rodsim.app.figures.projections import projections
from rodsim.app.figures.scene_drawing import draw_parts
from rodsim.app.figures.state_series import MAX_FRAMES, colour_bar, coloured_states, evenly
from rodsim.app.figures.style import style
from rodsim.app.figures.writer import PlotError
from rodsim.io.atomic import write_atomic
from rodsim.io.cf_layout import key_variable
from rodsim.io.output import OutputError, check_target

__all__ = ["write_movie", "check_movie", "frames", "FRAME_SECONDS", "MAX_FRAMES",
           "MOVIE_DPI", "FFMPEG_ARGS", "frame_pixels", "draw_frames"]

#: How long each frame shows [s].
FRAME_SECONDS = 0.15

#: Pixels per inch of a frame.
MOVIE_DPI = 100


def frame_pixels(panels: int) -> tuple[int, int]:
    """A frame's width and height in pixels for one, two or three panels: 480 × 462,
    900 × 462, 1320 × 462. Even (H.264 in yuv420p needs it), and each p with p/100·100 ≥ p
    in floating point, so that matplotlib's movie writer keeps the size (460 would come out
    as 458 from its rounding to an even size) and the GIF and the mp4 frames match."""
    return 420 * panels + 60, 462


def _frame_inches(panels: int) -> tuple[float, float]:
    width, height = frame_pixels(panels)
    return width / MOVIE_DPI, height / MOVIE_DPI


#: ffmpeg's output options after the codec: H.264 in yuv420p (what players accept), an
#: mp4 container (the temporary's name ends in .tmp), and bitexact muxing without
#: metadata (no encoder version or date in the file).
FFMPEG_ARGS = ("-pix_fmt", "yuv420p", "-f", "mp4", "-fflags", "+bitexact",
               "-flags:v", "+bitexact", "-map_metadata", "-1")


def _dimension(ds: xr.Dataset) -> str:
    """The archive's frame dimension: ``step`` (track) or ``time`` (trajectory)."""
    kind = ds.attrs.get("kind")
    dimension = {"track": "step", "trajectory": "time"}.get(str(kind), "")
    if not dimension or dimension not in ds["position"].dims:
        raise PlotError("a movie is drawn from a track archive (rodsim track: one frame per "
                        "step) or a trajectory archive (rodsim simulate: one frame per "
                        "output time)")
    return dimension


def check_movie(ds: xr.Dataset, path: str | Path | None = None,
                encoder: Encoder | None = None) -> Encoder | None:
    """PlotError unless ``ds`` is a track or trajectory archive with a state to draw and,
    given the movie's ``path``, the path can be written and ``encoder`` (by default the one
    its suffix names, .mp4 or .gif) is there; returns that encoder."""
    dimension = _dimension(ds)
    if int(ds.sizes[dimension]) == 0:
        raise PlotError(f"the {ds.attrs['kind']} archive has no {dimension} to draw")
    if path is None:
        return None
    encoder = encoder or encoder_for(path)
    try:
        check_target(Path(path))
    except OutputError as exc:
        raise PlotError(str(exc)) from None
    return encoder


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


def draw_frames(ds: xr.Dataset, grab: Callable[[Figure], None], colour: str | None = None,
                hide: frozenset[str] = frozenset()) -> int:
    """Draw each frame of ``ds`` on one figure and hand it to ``grab`` once drawn; returns
    the number of frames. The figure is closed on return."""
    picked, captions = frames(ds)
    every = ds["position"].values
    states, colourings, scale = coloured_states(ds, picked, colour)
    extent = np.concatenate([s.points() for s in states])
    views = projections(extent)
    title = textwrap.fill(str(ds.attrs.get("title", "")), 44 * len(views))  # the frame's width
    with style():
        figure, axes = plt.subplots(1, len(views), figsize=_frame_inches(len(views)),
                                    squeeze=False, dpi=MOVIE_DPI, layout="constrained")
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
                grab(figure)
        finally:
            plt.close(figure)
    return len(picked)


def _write_gif(ds: xr.Dataset, temporary: Path, colour: str | None,
               hide: frozenset[str]) -> None:
    from PIL import Image

    pictures = []

    def grab(figure: Figure) -> None:
        buffer = io.BytesIO()  # through PNG: any backend, a notebook's too
        figure.savefig(buffer, format="png")
        buffer.seek(0)
        with Image.open(buffer) as picture:
            pictures.append(picture.convert("RGB").convert("P",
                                                           palette=Image.Palette.ADAPTIVE))

    draw_frames(ds, grab, colour, hide)
    pictures[0].save(temporary, format="GIF", save_all=True, append_images=pictures[1:],
                     duration=int(1000 * FRAME_SECONDS), loop=0)


def _write_mp4(ds: xr.Dataset, temporary: Path, colour: str | None, hide: frozenset[str],
               program: str) -> None:
    from matplotlib.animation import FFMpegWriter

    log = logging.getLogger("matplotlib.animation")  # ffmpeg's stderr: in the PlotError
    with contextlib.ExitStack() as stack:
        stack.callback(log.setLevel, log.level)
        log.setLevel(logging.ERROR)
        stack.enter_context(mpl.rc_context({"animation.ffmpeg_path": program}))
        rate: Any = 1.0 / FRAME_SECONDS  # frames per second, 6.67: ffmpeg reads a decimal
        writer = FFMpegWriter(fps=rate, codec="h264", extra_args=list(FFMPEG_ARGS))
        started = False

        def grab(figure: Figure) -> None:
            nonlocal started
            if not started:  # ffmpeg starts with the first frame's size
                stack.enter_context(writer.saving(figure, str(temporary), MOVIE_DPI))
                started = True
            writer.grab_frame()

        draw_frames(ds, grab, colour, hide)


def write_movie(ds: xr.Dataset, path: str | Path, colour: str | None = None,
                hide: frozenset[str] = frozenset(), encoder: Encoder | None = None) -> Path:
    """Write the movie of track or trajectory archive ``ds`` to ``path``: an mp4 or a GIF
    as its suffix says (PlotError for another suffix or kind of archive, or a missing
    encoder); ``encoder``: the one ``check_movie`` returned for ``path``; ``colour`` and
    ``hide``: see the module docstring."""
    encoder = encoder or check_movie(ds, path)
    assert encoder is not None
    path = Path(path)
    target = check_target(path)  # a symbolic link's target

    def write(temporary: Path) -> None:
        if encoder.format == GIF:
            _write_gif(ds, temporary, colour, hide)
        else:
            assert encoder.program is not None
            _write_mp4(ds, temporary, colour, hide, encoder.program)

    try:
        write_atomic(target, write, follow_umask=True)
    except subprocess.CalledProcessError as exc:
        said = (exc.stderr or "").strip().splitlines()
        raise PlotError(f"cannot write {path}: ffmpeg failed"
                        + (f": {said[-1]}" if said else "")) from None
    except OSError as exc:
        raise PlotError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path
