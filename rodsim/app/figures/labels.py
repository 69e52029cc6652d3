"""What a study figure reads from its archive's coordinates: the swept dimensions, their
values, labels with units, x axes (log where a sweep spans decades), titles and short texts
of numbers."""

from __future__ import annotations

import textwrap
from collections.abc import Iterable, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

__all__ = ["sweep_dims", "value_at", "is_numeric", "value_text", "point_label", "axis_label",
           "grid_indices", "log_axis", "axis_positions", "finish_x", "study_title",
           "span_text", "percent_text"]


def sweep_dims(ds: xr.Dataset) -> list[str]:
    return [str(dim) for dim in ds["status"].dims]


def value_at(ds: xr.Dataset, dim: str, i: int) -> Any:
    return ds[dim].values[i].item()


def is_numeric(ds: xr.Dataset, dim: str) -> bool:
    return np.issubdtype(ds[dim].dtype, np.number)


def value_text(value: Any) -> str:
    return f"{value:g}" if isinstance(value, (int, float, np.number)) else str(value)


def point_label(ds: xr.Dataset, point: dict[str, object]) -> str:
    parts = []
    for dim, value in point.items():
        units = ds[dim].attrs.get("units", "1")
        unit = "" if units in ("1", "-") else f" {units}"
        parts.append(f"{dim} = {value_text(value)}{unit}")
    return ", ".join(parts)


def axis_label(ds: xr.Dataset, dim: str) -> str:
    units = ds[dim].attrs.get("units", "1")
    return ds[dim].attrs.get("long_name", dim) + ("" if units in ("1", "-") else f" [{units}]")


def grid_indices(ds: xr.Dataset, dims: Sequence[str]) -> list[tuple[int, ...]]:
    return list(np.ndindex(*(ds.sizes[d] for d in dims))) if dims else [()]


def log_axis(values: np.ndarray, ratio: float = 20.0) -> bool:
    """Log scale for a positive numeric axis spanning at least a factor ``ratio``."""
    values = np.asarray(values, dtype=float)
    return bool(np.all(values > 0.0) and values.max() >= ratio * values.min())


def axis_positions(ds: xr.Dataset, dim: str) -> tuple[np.ndarray, list[str] | None]:
    """x positions of ``dim``'s values, and tick labels when they are not numbers."""
    if is_numeric(ds, dim):
        return ds[dim].values.astype(float), None
    return np.arange(ds.sizes[dim], dtype=float), [str(v) for v in ds[dim].values]


def finish_x(axes: plt.Axes, ds: xr.Dataset, dim: str, log_ratio: float = 20.0) -> None:
    x, ticks = axis_positions(ds, dim)
    if ticks is not None:
        axes.set_xticks(x, ticks)
        axes.set_xlim(x[0] - 0.5, x[-1] + 0.5)
    elif log_axis(x, log_ratio):
        axes.set_xscale("log")
        if len(x) <= 12 and x.max() < 100.0 * x.min():  # few decades: label the values
            axes.set_xticks(x, [value_text(v) for v in ds[dim].values])
            axes.xaxis.set_minor_formatter(NullFormatter())
    axes.set_xlabel(axis_label(ds, dim))


def study_title(figure: Figure, ds: xr.Dataset, result: str) -> None:
    """The study's name and size, the measured result (one line computed from the archive)
    and the paper's claim it is compared with."""
    width = max(40, int(12 * figure.get_figwidth()))  # characters of 10-pt text per line
    lines = [f"{ds.attrs['study']} ({ds.attrs.get('size', '')}) — measured: {result}"]
    if ds.attrs.get("paper"):
        lines.append(str(ds.attrs["paper"]))
    figure.suptitle("\n".join(textwrap.fill(line, width) for line in lines))


def span_text(values: Iterable[float], fmt: str = "g") -> str:
    """``a–b`` of the finite values (``a`` when they are all equal, ``n/a`` when none is)."""
    finite = [v for v in values if np.isfinite(v)]
    if not finite:
        return "n/a"
    low, high = format(min(finite), fmt), format(max(finite), fmt)
    return low if low == high else f"{low}–{high}"


def percent_text(value: float) -> str:
    return f"{100.0 * value:.2g} %"
