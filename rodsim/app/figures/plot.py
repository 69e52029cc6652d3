"""Figures from archives: every plot is drawn from a Dataset alone (run or study).

``plot_dataset(ds, stem)`` picks the figure from the archive's ``plot`` attribute (studies),
its ``kind`` (``track``, ``fit``, ``reach``: docs/inverse.md; ``modes``, ``trajectory``:
docs/dynamics.md), or
draws the centerlines of a single run, and writes ``stem.png`` and ``stem.pdf``.
Kinds:

- ``centerlines``: the first rod's centerline at every point (Figs. 6, 9, 14–18, 22), with
  the study's analytic reference for each point when it has one — recomputed from the
  archive's ``spec_json`` (``reference_centerlines``), the exact elastica drawn with the
  paper's analytical model (AM) on it for the hanging-mass scenes. With two or more swept
  parameters the colour follows the last one and the line style the others (Fig. 9: one
  colour per mass, one style per stiffness tensor). A second panel gives the tip's y against
  the first numeric swept parameter.
- ``error_vs_parameter``: tip and area errors against the first swept parameter, log–log
  (Fig. 7, convergence studies), one line per value of the second swept parameter and, with
  three or more, one panel per value of the last.
- ``error_vs_iteration``: tip error against the reference per step (Fig. 8), one line per
  value of the first swept parameter, one panel per value of the others.
"""


from __future__ import annotations

import warnings
from collections.abc import Iterable
from pathlib import Path

import xarray as xr
from matplotlib.figure import Figure

from rodsim.app.figures import labels, view3d
from rodsim.app.figures.inverse import fit_figure, reach_figure, run_figure, track_figure
from rodsim.app.figures.layers import layers_left_out
from rodsim.app.figures.modes import modes_figure
from rodsim.app.figures.projections import out_of_plane
from rodsim.app.figures.study_centerlines import centerlines_figure, centerlines_result
from rodsim.app.figures.study_errors import (
    error_vs_iteration_figure,
    error_vs_iteration_result,
    error_vs_parameter_figure,
    error_vs_parameter_result,
)
from rodsim.app.figures.style import style
from rodsim.app.figures.trajectory import trajectory_figure
from rodsim.app.figures.writer import HTML, PlotError, check_output, html_target, write_figure
from rodsim.io.cf_layout import from_file

__all__ = ["PLOT_KINDS", "plot_dataset", "draw_figure", "three_dimensional"]

PLOT_KINDS = ("centerlines", "error_vs_parameter", "error_vs_iteration")
#: The figure of each study plot kind.
DRAWERS = {"centerlines": centerlines_figure, "error_vs_parameter": error_vs_parameter_figure,
           "error_vs_iteration": error_vs_iteration_figure}
#: The measured result of each study figure, one line computed from the archive.
RESULTS = {"centerlines": centerlines_result, "error_vs_parameter": error_vs_parameter_result,
           "error_vs_iteration": error_vs_iteration_result}
#: Figures of the inverse tools' archives, by their ``kind`` attribute.
KIND_DRAWERS = {"fit": fit_figure, "reach": reach_figure, "modes": modes_figure}
#: Figures of the archives of several states, which draw them coloured (``--colour``) and
#: with layers left out (``--hide``) or picked (``--show``), by their ``kind`` attribute.
SERIES_DRAWERS = {"track": track_figure, "trajectory": trajectory_figure}


def plot_dataset(ds: xr.Dataset, stem: str | Path, formats: Iterable[str] = ("png", "pdf"),
                 colour: str | None = None, hide: str | Iterable[str] = (),
                 cdn: bool = False, show: str | Iterable[str] | None = None) -> list[Path]:
    """Draw the archive's figure and write ``stem.<format>`` for each format.

    The formats and the folder are checked first (``check_output``); a format that
    fails to write (e.g. ``pgf`` without LaTeX) leaves no partial file. ``colour``,
    ``hide`` and ``show``: see ``draw_figure``; ``cdn``: the html view loads plotly from its CDN
    (``rodsim.app.figures.view3d.write_html``). Raises ``PlotError``.
    """
    formats = check_output(stem, formats)
    ds = from_file(ds)
    hidden = layers_left_out(show, hide)
    _check_run_options(ds, colour, hidden, show is not None)
    if ds.attrs.get("kind") == "batch":
        raise PlotError("a batch archive has no figure: select cases with xarray "
                        "(ds.sel(case=…)) and plot their positions (docs/batch.md)")
    html = HTML in formats
    formats = [fmt for fmt in formats if fmt != HTML]
    if html and "study" in ds.attrs:
        raise PlotError("the interactive 3D view (html) is drawn for run, track, fit, "
                        "reach and trajectory archives, not studies")
    paths = []
    if html:
        try:
            paths.append(view3d.write_html(ds, html_target(stem), colour, hidden, cdn))
        except OSError as exc:
            raise PlotError(f"cannot write {stem}.{HTML}: {exc.strerror or exc}") from None
    if not formats:
        return paths
    with warnings.catch_warnings():  # a character the font lacks is drawn as a box
        warnings.filterwarnings("ignore", message="Glyph .* missing from font",
                                category=UserWarning)
        with style():
            return write_figure(draw_figure(ds, colour, hidden), stem, formats) + paths


def three_dimensional(ds: xr.Dataset) -> bool:
    """Whether a run, track, fit, reach or trajectory archive's shapes leave the x–y plane
    (then ``rodsim plot`` adds the interactive 3D view when plotly is installed)."""
    if "study" in ds.attrs or "position" not in ds:
        return False
    return out_of_plane(ds["position"].values)


def draw_figure(ds: xr.Dataset, colour: str | None = None, hide: str | Iterable[str] = (),
                show: str | Iterable[str] | None = None) -> Figure:
    """The archive's figure, not written (the caller closes it); draw it inside
    ``style``. A study figure's title states the measured result (``RESULTS``).
    A run's, a track's or a trajectory's figure only: ``colour`` colours the rods by
    ``curvature`` or ``strain`` or the tendons by ``tension``
    (``rodsim.app.figures.colouring``; a track's steps and a trajectory's output times on one
    shared scale: ``rodsim.app.figures.state_series``), ``hide`` leaves out layers
    (``rodsim.app.figures.layers.LAYERS``), ``show`` draws only the layers it names (what
    no layer holds, e.g. the axes, is always drawn: ``rodsim.app.figures.layers``); the
    two do not combine (``layers_left_out``).
    Raises ``PlotError`` for an unknown plot kind, colouring or layer, a colouring the
    archive has no data for, and for a study in which every
    point failed (rodsim writes such archives: there is no shape or error to draw). A Dataset
    opened with plain xarray from a schema 3 file gets its labels back first
    (``rodsim.io.cf_layout.from_file``)."""
    ds = from_file(ds)
    hidden = layers_left_out(show, hide)
    _check_run_options(ds, colour, hidden, show is not None)
    if "study" in ds.attrs:
        kind = ds.attrs.get("plot", "centerlines")
        if not isinstance(kind, str) or kind not in DRAWERS:
            raise PlotError(f"unknown plot kind {str(kind)[:40]!r}; known: "
                            f"{', '.join(DRAWERS)}")
        if not bool((ds["status"] == 0).any()):
            raise PlotError(f"every one of the {int(ds['status'].size)} points of study "
                            f"{str(ds.attrs['study'])[:40]!r} failed: nothing to draw (the "
                            "archive's 'message' variable says why)")
        figure = DRAWERS[kind](ds)
        labels.study_title(figure, ds, RESULTS[kind](ds))
        return figure
    if ds.attrs.get("kind") in SERIES_DRAWERS:
        return SERIES_DRAWERS[ds.attrs["kind"]](ds, colour, hidden)
    if ds.attrs.get("kind") in KIND_DRAWERS:
        return KIND_DRAWERS[ds.attrs["kind"]](ds)
    return run_figure(ds, colour, hidden)


def _check_run_options(ds: xr.Dataset, colour: str | None, hidden: frozenset[str],
                       show: bool = False) -> None:
    """Colouring and the choice of layers (``hidden``, from ``--show`` when ``show``) are
    the figures' of a run, a track and a trajectory: refused for any other archive."""
    kind = ds.attrs.get("kind")
    if (colour or hidden or show) and ("study" in ds.attrs or kind in KIND_DRAWERS):
        what = "--colour" if colour else "--show" if show else "--hide"
        other = "a study" if "study" in ds.attrs else f"a {kind} archive"
        raise PlotError(f"{what} applies to the figure of a run, track or trajectory "
                        f"archive, not to {other}")
