"""Figures from archives: every plot is drawn from a Dataset alone (run or study).

``plot_dataset(ds, stem)`` picks the figure from the archive's ``plot`` attribute (studies),
its ``kind`` (``track``, ``fit``, ``reach``: docs/inverse.md), or draws the centerlines of a
single run, and writes ``stem.png`` and ``stem.pdf``.
Kinds:

- ``centerlines``: the first rod's centerline at every point (Figs. 6, 9, 14–18, 22), with
  the study's analytic reference for each point when it has one — recomputed from the
  archive's ``spec_json`` (:func:`reference_centerlines`), the exact elastica drawn with the
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

import contextlib
import io
import json
import os
import textwrap
import warnings
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import NullFormatter

from rodsim.app import view3d
from rodsim.io.cf_layout import from_file, key_variable
from rodsim.io.output import OutputError, check_target

__all__ = ["plot_dataset", "draw_figure", "style", "STYLE", "PLOT_KINDS",
           "reference_centerlines", "PlotError", "supported_formats", "check_output"]

PLOT_KINDS = ("centerlines", "error_vs_parameter", "error_vs_iteration")

#: Analytic curves drawn for a study's reference kind: (kind, label, style) — the first is
#: the reference the errors are measured against.
OVERLAYS = {
    "exact": (("exact", "exact elastica", {"color": "k", "lw": 0.9, "ls": "-"}),
              ("paper", "analytical model (AM), Eqs. (21)–(23) corrected",
               {"color": "k", "ls": "none", "marker": "o", "mfc": "none", "ms": 4})),
    "paper": (("paper", "analytical model (AM), Eqs. (21)–(23) corrected",
               {"color": "k", "lw": 0.9, "ls": "-"}),),
    "extensible": (("extensible", "extensible elastica", {"color": "k", "lw": 0.9, "ls": "-"}),),
    "arc": (("arc", "constant-curvature arc", {"color": "k", "lw": 0.9, "ls": "-"}),),
}
LINE_STYLES = ("-", "--", ":", "-.")
MARKERS = ("o", "s", "^", "v", "D", "P")
#: Every how many σ samples the AM markers are drawn (101 samples: 11 markers).
MARKER_EVERY = 10
DPI = 100
#: The style file of every rodsim figure (package data).
STYLE = Path(__file__).with_name("rodsim.mplstyle")


#: The format of the interactive 3D view (rodsim/app/view3d.py, plotly).
HTML = "html"


class PlotError(ValueError):
    """A figure cannot be drawn or written: unknown format, unwritable folder, bad archive."""


# Output formats and paths -------------------------------------------------------------------


def supported_formats() -> list[str]:
    """The file formats matplotlib can write (``png``, ``pdf``, ``svg``, …)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return sorted(FigureCanvasBase.get_supported_filetypes())


def check_output(stem: str | Path, formats: Iterable[str]) -> list[str]:
    """Validate the formats and the output folder before drawing anything.

    Returns the formats, lower-cased, without duplicates; raises :class:`PlotError` for an
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


# Points, labels and colours -----------------------------------------------------------------


def _sweep_dims(ds: xr.Dataset) -> list[str]:
    return list(ds["status"].dims)


def _value(ds: xr.Dataset, dim: str, i: int) -> Any:
    return ds[dim].values[i].item()


def _is_numeric(ds: xr.Dataset, dim: str) -> bool:
    return np.issubdtype(ds[dim].dtype, np.number)


def _text(value: Any) -> str:
    return f"{value:g}" if isinstance(value, (int, float, np.number)) else str(value)


def _label(ds: xr.Dataset, point: dict[str, object]) -> str:
    parts = []
    for dim, value in point.items():
        units = ds[dim].attrs.get("units", "1")
        unit = "" if units in ("1", "-") else f" {units}"
        parts.append(f"{dim} = {_text(value)}{unit}")
    return ", ".join(parts)


def _axis_label(ds: xr.Dataset, dim: str) -> str:
    units = ds[dim].attrs.get("units", "1")
    return ds[dim].attrs.get("long_name", dim) + ("" if units in ("1", "-") else f" [{units}]")


def _indices(ds: xr.Dataset, dims: Sequence[str]) -> list[tuple[int, ...]]:
    return list(np.ndindex(*(ds.sizes[d] for d in dims))) if dims else [()]


def _colours(count: int, numeric: bool) -> list[Any]:
    """Sequential colours for five or more ordered values (the trend reads as a gradient),
    the categorical cycle otherwise."""
    if numeric and count >= 5:
        cmap = plt.get_cmap("viridis")
        return [cmap(0.85 * i / (count - 1)) for i in range(count)]
    cycle = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    return [cycle[i % len(cycle)] for i in range(count)]


def _log_axis(values: np.ndarray, ratio: float = 20.0) -> bool:
    """Log scale for a positive numeric axis spanning at least a factor ``ratio``."""
    values = np.asarray(values, dtype=float)
    return bool(np.all(values > 0.0) and values.max() >= ratio * values.min())


def _positions(ds: xr.Dataset, dim: str) -> tuple[np.ndarray, list[str] | None]:
    """x positions of ``dim``'s values, and tick labels when they are not numbers."""
    if _is_numeric(ds, dim):
        return ds[dim].values.astype(float), None
    return np.arange(ds.sizes[dim], dtype=float), [str(v) for v in ds[dim].values]


def _finish_x(axes: plt.Axes, ds: xr.Dataset, dim: str, log_ratio: float = 20.0) -> None:
    x, ticks = _positions(ds, dim)
    if ticks is not None:
        axes.set_xticks(x, ticks)
        axes.set_xlim(x[0] - 0.5, x[-1] + 0.5)
    elif _log_axis(x, log_ratio):
        axes.set_xscale("log")
        if len(x) <= 12 and x.max() < 100.0 * x.min():  # few decades: label the values
            axes.set_xticks(x, [_text(v) for v in ds[dim].values])
            axes.xaxis.set_minor_formatter(NullFormatter())
    axes.set_xlabel(_axis_label(ds, dim))


def _title(figure: Figure, ds: xr.Dataset, result: str) -> None:
    """The study's name and size, the measured result (one line computed from the archive)
    and the paper's claim it is compared with."""
    width = max(40, int(12 * figure.get_figwidth()))  # characters of 10-pt text per line
    lines = [f"{ds.attrs['study']} ({ds.attrs.get('size', '')}) — measured: {result}"]
    if ds.attrs.get("paper"):
        lines.append(str(ds.attrs["paper"]))
    figure.suptitle("\n".join(textwrap.fill(line, width) for line in lines))


def _span(values: Iterable[float], fmt: str = "g") -> str:
    """``a–b`` of the finite values (``a`` when they are all equal, ``n/a`` when none is)."""
    finite = [v for v in values if np.isfinite(v)]
    if not finite:
        return "n/a"
    low, high = format(min(finite), fmt), format(max(finite), fmt)
    return low if low == high else f"{low}–{high}"


def _percent(value: float) -> str:
    return f"{100.0 * value:.2g} %"


# Analytic references ------------------------------------------------------------------------


def reference_centerlines(ds: xr.Dataset, kinds: Sequence[str] | None = None
                          ) -> dict[str, dict[tuple[int, ...], np.ndarray]]:
    """Analytic references (σ, 3) [m] of the first rod at every grid point that has one.

    Returns ``{kind: {grid index: curve}}`` for each of ``kinds`` (default: the study's
    reference). Recomputed from the archive's ``spec_json`` (the base scene and the sweeps,
    :func:`rodsim.app.study.point_scene`), so it needs nothing but the Dataset. The hanging-mass
    kinds (``exact``, ``paper``, ``extensible``) come from one
    :func:`~rodsim.core.analytic.reference.cantilever_reference` per point, sampled at σ L (the
    paper's model, sampled in φ, is interpolated); ``arc`` from
    :func:`~rodsim.core.analytic.reference.reference_centerline`. Points whose scene does not
    qualify, or is invalid, are left out.
    """
    from rodsim.app.study import StudySpec, point_scene
    from rodsim.core.analytic.reference import (
        REFERENCE_KINDS,
        cantilever_reference,
        reference_centerline,
    )

    spec_json = ds.attrs.get("spec_json")
    spec = StudySpec.from_json(spec_json) if spec_json else None
    wanted = kinds or [spec.reference if spec is not None else None]
    kinds = [k for k in wanted if k in REFERENCE_KINDS]
    out: dict[str, dict[tuple[int, ...], np.ndarray]] = {k: {} for k in kinds}
    if spec is None or not kinds:
        return out
    sigma = ds["sigma"].values
    for index in _indices(ds, _sweep_dims(ds)):
        try:
            scene = point_scene(spec, index)
            s = sigma * next(iter(scene.rods.values())).length
            cantilever = (cantilever_reference(scene) if set(kinds) - {"arc"} else None)
            for kind in kinds:
                if kind == "arc":
                    curve = reference_centerline(scene, kind, s)
                elif cantilever is None:
                    curve = None
                else:
                    shape = getattr(cantilever, kind)
                    curve = np.zeros((len(s), 3))
                    curve[:, 0] = np.interp(s, shape.s, shape.x)
                    curve[:, 1] = np.interp(s, shape.s, shape.y)
                if curve is not None:
                    out[kind][index] = curve
        except Exception:  # an invalid point (recorded as such): nothing to draw
            continue
    return out


def _draw_references(ds: xr.Dataset, axes: plt.Axes) -> dict[tuple[int, ...], np.ndarray]:
    """Draw each distinct analytic reference curve once; returns the study's reference."""
    overlays = OVERLAYS.get(ds.attrs.get("reference", ""), ())
    if not overlays:
        return {}
    curves = reference_centerlines(ds, [kind for kind, _, _ in overlays])
    for kind, label, style in overlays:
        drawn: list[np.ndarray] = []
        for curve in curves[kind].values():
            if any(np.allclose(curve, other, rtol=0.0, atol=1e-12) for other in drawn):
                continue
            every = MARKER_EVERY if style.get("marker") else None
            axes.plot(curve[:, 0], curve[:, 1], markevery=every, zorder=3,
                      label=None if drawn else label, **style)
            drawn.append(curve)
    return curves[overlays[0][0]]


# Centerlines --------------------------------------------------------------------------------


def _tip_error_text(sel: xr.Dataset) -> str:
    error = float(sel["tip_error"]) if "tip_error" in sel else float("nan")
    return f" (tip error {100 * error:.2g} % L)" if np.isfinite(error) and error > 0 else ""


def _point_styles(ds: xr.Dataset) -> dict[tuple[int, ...], dict[str, Any]]:
    """Colour, line style and marker of every grid point: the colour follows the last swept
    parameter with more than one value, the style the others (Fig. 9: colour = mass)."""
    dims = _sweep_dims(ds)
    varying = [d for d in dims if ds.sizes[d] > 1] or dims
    colour_dim = varying[-1] if varying else None
    style_dims = [d for d in dims if d != colour_dim]
    colours = (_colours(ds.sizes[colour_dim], _is_numeric(ds, colour_dim))
               if colour_dim else ["C0"])
    styles = {index: n for n, index in enumerate(_indices(ds, style_dims))}
    out = {}
    for index in _indices(ds, dims):
        point = dict(zip(dims, index, strict=True))
        n = styles[tuple(point[d] for d in style_dims)]
        out[index] = {"color": colours[point[colour_dim]] if colour_dim else colours[0],
                      "ls": LINE_STYLES[n % len(LINE_STYLES)],
                      "marker": MARKERS[n % len(MARKERS)]}
    return out


#: Markers on a model centerline every this many σ samples, offset by the point's number.
STAGGER = 6
#: Two centerlines closer than this fraction of the drawing's span coincide on the figure.
COINCIDE = 0.01


def _coinciding(lines: Sequence[np.ndarray]) -> int:
    """How many of the (σ, 3) centerlines lie within :data:`COINCIDE` of the drawing's span
    of another one (everywhere): those a reader cannot tell apart without markers."""
    if len(lines) < 2:
        return 0
    stacked = np.stack([line[:, :2] for line in lines])
    span = float(np.ptp(stacked.reshape(-1, 2), axis=0).max()) or 1.0
    gaps = np.abs(stacked[:, None] - stacked[None, :]).max(axis=(2, 3))
    np.fill_diagonal(gaps, np.inf)
    return int((gaps.min(axis=1) < COINCIDE * span).sum())


#: Above this many points a centerline legend lists colours and styles, not every point.
LEGEND_POINTS = 12


def _compact_legend(ds: xr.Dataset, axes: plt.Axes) -> None:
    """Legend for many points: one entry per colour value (last varying sweep) and, when
    they are few, one per line style (the other sweeps), plus the reference curves."""
    dims = _sweep_dims(ds)
    styles = _point_styles(ds)
    varying = [d for d in dims if ds.sizes[d] > 1] or dims
    colour_dim = varying[-1]
    style_dims = [d for d in dims if d != colour_dim]
    handles, labels = [h for h in axes.get_legend_handles_labels()[0]], \
        list(axes.get_legend_handles_labels()[1])
    for i in range(ds.sizes[colour_dim]):
        index = tuple(i if d == colour_dim else 0 for d in dims)
        handles.append(Line2D([], [], color=styles[index]["color"], lw=2))
        labels.append(_label(ds, {colour_dim: _value(ds, colour_dim, i)}))
    groups = _indices(ds, style_dims)
    if style_dims and len(groups) <= LEGEND_POINTS:
        for group in groups:
            select = dict(zip(style_dims, group, strict=True))
            index = tuple(select.get(d, 0) for d in dims)
            handles.append(Line2D([], [], color="0.4", ls=styles[index]["ls"],
                                  marker=styles[index]["marker"], ms=3))
            labels.append(_label(ds, {d: _value(ds, d, i) for d, i in select.items()}))
    axes.legend(handles, labels, loc="best")


def _centerlines(ds: xr.Dataset) -> Figure:
    dims = _sweep_dims(ds)
    numeric = [d for d in dims if _is_numeric(ds, d) and ds.sizes[d] > 1]
    tip_dim = numeric[0] if numeric else (dims[0] if dims else None)
    figure, (axes, tips) = plt.subplots(1, 2, figsize=(11.0, 5.0), width_ratios=(1.6, 1.0),
                                        constrained_layout=True)
    references = _draw_references(ds, axes)
    styles = _point_styles(ds)
    rod = ds["rod"].values[0]
    last_is_reference = ds.attrs.get("reference") == "last" and bool(dims)
    drawn: list[np.ndarray] = []
    for n, (index, style) in enumerate(styles.items()):
        point = dict(zip(dims, index, strict=True))
        sel = ds.isel(point)
        if int(sel["status"]) != 0:
            continue
        line = sel["centerline"].sel(rod=rod).values
        label = _label(ds, {d: _value(ds, d, i) for d, i in point.items()})
        if last_is_reference and point[dims[0]] == ds.sizes[dims[0]] - 1:
            label += " (reference)"
        many = len(styles) > LEGEND_POINTS
        # Markers staggered along σ (every STAGGER-th sample, offset per point): curves that
        # coincide show each colour's markers between the others'.
        axes.plot(line[:, 0], line[:, 1], markersize=4.5, lw=1.8,
                  markevery=(n % STAGGER, STAGGER),
                  label=None if many else label + _tip_error_text(sel), **style)
        drawn.append(line)
    axes.set_xlabel("x [m]")
    axes.set_ylabel("y [m]")
    axes.set_aspect("equal", adjustable="datalim")
    axes.grid(True, alpha=0.3)
    title = f"{rod} centerline at equilibrium ({ds.attrs.get('integrator', '')})"
    coinciding = _coinciding(drawn)
    if coinciding:
        title += (f"\n{coinciding} curves lie within {COINCIDE:.0%} of the span of another: "
                  "their markers are staggered")
    axes.set_title(title)
    if len(styles) > LEGEND_POINTS:
        _compact_legend(ds, axes)
    else:
        axes.legend(loc="best")
    if tip_dim is None:
        tips.set_visible(False)
    else:
        _tips(ds, tips, tip_dim, references, styles)
    return figure


def _tips(ds: xr.Dataset, axes: plt.Axes, dim: str,
          references: dict[tuple[int, ...], np.ndarray],
          styles: dict[tuple[int, ...], dict[str, Any]]) -> None:
    """Tip y of the first rod against ``dim``: one grey line per value of the other sweeps,
    each point in its centerline's colour and marker; the reference's tip as black crosses."""
    dims = _sweep_dims(ds)
    others = [d for d in dims if d != dim]
    x, _ = _positions(ds, dim)
    tip_y = ds["tip"].isel(rod=0).sel(axis="y").where(ds["status"] == 0)
    for n, group in enumerate(_indices(ds, others)):
        select = dict(zip(others, group, strict=True))
        y = tip_y.isel(select).values
        indices = [tuple(i if d == dim else select[d] for d in dims)
                   for i in range(ds.sizes[dim])]
        label = _label(ds, {d: _value(ds, d, i) for d, i in select.items()}) or "model"
        first = styles[indices[0]]
        axes.plot(x, y, color="0.5", lw=1.0, ls=first["ls"], marker=first["marker"], ms=0,
                  label=label)
        for xi, yi, index in zip(x, y, indices, strict=True):
            axes.plot([xi], [yi], ls="none", marker=styles[index]["marker"], ms=5,
                      color=styles[index]["color"])
        ref = [references[i][-1, 1] if i in references else np.nan for i in indices]
        if np.any(np.isfinite(ref)):
            axes.plot(x, ref, "x", color="k", ms=7,
                      label="reference tip" if n == 0 else None)
    _finish_x(axes, ds, dim)
    axes.set_ylabel("tip y [m]")
    _show_size_of_change(axes, ds, tip_y.values)
    axes.grid(True, which="both", alpha=0.3)
    if len(_indices(ds, others)) <= LEGEND_POINTS:
        axes.legend()


#: The tip panel's y range spans at least this share of the rod's length, so that a
#: change too small to matter is drawn flat (its size is in the panel's title).
MIN_TIP_RANGE = 0.01


def _rod_length(ds: xr.Dataset) -> float:
    """The first rod's length from the stored scene (NaN if it cannot be read)."""
    try:
        rods = json.loads(ds.attrs["scene_json"])["rods"]
        return float(rods[str(ds["rod"].values[0])]["length"])
    except (KeyError, TypeError, ValueError):
        return float("nan")


def _length_text(value: float) -> str:
    """A length with a unit that reads: m, mm or µm."""
    magnitude = abs(value)
    if magnitude >= 0.1:
        return f"{value:.3g} m"
    if magnitude >= 1e-4:
        return f"{value * 1e3:.3g} mm"
    return f"{value * 1e6:.3g} µm"


def _show_size_of_change(axes: plt.Axes, ds: xr.Dataset, values: np.ndarray) -> None:
    """No offset notation, a y range of at least :data:`MIN_TIP_RANGE` L around the values,
    and the size of the change (max − min) in the title, in length and in L."""
    finite = np.asarray(values, dtype=float)
    finite = finite[np.isfinite(finite)]
    axes.ticklabel_format(axis="y", useOffset=False, style="plain")
    if finite.size == 0:
        axes.set_title("tip deflection")
        return
    change = float(finite.max() - finite.min())
    length = _rod_length(ds)
    title = f"tip deflection: changes by {_length_text(change)}"
    if np.isfinite(length) and length > 0:
        title += f" ({change / length:.2g} L)"
        low, high = axes.get_ylim()
        middle, half = 0.5 * (finite.max() + finite.min()), 0.5 * MIN_TIP_RANGE * length
        axes.set_ylim(min(low, middle - half), max(high, middle + half))
    axes.set_title(title)


# Errors against a parameter -----------------------------------------------------------------


def _positive(values: np.ndarray) -> np.ndarray:
    values = np.asarray(values, dtype=float)
    return np.where(values > 0.0, values, np.nan)


def _panel_grid(count: int, width: float = 4.6, height: float = 4.0
                ) -> tuple[Figure, list[plt.Axes]]:
    columns = count if count <= 3 else int(np.ceil(np.sqrt(count)))
    rows = -(-count // columns)
    figure, grid = plt.subplots(rows, columns, figsize=(width * columns + 0.8, height * rows),
                                squeeze=False, sharey=True, constrained_layout=True)
    panels = list(grid.ravel())
    for extra in panels[count:]:
        extra.set_visible(False)
    return figure, panels[:count]


#: The errors an ``error_vs_parameter`` figure draws, one row of panels each, and their
#: short axis labels (the units come from the archive).
ERRORS = {"tip_error": "tip error / L", "area_error": "area error / L (Fig. 21)"}


def _error_label(ds: xr.Dataset, name: str) -> str:
    """``tip error / L [1]``-style label of an error with the archive's units, and what it
    is measured against."""
    units = ds[name].attrs.get("units", "1")
    reference = ds.attrs.get("reference")
    against = {None: "", "None": "", "last": "\nagainst the last point"}.get(
        reference, f"\nagainst the {reference} reference")
    return f"{ERRORS[name]} [{'dimensionless' if units in ('1', '-') else units}]{against}"


def _error_grid(count: int, rows: int) -> tuple[Figure, np.ndarray]:
    """``rows`` × ``count`` panels: one row per error (each with its own unit), one column
    per value of the panel sweep."""
    width = max(6.4, 4.2 * count + 0.8)
    figure, grid = plt.subplots(rows, count, figsize=(width, 3.4 * rows + 0.6),
                                squeeze=False, sharex="col", sharey="row",
                                constrained_layout=True)
    return figure, grid


def _draw_fitted_order(axes: plt.Axes, x: np.ndarray, y: np.ndarray, dim: str,
                       first_line: bool) -> None:
    """The power law fitted where the error still falls, dashed over that range only."""
    order, keep = _fitted_order(x, y)
    if not np.isfinite(order):
        return
    xs, ys = x[keep], y[keep]
    scale = np.exp(np.mean(np.log(ys) + order * np.log(xs)))
    span = np.array([xs.min(), xs.max()])
    axes.plot(span, scale * span ** -order, color="k", ls="--", lw=0.9, zorder=4,
              label=f"fit: ∝ {dim}^−{order:.2f}" if first_line else None)


def _error_vs_parameter(ds: xr.Dataset) -> Figure:
    """Tip error (top row, [1]) and area error (bottom row, [m]) against the first swept
    parameter: the two have different units, so they never share an axis."""
    dims = _sweep_dims(ds)
    if not dims:  # nothing swept: no parameter to plot against
        return _centerlines(ds)
    first = dims[0]
    panel_dims = [dims[-1]] if len(dims) >= 3 else []
    line_dims = [d for d in dims[1:] if d not in panel_dims]
    panel_groups = _indices(ds, panel_dims)
    line_groups = _indices(ds, line_dims)
    errors = [name for name in ERRORS if name in ds]  # a study without a reference has none
    figure, grid = _error_grid(len(panel_groups), max(len(errors), 1))
    x, _ = _positions(ds, first)
    colours = _colours(len(line_groups), len(line_dims) == 1 and _is_numeric(ds, line_dims[0]))
    anything = False
    for row, name in enumerate(errors):
        for axes, panel in zip(grid[row], panel_groups, strict=True):
            panel_select = dict(zip(panel_dims, panel, strict=True))
            for n, group in enumerate(line_groups):
                sub = ds.isel(panel_select | dict(zip(line_dims, group, strict=True)))
                y = _positive(sub[name].where(sub["status"] == 0).values)
                if np.all(np.isnan(y)):
                    continue
                anything = True
                label = _label(ds, {d: _value(ds, d, i)
                                    for d, i in zip(line_dims, group, strict=True)})
                # Successive lines thinner, with their own marker: coinciding ones stay
                # visible.
                axes.plot(x, y, color=colours[n], marker=MARKERS[n % len(MARKERS)],
                          ls=LINE_STYLES[n % len(LINE_STYLES)], ms=max(3.0, 6.5 - n),
                          lw=max(1.0, 2.4 - 0.4 * n), label=label or "model")
                if name == "tip_error" and _is_numeric(ds, first):
                    _draw_fitted_order(axes, np.asarray(x, dtype=float), y, first,
                                       first_line=n == 0)
            axes.set_yscale("log")
            axes.grid(True, which="both", alpha=0.3)
            if row == 0:
                _panel_title(axes, ds, panel_select)
        grid[row, 0].set_ylabel(_error_label(ds, name))
    for axes in grid[-1]:
        _finish_x(axes, ds, first, log_ratio=2.0)  # log–log: orders of convergence
    if not anything:
        grid[0, 0].text(0.5, 0.5, "no errors: the study has no reference, or no point has one",
                        ha="center", va="center", transform=grid[0, 0].transAxes)
        return figure
    grid[0, -1].legend(loc="best")
    return figure


#: A point belongs to the range an order is fitted over while the error still falls: the
#: local order of each step of the sweep, −Δlog(error)/Δlog(parameter), must be at least
#: this (a plateau, the floor set by another error, has a local order near 0).
MIN_LOCAL_ORDER = 0.5


def _falling(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Mask of the points where the error still falls: from the end of the sweep with the
    largest error, the leading run of steps whose local order is at least
    :data:`MIN_LOCAL_ORDER` (so a plateau is left out of the fit)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    usable = np.flatnonzero(np.isfinite(x) & np.isfinite(y) & (x > 0.0) & (y > 0.0))
    mask = np.zeros(x.shape, dtype=bool)
    if usable.size < 2:
        return mask
    order = usable[np.argsort(x[usable])]
    if y[order[-1]] > y[order[0]]:  # the error falls towards small x
        order = order[::-1]
    mask[order[0]] = True
    for previous, current in zip(order[:-1], order[1:], strict=True):
        ratio = abs(np.log(x[current] / x[previous]))
        if ratio == 0.0 or np.log(y[previous] / y[current]) / ratio < MIN_LOCAL_ORDER:
            break
        mask[current] = True
    return mask


def _fitted_order(x: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray]:
    """The order p of ``y ∝ x^-p`` fitted (least squares, log–log) where the error still
    falls (:func:`_falling`), and that mask; NaN with fewer than two such points."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = _falling(x, y)
    if keep.sum() < 2 or np.ptp(x[keep]) == 0.0:
        return float("nan"), keep
    return float(-np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)[0]), keep


def _error_vs_parameter_result(ds: xr.Dataset) -> str:
    """The observed order of the tip error in the first swept parameter (fitted for every
    line of the figure) and the smallest tip error, or what is plotted when there is
    nothing to fit."""
    dims = _sweep_dims(ds)
    if not dims or "tip_error" not in ds:
        return "tip and area errors against the swept parameter (none in this archive)"
    first = dims[0]
    error = ds["tip_error"].where(ds["status"] == 0)
    name = ds[first].attrs.get("long_name", first)
    if not _is_numeric(ds, first):
        return f"tip error / L {_span(error.values.ravel(), '.2g')} over {name}"
    others = dims[1:]
    x = ds[first].values.astype(float)
    fits = [_fitted_order(x, error.isel(dict(zip(others, group, strict=True))).values)
            for group in _indices(ds, others)]
    orders = [p for p, _ in fits]
    fitted = np.any([mask for p, mask in fits if np.isfinite(p)], axis=0) if any(
        np.isfinite(orders)) else np.zeros(x.shape, dtype=bool)
    if not bool(error.notnull().any()):
        return f"no tip error: no point of {name} converged with a reference"
    best = error.where(error == error.min(), drop=True)
    where = _label(ds, {d: best[d].values.ravel()[0].item() for d in dims if d in best.dims})
    smallest = f"smallest {_percent(float(error.min()))} of L at {where}"
    if not fitted.any():
        return f"the tip error does not fall over {first}; {smallest}"
    lines = f" ({len(orders)} lines)" if len(orders) > 1 else ""
    levels = "" if fitted.all() else (f", then levels off (error of something else than "
                                      f"{first})")
    return (f"tip error / L ∝ {first}^−p with p = {_span(orders, '.2f')}{lines}, fitted where "
            f"it still falls: {first} = {_span(x[fitted])}{levels}; {smallest}")


def _panel_title(axes: plt.Axes, ds: xr.Dataset, panel_select: dict[str, int]) -> None:
    """Title a panel with the swept values it holds (nothing when there is one panel)."""
    if panel_select:
        axes.set_title(_label(ds, {d: _value(ds, d, i) for d, i in panel_select.items()}))


# Errors against the iteration ---------------------------------------------------------------


def _error_vs_iteration(ds: xr.Dataset) -> Figure:
    dims = _sweep_dims(ds)
    if "history_error" not in ds:  # the study kept no per-step history (history=False)
        figure = _centerlines(ds)
        figure.axes[0].text(0.02, 0.02, "no per-step history in this archive: centerlines "
                            "drawn instead", transform=figure.axes[0].transAxes)
        return figure
    line_dims, panel_dims = dims[:1], dims[1:]
    panel_groups = _indices(ds, panel_dims)
    line_groups = _indices(ds, line_dims)
    figure, panels = _panel_grid(len(panel_groups))
    colours = _colours(len(line_groups), bool(line_dims) and _is_numeric(ds, line_dims[0]))
    for axes, panel in zip(panels, panel_groups, strict=True):
        panel_select = dict(zip(panel_dims, panel, strict=True))
        for n, group in enumerate(line_groups):
            select = panel_select | dict(zip(line_dims, group, strict=True))
            sub = ds.isel(select)
            error = sub["history_error"].values
            keep = ~np.isnan(error)
            steps = np.arange(1, len(error) + 1)
            label = _label(ds, {d: _value(ds, d, i) for d, i in zip(line_dims, group,
                                                                    strict=True)})
            if int(sub["status"]) != 0:
                label += " (failed)"
            axes.semilogy(steps[keep], error[keep], "o-", ms=3, color=colours[n], label=label)
        axes.set_xlabel("iteration (time step)")
        axes.grid(True, which="both", alpha=0.3)
        _panel_title(axes, ds, panel_select)
    panels[0].set_ylabel(f"tip error against the {ds.attrs.get('reference')} reference / L")
    panels[-1].legend()
    return figure


def _steps_taken(ds: xr.Dataset) -> xr.DataArray:
    """Time steps each point took to come to rest: its recorded history length (NaN for a
    failed point)."""
    steps = ds["history_error"].notnull().sum("step").astype(float)
    return steps.where(ds["status"] == 0)


def _error_vs_iteration_result(ds: xr.Dataset) -> str:
    """Steps to rest per value of the first swept parameter, for each value of the others;
    says so when the first parameter changes nothing."""
    if "history_error" not in ds:
        return "centerlines (no per-step history in this archive)"
    dims = _sweep_dims(ds)
    if not dims:
        return f"{int(_steps_taken(ds))} time steps to rest"
    steps = _steps_taken(ds)
    line_dim, panel_dims = dims[0], dims[1:]
    symbol = ds[line_dim].attrs.get("long_name", line_dim).split()[-1]
    groups = _indices(ds, panel_dims)
    if len(groups) == 1 and ds.sizes[line_dim] <= 8:
        return "time steps to rest: " + ", ".join(
            f"{symbol} = {_text(_value(ds, line_dim, i))}: {_span([float(v)], '.0f')}"
            for i, v in enumerate(steps.values.ravel()))
    parts, flat = [], True
    for group in groups:
        select = dict(zip(panel_dims, group, strict=True))
        values = steps.isel(select).values.ravel()
        flat &= bool(np.nanmin(values) == np.nanmax(values)) if np.isfinite(values).any() \
            else True
        parts.append(f"{_span(values, '.0f')} at "
                     f"{_label(ds, {d: _value(ds, d, i) for d, i in select.items()})}")
    lead = f"{symbol} has no effect: " if flat else ""
    return f"{lead}time steps to rest for every {symbol}: " + "; ".join(parts)


def _centerlines_result(ds: xr.Dataset) -> str:
    """The largest tip error against the reference (per value of the first swept parameter
    when there are two or more), or the range of the tip's y without a reference."""
    dims = _sweep_dims(ds)
    ok = ds["status"] == 0
    error = ds["tip_error"].where(ok) if "tip_error" in ds else None
    if error is not None and bool(error.notnull().any()):
        reference = ds.attrs.get("reference")
        against = (f"the last {dims[0]} point" if reference == "last"
                   else f"the {reference} reference")
        if len(dims) >= 2 and ds.sizes[dims[0]] > 1:
            parts = [f"{_label(ds, {dims[0]: _value(ds, dims[0], i)})}: "
                     + (_percent(float(error.isel({dims[0]: i}).max()))
                        if bool(error.isel({dims[0]: i}).notnull().any())
                        else f"no {reference} reference")
                     for i in range(ds.sizes[dims[0]])]
        else:
            parts = [f"{_percent(float(error.max()))} over {int(error.notnull().sum())} points"]
        return f"largest tip error / L against {against}: " + "; ".join(parts)
    tip_y = ds["tip"].isel(rod=0).sel(axis="y").where(ok).values.ravel()
    finite = tip_y[np.isfinite(tip_y)]
    if finite.size == 0:
        return "no point converged"
    change = float(finite.max() - finite.min())
    return (f"tip y of {ds['rod'].values[0]} {_span(finite, '.3g')} m over {finite.size} "
            f"points (a change of {_length_text(change)})")


# Single runs --------------------------------------------------------------------------------


def _tip_text(ds: xr.Dataset) -> str:
    """The first rod's tip, computed from the positions (mm)."""
    tip = _first_rod_nodes(ds).values[-1]
    return (f"tip of {ds['rod'].values[0]}: x, y, z = "
            + ", ".join(f"{1e3 * v:.4g}" for v in tip) + " mm")


def _run_centerlines(ds: xr.Dataset) -> Figure:
    """A run: its rods in x–y, and in x–z and y–z too when the shape leaves the x–y plane;
    the title names the tip, computed from the positions."""
    figure, views = _views(ds, np.empty((0, 3)))
    for panel, _ in views:
        panel.legend(loc="best")
    figure.suptitle(f"{ds.attrs.get('title', '')}\n{_tip_text(ds)}")
    return figure


# Inverse tools (docs/inverse.md) --------------------------------------------------------


def _first_rod_nodes(ds: xr.Dataset) -> xr.DataArray:
    first = ds["rod"].values[0]
    return ds["position"].sel(node=ds["rod"] == first)


def _out_of_plane(positions: np.ndarray) -> bool:
    """Whether a shape leaves the x–y plane (then the x–z and y–z views are drawn too)."""
    return bool(np.ptp(positions[..., 2]) > 1e-6 * max(np.ptp(positions[..., 0]), 1e-12))


def _track_figure(ds: xr.Dataset) -> Figure:
    """A track: the first rod's centerline at every step, coloured by step, and the tip
    against the first ramped value."""
    figure, (shapes, tips) = plt.subplots(1, 2, figsize=(10.0, 4.4), constrained_layout=True)
    nodes = _first_rod_nodes(ds).values
    ramp = list(json.loads(ds.attrs["ramp_json"]))[0]
    values = key_variable(ds, ramp).values
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 1.0, max(len(values), 1)))
    for step, colour in enumerate(colours):
        shapes.plot(nodes[step, :, 0], nodes[step, :, 1], color=colour, lw=0.9)
    mappable = plt.cm.ScalarMappable(cmap="viridis", norm=plt.Normalize(values.min(),
                                                                        values.max()))
    figure.colorbar(mappable, ax=shapes, label=_ramp_label(ds, ramp))
    shapes.set_xlabel("x [m]")
    shapes.set_ylabel("y [m]")
    shapes.set_aspect("equal", adjustable="datalim")
    shapes.set_title(f"centerline of {ds['rod'].values[0]} at each of {len(values)} steps")
    for axis, name in enumerate("xyz"):
        tips.plot(values, nodes[:, -1, axis], label=f"tip {name}")
    tips.set_xlabel(_ramp_label(ds, ramp))
    tips.set_ylabel("tip position [m]")
    tips.legend()
    last = nodes[-1, -1] if len(values) else np.full(3, np.nan)
    unit = key_variable(ds, ramp).attrs.get("units", "")
    figure.suptitle(f"{ds.attrs.get('title', '')}\ntip of {ds['rod'].values[0]} at "
                    f"{short_key(ramp)} = {values[-1]:.4g} {unit}: x, y, z = "
                    + ", ".join(f"{1e3 * v:.4g}" for v in last) + " mm")
    return figure


def short_key(key: str) -> str:
    """A short label for a dotted scene key: its last part and the rod or tendon it belongs
    to (``tendons.tendon.tendon_actuation.force`` → ``force (tendon)``)."""
    parts = key.split(".")
    if len(parts) >= 3 and parts[0] in ("rods", "tendons"):
        return f"{parts[-1]} ({parts[1]})"
    return parts[-1]


def _ramp_label(ds: xr.Dataset, key: str) -> str:
    unit = key_variable(ds, key).attrs.get("units", "")
    label = short_key(key)
    return f"{label} [{unit}]" if unit not in ("", "1") else label


#: The projections of a 3D shape: (horizontal, vertical) world axes of each panel.
PROJECTIONS = ((0, 1), (0, 2), (1, 2))


def _views(ds: xr.Dataset, extra: np.ndarray) -> tuple[Figure, list[plt.Axes]]:
    """The run's rods in x–y, and in x–z and y–z when the shape or ``extra`` points leave
    the x–y plane (a 3D shape seen from one side only can hide a whole bend)."""
    three_d = _out_of_plane(np.concatenate([ds["position"].values, extra]))
    count = len(PROJECTIONS) if three_d else 1
    figure, axes = plt.subplots(1, count, figsize=(4.4 * count + 1.0 if three_d else 6.4, 4.8),
                                constrained_layout=True, squeeze=False)
    views = list(PROJECTIONS[:count])
    for panel, (h, v) in zip(axes[0], views, strict=True):
        for rod in np.unique(ds["rod"].values):
            nodes = ds["position"].sel(node=ds["rod"] == rod).values
            panel.plot(nodes[:, h], nodes[:, v], marker=".", ms=3, lw=0.9, label=str(rod))
        panel.set_xlabel(f"{'xyz'[h]} [m]")
        panel.set_ylabel(f"{'xyz'[v]} [m]")
        panel.set_aspect("equal", adjustable="datalim")
    figure.suptitle(ds.attrs.get("title", ""))
    return figure, list(zip(axes[0], views, strict=True))


def _unit(variable: xr.DataArray) -> str:
    unit = variable.attrs.get("units", "")
    return f" {unit}" if unit not in ("", "1") else ""


def _fit_figure(ds: xr.Dataset) -> Figure:
    """A fit: the measured points on the fitted shape, with the fitted values."""
    data = ds["data_position"].values
    figure, views = _views(ds, data)
    for panel, (h, v) in views:
        panel.plot(data[:, h], data[:, v], ls="none", marker="x", color="k", ms=5,
                   label="measured points")
        panel.legend()
    fitted = ", ".join(f"{short_key(key)} = {float(key_variable(ds, key)):.5g} ± "
                       f"{float(key_variable(ds, key, 'standard_error')):.2g}"
                       f"{_unit(key_variable(ds, key))}"
                       for key in json.loads(ds.attrs["fit_parameters"]))
    views[0][0].set_title(textwrap.fill(f"fit: {fitted}; residual RMS "
                                        f"{ds.attrs['residual_rms']:.3g} m", 80))
    return figure


def _reach_figure(ds: xr.Dataset) -> Figure:
    """A reach: the shape that puts the tip nearest the target, the target and the tip."""
    target = ds["target"].values
    figure, views = _views(ds, target[None, :])
    tip = _first_rod_nodes(ds).values[-1]
    for panel, (h, v) in views:
        panel.plot(target[h], target[v], marker="*", ms=12, color="r", ls="none",
                   label="target")
        panel.plot(tip[h], tip[v], marker="o", mfc="none", ms=9, color="k", ls="none",
                   label="tip reached")
        panel.legend()
    values = ", ".join(f"{short_key(key)} = {float(key_variable(ds, key)):.5g}"
                       f"{_unit(key_variable(ds, key))}"
                       for key in json.loads(ds.attrs["reach_parameters"]))
    views[0][0].set_title(textwrap.fill(f"reach: {values}; distance "
                                        f"{ds.attrs['distance']:.3g} m", 80))
    return figure


DRAWERS = {"centerlines": _centerlines, "error_vs_parameter": _error_vs_parameter,
           "error_vs_iteration": _error_vs_iteration}
#: The measured result of each study figure, one line computed from the archive.
RESULTS = {"centerlines": _centerlines_result, "error_vs_parameter": _error_vs_parameter_result,
           "error_vs_iteration": _error_vs_iteration_result}
#: Figures of the inverse tools' archives, by their ``kind`` attribute.
KIND_DRAWERS = {"track": _track_figure, "fit": _fit_figure, "reach": _reach_figure}


def plot_dataset(ds: xr.Dataset, stem: str | Path, formats: Iterable[str] = ("png", "pdf")
                 ) -> list[Path]:
    """Draw the archive's figure and write ``stem.<format>`` for each format.

    The formats and the folder are checked first (:func:`check_output`); a format that
    fails to write (e.g. ``pgf`` without LaTeX) leaves no partial file. Raises
    :class:`PlotError`.
    """
    formats = check_output(stem, formats)
    ds = from_file(ds)
    html = HTML in formats
    formats = [fmt for fmt in formats if fmt != HTML]
    if html and "study" in ds.attrs:
        raise PlotError("the interactive 3D view (html) is drawn for run, track, fit and "
                        "reach archives, not studies")
    paths = []
    if html:
        try:
            paths.append(view3d.write_html(ds, _html_target(stem)))
        except OSError as exc:
            raise PlotError(f"cannot write {stem}.{HTML}: {exc.strerror or exc}") from None
    if not formats:
        return paths
    with warnings.catch_warnings():  # a character the font lacks is drawn as a box
        warnings.filterwarnings("ignore", message="Glyph .* missing from font",
                                category=UserWarning)
        with style():
            return _draw_and_write(ds, stem, formats) + paths


def _html_target(stem: str | Path) -> Path:
    try:
        return check_target(Path(f"{stem}.{HTML}"))
    except OutputError as exc:
        raise PlotError(str(exc)) from None


def three_dimensional(ds: xr.Dataset) -> bool:
    """Whether a run, track, fit or reach archive's shapes leave the x–y plane (then
    ``rodsim plot`` adds the interactive 3D view when plotly is installed)."""
    if "study" in ds.attrs or "position" not in ds:
        return False
    return _out_of_plane(ds["position"].values)


def style() -> contextlib.AbstractContextManager[None]:
    """rodsim's figure style (``rodsim/app/rodsim.mplstyle``: no text below 8 pt, readable
    lines, a colour cycle whose neighbours differ) for the figures drawn inside it."""
    return plt.style.context(STYLE)


def draw_figure(ds: xr.Dataset) -> Figure:
    """The archive's figure, not written (the caller closes it); draw it inside
    :func:`style`. A study figure's title states the measured result (:data:`RESULTS`).
    Raises :class:`PlotError` for an unknown plot kind. A Dataset opened with plain xarray
    from a schema 3 file gets its labels back first (:func:`rodsim.io.cf_layout.from_file`)."""
    ds = from_file(ds)
    if "study" in ds.attrs:
        kind = ds.attrs.get("plot", "centerlines")
        if kind not in DRAWERS:
            raise PlotError(f"unknown plot kind {kind!r}; known: {', '.join(DRAWERS)}")
        figure = DRAWERS[kind](ds)
        _title(figure, ds, RESULTS[kind](ds))
        return figure
    if ds.attrs.get("kind") in KIND_DRAWERS:
        return KIND_DRAWERS[ds.attrs["kind"]](ds)
    return _run_centerlines(ds)


def _draw_and_write(ds: xr.Dataset, stem: str | Path, formats: list[str]) -> list[Path]:
    """Draw the archive's figure and write it in each format (see :func:`plot_dataset`)."""
    figure = draw_figure(ds)
    paths = []
    try:
        for fmt in formats:
            path = Path(f"{stem}.{fmt}")
            try:
                target = check_target(path)  # a symbolic link's target
            except OutputError as exc:
                raise PlotError(str(exc)) from None
            temporary = target.with_name(f".{target.name}.{os.getpid()}.tmp")
            try:  # through a temporary: a failed write keeps any older figure intact
                if fmt == "png":
                    _save_png(figure, temporary)
                else:
                    figure.savefig(temporary, dpi=DPI, format=fmt)
                os.replace(temporary, target)
            except BaseException as exc:
                with contextlib.suppress(OSError):
                    temporary.unlink()
                if not isinstance(exc, Exception):
                    raise
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

