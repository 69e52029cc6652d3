"""The error study figures: ``error_vs_parameter`` (tip and area errors against the first
swept parameter, log–log, with the fitted order: Fig. 7, convergence studies) and
``error_vs_iteration`` (tip error per step: Fig. 8)."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from rodsim.app.figures import labels as lab
from rodsim.app.figures.study_centerlines import centerlines_figure
from rodsim.app.figures.style import LINE_STYLES, MARKERS, colours_for

__all__ = ["error_vs_parameter_figure", "error_vs_parameter_result",
           "error_vs_iteration_figure", "error_vs_iteration_result"]


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


def error_vs_parameter_figure(ds: xr.Dataset) -> Figure:
    """Tip error (top row, [1]) and area error (bottom row, [m]) against the first swept
    parameter: the two have different units, so they never share an axis."""
    dims = lab.sweep_dims(ds)
    if not dims:  # nothing swept: no parameter to plot against
        return centerlines_figure(ds)
    first = dims[0]
    panel_dims = [dims[-1]] if len(dims) >= 3 else []
    line_dims = [d for d in dims[1:] if d not in panel_dims]
    panel_groups = lab.grid_indices(ds, panel_dims)
    line_groups = lab.grid_indices(ds, line_dims)
    errors = [name for name in ERRORS if name in ds]  # a study without a reference has none
    figure, grid = _error_grid(len(panel_groups), max(len(errors), 1))
    x, _ = lab.axis_positions(ds, first)
    colours = colours_for(len(line_groups),
                          len(line_dims) == 1 and lab.is_numeric(ds, line_dims[0]))
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
                label = lab.point_label(ds, {d: lab.value_at(ds, d, i)
                                    for d, i in zip(line_dims, group, strict=True)})
                # Successive lines thinner, with their own marker: coinciding ones stay
                # visible.
                axes.plot(x, y, color=colours[n], marker=MARKERS[n % len(MARKERS)],
                          ls=LINE_STYLES[n % len(LINE_STYLES)], ms=max(3.0, 6.5 - n),
                          lw=max(1.0, 2.4 - 0.4 * n), label=label or "model")
                if name == "tip_error" and lab.is_numeric(ds, first):
                    _draw_fitted_order(axes, np.asarray(x, dtype=float), y, first,
                                       first_line=n == 0)
            axes.set_yscale("log")
            axes.grid(True, which="both", alpha=0.3)
            if row == 0:
                _panel_title(axes, ds, panel_select)
        grid[row, 0].set_ylabel(_error_label(ds, name))
    for axes in grid[-1]:
        lab.finish_x(axes, ds, first, log_ratio=2.0)  # log–log: orders of convergence
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
    ``MIN_LOCAL_ORDER`` (so a plateau is left out of the fit)."""
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
    falls (``_falling``), and that mask; NaN with fewer than two such points."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = _falling(x, y)
    if keep.sum() < 2 or np.ptp(x[keep]) == 0.0:
        return float("nan"), keep
    return float(-np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)[0]), keep


def error_vs_parameter_result(ds: xr.Dataset) -> str:
    """The observed order of the tip error in the first swept parameter (fitted for every
    line of the figure) and the smallest tip error, or what is plotted when there is
    nothing to fit."""
    dims = lab.sweep_dims(ds)
    if not dims or "tip_error" not in ds:
        return "tip and area errors against the swept parameter (none in this archive)"
    first = dims[0]
    error = ds["tip_error"].where(ds["status"] == 0)
    name = ds[first].attrs.get("long_name", first)
    if not lab.is_numeric(ds, first):
        return f"tip error / L {lab.span_text(error.values.ravel(), '.2g')} over {name}"
    others = dims[1:]
    x = ds[first].values.astype(float)
    fits = [_fitted_order(x, error.isel(dict(zip(others, group, strict=True))).values)
            for group in lab.grid_indices(ds, others)]
    orders = [p for p, _ in fits]
    fitted = np.any([mask for p, mask in fits if np.isfinite(p)], axis=0) if any(
        np.isfinite(orders)) else np.zeros(x.shape, dtype=bool)
    if not bool(error.notnull().any()):
        return f"no tip error: no point of {name} converged with a reference"
    best = error.where(error == error.min(), drop=True)
    where = lab.point_label(ds, {d: best[d].values.ravel()[0].item() for d in dims
                                 if d in best.dims})
    smallest = f"smallest {lab.percent_text(float(error.min()))} of L at {where}"
    if not fitted.any():
        return f"the tip error does not fall over {first}; {smallest}"
    lines = f" ({len(orders)} lines)" if len(orders) > 1 else ""
    levels = "" if fitted.all() else (f", then levels off (error of something else than "
                                      f"{first})")
    return (f"tip error / L ∝ {first}^−p with p = {lab.span_text(orders, '.2f')}{lines}, "
            "fitted where "
            f"it still falls: {first} = {lab.span_text(x[fitted])}{levels}; {smallest}")


def _panel_title(axes: plt.Axes, ds: xr.Dataset, panel_select: dict[str, int]) -> None:
    """Title a panel with the swept values it holds (nothing when there is one panel)."""
    if panel_select:
        axes.set_title(lab.point_label(ds, {d: lab.value_at(ds, d, i)
                                            for d, i in panel_select.items()}))


# Errors against the iteration ---------------------------------------------------------------


def error_vs_iteration_figure(ds: xr.Dataset) -> Figure:
    dims = lab.sweep_dims(ds)
    if "history_error" not in ds:  # the study kept no per-step history (history=False)
        figure = centerlines_figure(ds)
        figure.axes[0].text(0.02, 0.02, "no per-step history in this archive: centerlines "
                            "drawn instead", transform=figure.axes[0].transAxes)
        return figure
    line_dims, panel_dims = dims[:1], dims[1:]
    panel_groups = lab.grid_indices(ds, panel_dims)
    line_groups = lab.grid_indices(ds, line_dims)
    figure, panels = _panel_grid(len(panel_groups))
    colours = colours_for(len(line_groups), bool(line_dims) and lab.is_numeric(ds, line_dims[0]))
    for axes, panel in zip(panels, panel_groups, strict=True):
        panel_select = dict(zip(panel_dims, panel, strict=True))
        for n, group in enumerate(line_groups):
            select = panel_select | dict(zip(line_dims, group, strict=True))
            sub = ds.isel(select)
            error = sub["history_error"].values
            keep = ~np.isnan(error)
            steps = np.arange(1, len(error) + 1)
            label = lab.point_label(ds, {d: lab.value_at(ds, d, i) for d, i in zip(line_dims, group,
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


def error_vs_iteration_result(ds: xr.Dataset) -> str:
    """Steps to rest per value of the first swept parameter, for each value of the others;
    says so when the first parameter changes nothing."""
    if "history_error" not in ds:
        return "centerlines (no per-step history in this archive)"
    dims = lab.sweep_dims(ds)
    if not dims:
        return f"{int(_steps_taken(ds))} time steps to rest"
    steps = _steps_taken(ds)
    line_dim, panel_dims = dims[0], dims[1:]
    symbol = ds[line_dim].attrs.get("long_name", line_dim).split()[-1]
    groups = lab.grid_indices(ds, panel_dims)
    if len(groups) == 1 and ds.sizes[line_dim] <= 8:
        return "time steps to rest: " + ", ".join(
            f"{symbol} = {lab.value_text(lab.value_at(ds, line_dim, i))}: "
            f"{lab.span_text([float(v)], '.0f')}"
            for i, v in enumerate(steps.values.ravel()))
    parts, flat = [], True
    for group in groups:
        select = dict(zip(panel_dims, group, strict=True))
        values = steps.isel(select).values.ravel()
        flat &= bool(np.nanmin(values) == np.nanmax(values)) if np.isfinite(values).any() \
            else True
        parts.append(f"{lab.span_text(values, '.0f')} at "
                     + lab.point_label(ds, {d: lab.value_at(ds, d, i)
                                            for d, i in select.items()}))
    lead = f"{symbol} has no effect: " if flat else ""
    return f"{lead}time steps to rest for every {symbol}: " + "; ".join(parts)
