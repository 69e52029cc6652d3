"""Figures from archives: every plot is drawn from a Dataset alone (run or study).

``plot_dataset(ds, stem)`` picks the figure from the archive's ``plot`` attribute (studies)
or draws the centerlines of a single run, and writes ``stem.png`` and ``stem.pdf``.
Kinds:

- ``centerlines``: the first rod's centerline at every point, one line per point (Figs. 6,
  9, 14–18, 22); the analytic reference when the study has one.
- ``error_vs_parameter``: tip and area errors against the first swept parameter, log–log
  (Fig. 7, convergence studies), one line per value of the other swept parameters.
- ``error_vs_iteration``: tip error against the reference per step (Fig. 8).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

__all__ = ["plot_dataset", "PLOT_KINDS"]

PLOT_KINDS = ("centerlines", "error_vs_parameter", "error_vs_iteration")


def _label(ds: xr.Dataset, point: dict[str, object]) -> str:
    parts = []
    for dim, value in point.items():
        units = ds[dim].attrs.get("units", "1")
        unit = "" if units in ("1", "-") else f" {units}"
        text = f"{value:g}" if isinstance(value, (int, float, np.number)) else str(value)
        parts.append(f"{dim} = {text}{unit}")
    return ", ".join(parts)


def _sweep_dims(ds: xr.Dataset) -> list[str]:
    return [d for d in ds["status"].dims]


def _points(ds: xr.Dataset) -> Iterable[dict[str, object]]:
    dims = _sweep_dims(ds)
    for index in np.ndindex(*(ds.sizes[d] for d in dims)):
        yield {d: ds[d].values[i].item() for d, i in zip(dims, index, strict=True)}


def _centerlines(ds: xr.Dataset, axes: plt.Axes) -> None:
    rod = ds["rod"].values[0]
    for point in _points(ds):
        sel = ds.sel(point)
        if int(sel["status"]) != 0:
            continue
        line = sel["centerline"].sel(rod=rod).values
        axes.plot(line[:, 0], line[:, 1], marker=".", markersize=3, label=_label(ds, point))
    axes.set_xlabel("x [m]")
    axes.set_ylabel("y [m]")
    axes.set_aspect("equal", adjustable="datalim")
    axes.legend(fontsize=7)


def _error_vs_parameter(ds: xr.Dataset, axes: plt.Axes) -> None:
    dims = _sweep_dims(ds)
    first, others = dims[0], dims[1:]
    x = ds[first].values
    groups = list(np.ndindex(*(ds.sizes[d] for d in others))) if others else [()]
    for group in groups:
        select = {d: i for d, i in zip(others, group, strict=True)}
        sub = ds.isel(select)
        suffix = _label(ds, {d: ds[d].values[i].item() for d, i in select.items()})
        for name, style in (("tip_error", "o-"), ("area_error", "s--")):
            y = sub[name].values
            if np.all(np.isnan(y)):
                continue
            axes.loglog(x, y, style, label=f"{name.replace('_', ' ')} {suffix}".strip())
    units = ds[first].attrs.get("units", "1")
    axes.set_xlabel(f"{ds[first].attrs.get('long_name', first)}"
                    + ("" if units in ("1", "-") else f" [{units}]"))
    axes.set_ylabel("error / L")
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=7)


def _error_vs_iteration(ds: xr.Dataset, axes: plt.Axes) -> None:
    for point in _points(ds):
        error = ds["history_error"].sel(point).values
        steps = np.arange(1, len(error) + 1)
        keep = ~np.isnan(error)
        axes.semilogy(steps[keep], error[keep], label=_label(ds, point))
    axes.set_xlabel("iteration (time step)")
    axes.set_ylabel(f"tip error against the {ds.attrs.get('reference')} reference / L")
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=7)


def _run_centerlines(ds: xr.Dataset, axes: plt.Axes) -> None:
    for rod in np.unique(ds["rod"].values):
        nodes = ds["position"].sel(node=ds["rod"] == rod).values
        axes.plot(nodes[:, 0], nodes[:, 1], marker=".", label=str(rod))
    axes.set_xlabel("x [m]")
    axes.set_ylabel("y [m]")
    axes.set_aspect("equal", adjustable="datalim")
    axes.legend(fontsize=7)


def plot_dataset(ds: xr.Dataset, stem: str | Path, formats: Iterable[str] = ("png", "pdf")
                 ) -> list[Path]:
    """Draw the archive's figure and write ``stem.<format>`` for each format."""
    figure, axes = plt.subplots(figsize=(6.4, 4.8), constrained_layout=True)
    if "study" in ds.attrs:
        kind = ds.attrs.get("plot", "centerlines")
        drawers = {"centerlines": _centerlines, "error_vs_parameter": _error_vs_parameter,
                   "error_vs_iteration": _error_vs_iteration}
        if kind not in drawers:
            raise ValueError(f"unknown plot kind {kind!r}; known: {', '.join(drawers)}")
        drawers[kind](ds, axes)
        axes.set_title(f"{ds.attrs['study']}: {ds.attrs['paper']}", fontsize=8)
    else:
        _run_centerlines(ds, axes)
        axes.set_title(ds.attrs.get("title", ""), fontsize=8)
    paths = []
    for fmt in formats:
        path = Path(f"{stem}.{fmt}")
        figure.savefig(path, dpi=120)
        paths.append(path)
    plt.close(figure)
    return paths
