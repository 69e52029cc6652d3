"""Where figures go: the formats matplotlib (and the 3-D view) can write, the checks of an
output stem before anything is drawn, and the write of each format through the package's one
atomic writer (``rodsim.io.atomic.write_atomic``)."""

from __future__ import annotations

import io
import os
from collections.abc import Iterable
from pathlib import Path

import matplotlib.pyplot as plt
from matplotlib.figure import Figure

from rodsim.app.figures import view3d
from rodsim.app.figures.errors import PlotError
from rodsim.app.figures.style import DPI
from rodsim.io.atomic import write_atomic
from rodsim.io.output import OutputError, check_target

__all__ = ["HTML", "PlotError", "supported_formats", "check_output", "write_figure",
           "html_target"]

#: The format of the interactive 3D view (rodsim/app/figures/view3d.py, plotly).
HTML = "html"


def supported_formats() -> list[str]:
    """The file formats matplotlib can write (``png``, ``pdf``, ``svg``, …)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return sorted(FigureCanvasBase.get_supported_filetypes())


def check_output(stem: str | Path, formats: Iterable[str]) -> list[str]:
    """Validate the formats and the output folder before drawing anything.

    Returns the formats, lower-cased, without duplicates; raises ``PlotError`` for an
    unknown format, a stem that names a folder, or a folder that is missing or where no file
    can be created.
    """
    wanted: list[str] = []
    for fmt in formats:
        fmt = fmt.strip().lower().lstrip(".")
        if fmt and fmt not in wanted:
            wanted.append(fmt)
    if not wanted:
        raise PlotError("no figure format given (e.g. --format png,pdf)")
    known = supported_formats()
    unknown = [fmt for fmt in wanted if fmt not in known and fmt != HTML]
    if unknown:
        raise PlotError(f"unknown figure format {unknown[0]!r}; matplotlib writes: "
                        + ", ".join(known) + f" (and {HTML}: the interactive 3D view)")
    if HTML in wanted and not view3d.available():
        raise PlotError(view3d.MISSING)
    text = str(stem)
    if not text or text.endswith(("/", os.sep)):
        raise PlotError(f"output {text!r} must name a file stem (e.g. figures/fig6), "
                        "not a folder")
    for fmt in wanted:  # the target rules of rodsim/io/output.py: folders, devices refused
        try:
            check_target(Path(f"{text}.{fmt}"))
        except OutputError as exc:
            raise PlotError(str(exc)) from None
    return wanted


def html_target(stem: str | Path) -> Path:
    try:
        return check_target(Path(f"{stem}.{HTML}"))
    except OutputError as exc:
        raise PlotError(str(exc)) from None


def write_figure(figure: Figure, stem: str | Path, formats: list[str]) -> list[Path]:
    """Write a drawn figure as ``stem.<format>`` for each format, each through the atomic
    write of ``rodsim.io.atomic`` (a failed write keeps any older figure intact), and
    close it; raises ``PlotError``."""
    paths = []
    try:
        for fmt in formats:
            path = Path(f"{stem}.{fmt}")
            try:
                target = check_target(path)  # a symbolic link's target
            except OutputError as exc:
                raise PlotError(str(exc)) from None

            def save(temporary: Path, fmt: str = fmt) -> None:
                if fmt == "png":
                    _save_png(figure, temporary)
                else:
                    figure.savefig(temporary, dpi=DPI, format=fmt)

            try:
                write_atomic(target, save, follow_umask=True)
            except Exception as exc:
                reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
                raise PlotError(f"cannot write {path}: {reason}") from None
            paths.append(path)
    finally:
        plt.close(figure)
    return paths


def _save_png(figure: Figure, path: Path) -> None:
    """PNG with an adaptive 256-colour palette: a third of the size of the RGBA image, so
    the figures committed to docs/ stay small; plain savefig if Pillow is missing."""
    try:
        from PIL import Image
    except ImportError:
        figure.savefig(path, dpi=DPI)
        return
    buffer = io.BytesIO()
    figure.savefig(buffer, dpi=DPI, format="png")
    buffer.seek(0)
    with Image.open(buffer) as image:
        palette = image.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT)
        palette.save(path, format="PNG", optimize=True)
