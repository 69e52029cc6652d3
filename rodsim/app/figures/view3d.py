"""An interactive 3D view of an archive as a standalone HTML file (plotly): the rods, the
tendons' paths and terminations, the obstacles (translucent), the loads and the contact
forces (``rodsim.app.figures.scene_parts``); a track is animated, one frame per step, and
a trajectory (``rodsim simulate``) one frame per output time, at most ``MAX_FRAMES``
evenly spaced as in its movie (a slider and a play button). As the run figure:
``colour`` colours the rods' (or, for tension, the tendons') line traces by their value
(``rodsim.app.figures.colouring``; a track's steps or a trajectory's frames on one shared
scale), with a colour bar titled with the quantity and its
unit; the traces of the layers ``hide`` (``rodsim.app.figures.layers``) are left out.

plotly is an optional extra (``pip install "rodsim[view3d]"``): without it
``available`` is False, ``rodsim plot`` writes its usual figures and says nothing about
HTML, and asking for ``--format html`` is a one-line error naming the extra. The page embeds
plotly's JavaScript, so it opens offline: rotate, zoom and hover over a control point to
read its rod, index and coordinates. With ``cdn`` (``rodsim plot --cdn``) the page loads
plotly's JavaScript from plotly's CDN instead: a much smaller file that needs the network
to open.

The view opens on the whole scene: the axes' ranges are the box around every node and
tendon point (every step of a track, every frame of a trajectory) with a margin, drawn to
equal scales (the aspect ratio of the box), and the camera looks at the box's centre from
``CAMERA_DIRECTION`` at the distance from which the box's bounding sphere fits in
plotly's 45° field of view with a margin (``fitted_camera``), the box taken as
spanning ± its aspect ratio in the scene's units (the larger of the two readings of
plotly's scene units: the view may open a little wide, never cropped).
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from rodsim.app.figures import layers
from rodsim.app.figures.colouring import ColouredLine, Colouring
from rodsim.app.figures.scene_parts import Arrow, SceneParts
from rodsim.app.figures.spacer_disks import Disk, disk_ring
from rodsim.app.figures.state_series import MAX_FRAMES, coloured_states, evenly
from rodsim.io.atomic import write_atomic

__all__ = ["available", "write_html", "view_figure", "fitted_camera", "MISSING",
           "FIELD_OF_VIEW"]

MISSING = ("the interactive 3D view (html) needs plotly: pip install plotly, or "
           "pip install \"rodsim[view3d]\"")
#: plotly's vertical field of view of a 3-D scene [rad] (its perspective camera).
FIELD_OF_VIEW = math.pi / 4
#: Where the camera looks from (a unit vector from the box's centre).
CAMERA_DIRECTION = np.array([1.0, -1.4, 0.9]) / np.linalg.norm([1.0, -1.4, 0.9])
#: The margin around the box (of its largest side) and on the camera's distance.
BOX_MARGIN, CAMERA_MARGIN = 0.08, 1.05
ROD, TENDONS, OBSTACLE, LOAD, CONTACT = ("#0072B2", ("#D55E00", "#E69F00", "#56B4E9",
                                                     "#CC79A7", "#000000"),
                                         "#888888", "#009E73", "#A50F15")


def available() -> bool:
    """Whether plotly is installed."""
    return importlib.util.find_spec("plotly") is not None


def _states(ds: xr.Dataset) -> tuple[list[int], list[str], str]:
    """The states the view shows (indices along the archive's step or time), each one's
    slider label and the slider's prefix: a track's steps (labelled by the ramped value),
    a trajectory's output times (at most ``MAX_FRAMES``, evenly spaced, the first and the
    last among them), else the archive's one state."""
    import json

    from rodsim.app.figures.inverse import short_key
    from rodsim.io.cf_layout import key_variable

    dims = ds["position"].dims
    if "step" in dims:
        count = int(ds.sizes["step"])
        ramp = next(iter(json.loads(ds.attrs["ramp_json"])), None) \
            if "ramp_json" in ds.attrs else None
        values = key_variable(ds, ramp).values if ramp else np.arange(count)
        prefix = f"{short_key(ramp) if ramp else 'step'} = "
        return list(range(count)), [f"{float(v):.4g}" for v in values], prefix
    if "time" in dims:
        picked = evenly(int(ds.sizes["time"]), MAX_FRAMES)
        times = ds["time"].values
        return picked, [f"{float(times[k]):.4g}" for k in picked], "t [s] = "
    return [0], [""], ""


def fitted_camera(points: np.ndarray) -> tuple[dict[str, Any], dict[str, Any]]:
    """The scene's axes (ranges, equal scales) and the camera that frames ``points`` (n, 3):
    (``scene`` layout entries, ``camera``). In plotly's scene units the box is taken to
    span ± its ``aspectratio`` (largest 1) about the origin; the eye sits at the distance
    r / sin(FOV/2) × margin from it, r = |aspectratio| the box's half diagonal."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = BOX_MARGIN * max(float(np.max(hi - lo)), 1e-9)
    lo, hi = lo - pad, hi + pad
    sides = hi - lo
    ratio = sides / float(np.max(sides))
    radius = float(np.linalg.norm(ratio))
    distance = CAMERA_MARGIN * radius / math.sin(FIELD_OF_VIEW / 2)
    eye = distance * CAMERA_DIRECTION
    axes = {f"{name}axis": {"range": [float(lo[k]), float(hi[k])], "title": f"{name} [m]",
                            "autorange": False}
            for k, name in enumerate("xyz")}
    scene = {**axes, "aspectmode": "manual",
             "aspectratio": {name: float(ratio[k]) for k, name in enumerate("xyz")}}
    camera = {"eye": {name: float(eye[k]) for k, name in enumerate("xyz")},
              "center": {"x": 0.0, "y": 0.0, "z": 0.0}, "up": {"x": 0.0, "y": 1.0, "z": 0.0}}
    return scene, camera


def _moving(parts: SceneParts, size: float, hide: frozenset[str] = frozenset(),
            colours: Colouring | None = None, scale: tuple[Any, Any] | None = None
            ) -> list[Any]:
    """The traces that move with the state: rods, tendons, terminations, arrows, but those
    of the layers ``hide``; the lines of ``colours`` coloured on ``scale``
    (``rodsim.app.figures.colouring.colour_scale``), the first with the colour bar."""
    import plotly.graph_objects as go

    traces: list[Any] = []
    lines = {} if colours is None else colours.lines
    for rod, nodes in {} if layers.SHAPE in hide else parts.rods.items():
        if rod in lines:
            assert colours is not None and scale is not None
            traces.append(_coloured(lines[rod], rod, colours.label, scale, 8,
                                    bar=not traces))
            continue
        traces.append(go.Scatter3d(
            x=nodes[:, 0], y=nodes[:, 1], z=nodes[:, 2], mode="lines+markers", name=rod,
            marker={"size": 3, "color": ROD}, line={"width": 6, "color": ROD},
            hovertemplate=(f"{rod} node %{{pointNumber}}<br>x %{{x:.5g}} m<br>"
                           "y %{y:.5g} m<br>z %{z:.5g} m<extra></extra>")))
    for index, tendon in enumerate([] if layers.TENDON in hide else parts.tendons):
        p, colour = tendon.points, TENDONS[index % len(TENDONS)]
        if tendon.name in lines:
            assert colours is not None and scale is not None
            traces.append(_coloured(lines[tendon.name], tendon.name, colours.label, scale, 5,
                                    bar=index == 0, dash="dash" if tendon.string else "solid"))
        else:
            traces.append(go.Scatter3d(
                x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="lines+markers", name=tendon.name,
                legendgroup=tendon.name, line={"width": 3, "color": colour,
                                                "dash": "dash" if tendon.string else "solid"},
                marker={"size": 1.5, "color": colour},
                hovertemplate=f"tendon {tendon.name}<extra></extra>"))
        traces.append(go.Scatter3d(
            x=p[-1:, 0], y=p[-1:, 1], z=p[-1:, 2], mode="markers", legendgroup=tendon.name,
            name=f"termination {tendon.name}", showlegend=False,
            marker={"size": 5, "symbol": "square-open", "color": colour}))
    if parts.disks and layers.TENDON not in hide:
        traces.append(_disk_trace(parts.disks))
    for arrows, colour, what, layer in ((parts.loads, LOAD, "loads", layers.LOAD),
                                        (parts.contacts, CONTACT, "contact forces",
                                         layers.CONTACT)):
        if layer not in hide:
            traces.append(_arrow_trace(arrows, 0.2 * size, colour, what))
    return traces


def _disk_trace(disks: list[Disk]) -> Any:
    """Every spacer disk as a thin ring (``rodsim.app.figures.spacer_disks.disk_ring``),
    one trace, the rings apart."""
    import plotly.graph_objects as go

    gap = np.full((1, 3), np.nan)
    rings = np.concatenate([np.concatenate([disk_ring(d), gap]) for d in disks])
    return go.Scatter3d(x=rings[:, 0], y=rings[:, 1], z=rings[:, 2], mode="lines",
                        name="spacer disks", line={"width": 2, "color": "#404040"},
                        hoverinfo="skip")


def _coloured(line: ColouredLine, name: str, label: str, scale: tuple[Any, Any], width: int,
              bar: bool, dash: str = "solid") -> Any:
    """A line trace of ``line``'s pieces, each in the colour of its value on ``scale``
    (norm, colormap): the pieces apart (NaN between them), both ends of a piece carrying
    its value; the colour bar titled ``label`` when ``bar``."""
    import plotly.graph_objects as go

    norm, cmap = scale
    count = len(line.pieces)
    points = np.concatenate([line.pieces, np.full((count, 1, 3), np.nan)], axis=1
                            ).reshape(-1, 3)
    values = np.repeat(line.values, 3)
    colorscale = [[float(x), "rgb({:.0f},{:.0f},{:.0f})".format(*(255 * np.array(cmap(x)[:3])))]
                  for x in np.linspace(0.0, 1.0, 11)]
    return go.Scatter3d(
        x=points[:, 0], y=points[:, 1], z=points[:, 2], mode="lines", name=name,
        line={"width": width, "color": values, "colorscale": colorscale,
              "cmin": float(norm.vmin), "cmax": float(norm.vmax), "showscale": bar,
              "colorbar": {"title": {"text": label}}, "dash": dash},
        customdata=values, hovertemplate=f"{name}<br>%{{customdata:.4g}} ({label})"
                                         "<extra></extra>")


def _arrow_trace(arrows: list[Arrow], length: float, colour: str, name: str) -> Any:
    """One trace of arrows (shafts with a marker at the head; the largest ``length``),
    loads starting at their point, contact forces ending there; empty when there are
    none. Each head carries its arrow's ``gid`` as its ``customdata`` (as the run figure
    names its artists)."""
    import plotly.graph_objects as go

    xyz: list[np.ndarray] = []
    text: list[str] = []
    gids: list[str] = []
    largest = max((float(np.linalg.norm(a.vector)) for a in arrows), default=0.0)
    for arrow in arrows:
        if largest == 0.0:
            break
        v = length / largest * arrow.vector
        tail, head = ((arrow.point - v, arrow.point) if arrow.gid.startswith("contact:")
                      else (arrow.point, arrow.point + v))
        unit = "N m" if arrow.moment else "N"
        xyz += [tail, head, np.full(3, np.nan)]
        text += ["", f"{arrow.label}: {np.linalg.norm(arrow.vector):.3g} {unit}", ""]
        gids += ["", arrow.gid, ""]
    points = np.array(xyz) if xyz else np.zeros((0, 3))
    return go.Scatter3d(x=points[:, 0], y=points[:, 1], z=points[:, 2], mode="lines+markers",
                        name=name, line={"width": 4, "color": colour}, text=text,
                        customdata=gids,
                        marker={"size": [0 if not t else 4 for t in text], "color": colour},
                        hovertemplate="%{text}<extra></extra>")


def _obstacles(parts: SceneParts, lower: np.ndarray, upper: np.ndarray) -> list[Any]:
    """The obstacles: a translucent surface, or their outlines in the three planes through
    the box's centre when the type has none."""
    import plotly.graph_objects as go

    traces: list[Any] = []
    middle = 0.5 * (lower + upper)
    for obstacle in parts.obstacles:
        mesh = obstacle.surface(lower, upper)
        name = f"{obstacle.type} {obstacle.name}"
        if mesh is not None:
            v, t = mesh
            traces.append(go.Mesh3d(x=v[:, 0], y=v[:, 1], z=v[:, 2], i=t[:, 0], j=t[:, 1],
                                    k=t[:, 2], opacity=0.2, color=OBSTACLE, name=name,
                                    showlegend=True, hoverinfo="name"))
            continue
        curves = [c for view in ((0, 1), (0, 2), (1, 2))
                  for c in obstacle.outline(view, float(middle[3 - sum(view)]), lower,
                                            upper)]
        joined = np.concatenate([np.vstack([c, np.full((1, 3), np.nan)]) for c in curves]
                                ) if curves else np.zeros((0, 3))
        traces.append(go.Scatter3d(x=joined[:, 0], y=joined[:, 1], z=joined[:, 2],
                                   mode="lines", name=name, line={"color": OBSTACLE}))
    return traces


def view_figure(ds: xr.Dataset, colour: str | None = None,
                hide: frozenset[str] = frozenset()) -> Any:
    """The plotly Figure of the run, fit, reach, track or trajectory archive ``ds``;
    ``colour`` and
    ``hide``: see the module docstring."""
    import plotly.graph_objects as go

    indices, labels, prefix = _states(ds)
    states, colourings, scale = coloured_states(ds, indices, colour)
    every = np.concatenate([p.points() for p in states])
    if "target" in ds:
        every = np.concatenate([every, ds["target"].values[None, :]])
    if "data_position" in ds:
        every = np.concatenate([every, ds["data_position"].values])
    scene, camera = fitted_camera(every)
    lower = np.array([scene[f"{n}axis"]["range"][0] for n in "xyz"])
    upper = np.array([scene[f"{n}axis"]["range"][1] for n in "xyz"])
    size = float(np.max(upper - lower))
    last = states[-1]
    frames = [_moving(parts, size, hide, colours, scale)
              for parts, colours in zip(states, colourings, strict=True)]
    figure = go.Figure(frames[-1])
    moving = len(figure.data)
    for trace in [] if layers.OBSTACLE in hide else _obstacles(last, lower, upper):
        figure.add_trace(trace)
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
    figure.update_layout(title=str(ds.attrs.get("title", "rodsim")),
                         scene={**scene, "camera": camera},
                         margin={"l": 0, "r": 0, "t": 40, "b": 0})
    if len(states) > 1:
        _animate(figure, frames, moving, labels, prefix)
    return figure


def _animate(figure: Any, states: list[list[Any]], moving: int, labels: list[str],
             prefix: str) -> None:
    """One frame per state shown (its moving traces ``states``), a slider (its steps
    ``labels``, its value shown after ``prefix``) and a play button; the figure opens on
    the last state."""
    import plotly.graph_objects as go

    names = [f"{k}" for k in range(len(states))]
    figure.frames = [go.Frame(data=traces, traces=list(range(moving)), name=name)
                     for traces, name in zip(states, names, strict=True)]
    play = {"label": "play", "method": "animate",
            "args": [None, {"frame": {"duration": 150, "redraw": True}, "fromcurrent": True,
                            "transition": {"duration": 0}}]}
    pause = {"label": "pause", "method": "animate",
             "args": [[None], {"frame": {"duration": 0, "redraw": False},
                               "mode": "immediate"}]}
    figure.update_layout(
        updatemenus=[{"type": "buttons", "buttons": [play, pause], "x": 0.0, "y": 0.0,
                      "xanchor": "left", "yanchor": "bottom", "direction": "left"}],
        sliders=[{"active": len(states) - 1, "currentvalue": {"prefix": prefix},
                  "x": 0.15, "len": 0.85, "y": 0.0,
                  "steps": [{"label": label, "method": "animate",
                             "args": [[name], {"frame": {"duration": 0, "redraw": True},
                                               "mode": "immediate"}]}
                            for label, name in zip(labels, names, strict=True)]}])


def write_html(ds: xr.Dataset, path: str | Path, colour: str | None = None,
               hide: frozenset[str] = frozenset(), cdn: bool = False) -> Path:
    """Write the 3D view of the run, fit, reach, track or trajectory archive ``ds`` to
    ``path`` (``colour``, ``hide``: ``view_figure``): plotly's JavaScript embedded (opens
    offline), or with ``cdn`` a script tag that loads it from plotly's CDN."""
    figure = view_figure(ds, colour, hide)
    path = Path(path)
    write_atomic(path, lambda temporary: figure.write_html(
        temporary, include_plotlyjs="cdn" if cdn else True, full_html=True),
        follow_umask=True)
    return path
