"""The ``centerlines`` study figure (Figs. 6, 9, 14–18, 22): the first rod's centerline at
every point with the study's analytic reference, and the tip against the first numeric
swept parameter."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from rodsim.app.figures import labels as lab
from rodsim.app.figures.references import draw_references
from rodsim.app.figures.style import LINE_STYLES, MARKERS, colours_for

__all__ = ["centerlines_figure", "centerlines_result", "MIN_TIP_RANGE"]


def _tip_error_text(sel: xr.Dataset) -> str:
    error = float(sel["tip_error"]) if "tip_error" in sel else float("nan")
    return f" (tip error {100 * error:.2g} % L)" if np.isfinite(error) and error > 0 else ""


def _point_styles(ds: xr.Dataset) -> dict[tuple[int, ...], dict[str, Any]]:
    """Colour, line style and marker of every grid point: the colour follows the last swept
    parameter with more than one value, the style the others (Fig. 9: colour = mass)."""
    dims = lab.sweep_dims(ds)
    varying = [d for d in dims if ds.sizes[d] > 1] or dims
    colour_dim = varying[-1] if varying else None
    style_dims = [d for d in dims if d != colour_dim]
    colours = (colours_for(ds.sizes[colour_dim], lab.is_numeric(ds, colour_dim))
               if colour_dim else ["C0"])
    styles = {index: n for n, index in enumerate(lab.grid_indices(ds, style_dims))}
    out = {}
    for index in lab.grid_indices(ds, dims):
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
    """How many of the (σ, 3) centerlines lie within ``COINCIDE`` of the drawing's span
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
    dims = lab.sweep_dims(ds)
    styles = _point_styles(ds)
    varying = [d for d in dims if ds.sizes[d] > 1] or dims
    colour_dim = varying[-1]
    style_dims = [d for d in dims if d != colour_dim]
    handles, labels = [h for h in axes.get_legend_handles_labels()[0]], \
        list(axes.get_legend_handles_labels()[1])
    for i in range(ds.sizes[colour_dim]):
        index = tuple(i if d == colour_dim else 0 for d in dims)
        handles.append(Line2D([], [], color=styles[index]["color"], lw=2))
        labels.append(lab.point_label(ds, {colour_dim: lab.value_at(ds, colour_dim, i)}))
    groups = lab.grid_indices(ds, style_dims)
    if style_dims and len(groups) <= LEGEND_POINTS:
        for group in groups:
            select = dict(zip(style_dims, group, strict=True))
            index = tuple(select.get(d, 0) for d in dims)
            handles.append(Line2D([], [], color="0.4", ls=styles[index]["ls"],
                                  marker=styles[index]["marker"], ms=3))
            labels.append(lab.point_label(ds, {d: lab.value_at(ds, d, i)
                                               for d, i in select.items()}))
    axes.legend(handles, labels, loc="best")


def centerlines_figure(ds: xr.Dataset) -> Figure:
    dims = lab.sweep_dims(ds)
    numeric = [d for d in dims if lab.is_numeric(ds, d) and ds.sizes[d] > 1]
    tip_dim = numeric[0] if numeric else (dims[0] if dims else None)
    figure, (axes, tips) = plt.subplots(1, 2, figsize=(11.0, 5.0), width_ratios=(1.6, 1.0),
                                        constrained_layout=True)
    references = draw_references(ds, axes)
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
        label = lab.point_label(ds, {d: lab.value_at(ds, d, i) for d, i in point.items()})
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
    dims = lab.sweep_dims(ds)
    others = [d for d in dims if d != dim]
    x, _ = lab.axis_positions(ds, dim)
    tip_y = ds["tip"].isel(rod=0).sel(axis="y").where(ds["status"] == 0)
    for n, group in enumerate(lab.grid_indices(ds, others)):
        select = dict(zip(others, group, strict=True))
        y = tip_y.isel(select).values
        indices = [tuple(i if d == dim else select[d] for d in dims)
                   for i in range(ds.sizes[dim])]
        label = (lab.point_label(ds, {d: lab.value_at(ds, d, i) for d, i in select.items()})
                 or "model")
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
    lab.finish_x(axes, ds, dim)
    axes.set_ylabel("tip y [m]")
    _show_size_of_change(axes, ds, tip_y.values)
    axes.grid(True, which="both", alpha=0.3)
    if len(lab.grid_indices(ds, others)) <= LEGEND_POINTS:
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
    """No offset notation, a y range of at least ``MIN_TIP_RANGE`` L around the values,
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


def centerlines_result(ds: xr.Dataset) -> str:
    """The largest tip error against the reference (per value of the first swept parameter
    when there are two or more), or the range of the tip's y without a reference."""
    dims = lab.sweep_dims(ds)
    ok = ds["status"] == 0
    error = ds["tip_error"].where(ok) if "tip_error" in ds else None
    if error is not None and bool(error.notnull().any()):
        reference = ds.attrs.get("reference")
        against = (f"the last {dims[0]} point" if reference == "last"
                   else f"the {reference} reference")
        if len(dims) >= 2 and ds.sizes[dims[0]] > 1:
            parts = [f"{lab.point_label(ds, {dims[0]: lab.value_at(ds, dims[0], i)})}: "
                     + (lab.percent_text(float(error.isel({dims[0]: i}).max()))
                        if bool(error.isel({dims[0]: i}).notnull().any())
                        else f"no {reference} reference")
                     for i in range(ds.sizes[dims[0]])]
        else:
            parts = [f"{lab.percent_text(float(error.max()))} over "
                     f"{int(error.notnull().sum())} points"]
        return f"largest tip error / L against {against}: " + "; ".join(parts)
    tip_y = ds["tip"].isel(rod=0).sel(axis="y").where(ok).values.ravel()
    finite = tip_y[np.isfinite(tip_y)]
    if finite.size == 0:
        return "no point converged"
    change = float(finite.max() - finite.min())
    return (f"tip y of {ds['rod'].values[0]} {lab.span_text(finite, '.3g')} m over {finite.size} "
            f"points (a change of {_length_text(change)})")
