"""Which encoder writes a movie (``rodsim plot --movie``, ``rodsim.app.figures.movie``):
an mp4 (H.264) by ffmpeg through matplotlib's animation writer, or an animated GIF by
Pillow.

ffmpeg is looked for first in the ``imageio-ffmpeg`` package (a pip wheel that ships an
ffmpeg binary: ``pip install "rodsim[movie]"``; ``imageio_ffmpeg.get_ffmpeg_exe`` also
honours its ``IMAGEIO_FFMPEG_EXE`` variable), then as matplotlib's
``rcParams["animation.ffmpeg_path"]`` (``ffmpeg`` by default) on the PATH. Pillow comes
with matplotlib. A movie whose format is not asked for is an mp4 when an ffmpeg is found
and a GIF otherwise; each choice comes with a one-line note saying which and why (in
short words: where the ffmpeg came from, not its path, which ``Encoder.program`` holds). An mp4
asked for with no ffmpeg, or a GIF with no Pillow, is a one-line PlotError raised before
anything is drawn or written."""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import matplotlib as mpl

from rodsim.app.figures.errors import PlotError

__all__ = ["MP4", "GIF", "FORMATS", "Encoder", "find_ffmpeg", "choose_encoder",
           "encoder_for", "INSTALL_FFMPEG"]

MP4, GIF = "mp4", "gif"
#: The movie formats, the preferred first.
FORMATS = (MP4, GIF)

#: How to get an ffmpeg, in one phrase.
INSTALL_FFMPEG = 'pip install "rodsim[movie]" (imageio-ffmpeg) or put ffmpeg on the PATH'


@dataclass(frozen=True)
class Encoder:
    """A movie's format (``mp4`` or ``gif``), the ffmpeg program that encodes an mp4 (None
    for a GIF) and the one-line note saying which was chosen and why."""

    format: str
    program: str | None
    note: str


def find_ffmpeg() -> tuple[str, str] | None:
    """The ffmpeg program to use and where it was found, or None: imageio-ffmpeg's binary,
    else matplotlib's ``animation.ffmpeg_path`` found on the PATH (or as a path)."""
    try:
        import imageio_ffmpeg

        return str(imageio_ffmpeg.get_ffmpeg_exe()), "imageio-ffmpeg"
    except (ImportError, RuntimeError):
        pass
    configured = str(mpl.rcParams["animation.ffmpeg_path"])
    found = shutil.which(configured)
    return (found, "the PATH") if found else None


def _pillow() -> bool:
    try:
        from PIL import Image  # noqa: F401
    except ImportError:
        return False
    return True


def choose_encoder(requested: str | None = None) -> Encoder:
    """The encoder of a movie in format ``requested`` (``mp4``, ``gif``, or None: an mp4
    when an ffmpeg is found, else a GIF); PlotError when that format's encoder is
    missing."""
    if requested is not None and requested not in FORMATS:
        raise PlotError(f"unknown movie format {requested!r}; rodsim writes: "
                        + ", ".join(FORMATS))
    ffmpeg = find_ffmpeg() if requested != GIF else None
    if ffmpeg is not None:
        program, where = ffmpeg
        why = "as asked" if requested == MP4 else "ffmpeg found"
        return Encoder(MP4, program, f"movie as mp4 ({why}): ffmpeg from {where}")
    if requested == MP4:
        raise PlotError(f"an mp4 movie needs ffmpeg, which was not found: {INSTALL_FFMPEG}; "
                        "or ask for a GIF (--movie-format gif)")
    if not _pillow():
        raise PlotError("a movie is written as a GIF by Pillow, which is not installed: "
                        "pip install pillow" + ("" if requested == GIF else
                                                f" (or, for an mp4: {INSTALL_FFMPEG})"))
    if requested == GIF:
        return Encoder(GIF, None, "movie as GIF (as asked): Pillow")
    return Encoder(GIF, None, f"movie as GIF: no ffmpeg for an mp4 ({INSTALL_FFMPEG})")


def encoder_for(path: str | Path) -> Encoder:
    """The encoder named by the suffix of ``path`` (``.mp4`` or ``.gif``), or PlotError."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in FORMATS:
        raise PlotError(f"a movie's file ends in .mp4 or .gif, not {Path(path).name!r}")
    return choose_encoder(suffix)
