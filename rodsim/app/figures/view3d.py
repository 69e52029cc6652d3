"""An interactive 3D view of an archive's rods as a standalone HTML file (plotly).

plotly is an optional extra (``pip install "rodsim[view3d]"``): without it
:func:`available` is False, ``rodsim plot`` writes its usual figures and says nothing about
HTML, and asking for ``--format html`` is a one-line error naming the extra. The page embeds
plotly's JavaScript, so it opens offline: rotate, zoom and hover over a control point to
read its rod, index and coordinates. Axes have equal scales (``aspectmode = "data"``): a
bend looks as large as it is.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import xarray as xr

from rodsim.io.atomic import write_atomic

__all__ = ["available", "write_html", "MISSING"]

MISSING = ("the interactive 3D view (html) needs plotly: pip install plotly, or "
           "pip install \"rodsim[view3d]\"")


def available() -> bool:
    """Whether plotly is installed."""
    return importlib.util.find_spec("plotly") is not None


def _shapes(ds: xr.Dataset) -> dict[str, np.ndarray]:
    """Each rod's control points (N × 3, m); a track's last step."""
    positions = ds["position"]
    if "step" in positions.dims:
        positions = positions.isel(step=-1)
    rods = ds["rod"].values.astype(str)
    return {rod: positions.values[rods == rod] for rod in dict.fromkeys(rods)}


def write_html(ds: xr.Dataset, path: str | Path) -> Path:
    """Write the 3D view of the run, fit, reach or track archive ``ds`` to ``path``."""
    import plotly.graph_objects as go

    figure = go.Figure()
    for rod, nodes in _shapes(ds).items():
        figure.add_trace(go.Scatter3d(
            x=nodes[:, 0], y=nodes[:, 1], z=nodes[:, 2], mode="lines+markers", name=rod,
            marker={"size": 3}, line={"width": 5},
            hovertemplate=(f"{rod} node %{{pointNumber}}<br>x %{{x:.5g}} m<br>"
                           "y %{y:.5g} m<br>z %{z:.5g} m<extra></extra>")))
    if "target" in ds:
        target = ds["target"].values
        figure.add_trace(go.Scatter3d(x=[target[0]], y=[target[1]], z=[target[2]],
                                      mode="markers", name="target",
                                      marker={"size": 6, "symbol": "diamond"}))
    if "data_position" in ds:
        data = ds["data_position"].values
        figure.add_trace(go.Scatter3d(x=data[:, 0], y=data[:, 1], z=data[:, 2],
                                      mode="markers", name="measured points",
                                      marker={"size": 3, "symbol": "x"}))
    figure.update_layout(
        title=str(ds.attrs.get("title", "rodsim")),
        scene={"xaxis_title": "x [m]", "yaxis_title": "y [m]", "zaxis_title": "z [m]",
               "aspectmode": "data"},
        margin={"l": 0, "r": 0, "t": 40, "b": 0})
    path = Path(path)
    write_atomic(path, lambda temporary: figure.write_html(
        temporary, include_plotlyjs=True, full_html=True), follow_umask=True)
    return path
