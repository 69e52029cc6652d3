"""The figures of a single run and of the inverse tools' archives (``track``, ``fit``,
``reach``: docs/inverse.md): the rods in x–y, and in x–z and y–z when the shape leaves the
x–y plane; with tendon friction also the tension along each tendon (a run) or at each
termination against the ramp (a track: the pull–release loop)."""

from __future__ import annotations

import json
import textwrap

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from rodsim.app.figures import layers
from rodsim.app.figures.colouring import colour_scale, colouring
from rodsim.app.figures.projections import panel_grid, projections
from rodsim.app.figures.ramp_legs import Leg, hysteresis, ramp_legs
from rodsim.app.figures.scene_drawing import draw_parts
from rodsim.app.figures.scene_parts import scene_parts
from rodsim.app.figures.state_series import (
    colour_bar,
    coloured_states,
    draw_states,
    evenly,
    tint_bar,
    tints,
)
from rodsim.io.cf_layout import key_variable

__all__ = ["run_figure", "track_figure", "fit_figure", "reach_figure", "short_key"]

#: The colour map of a track's steps.
STEPS = plt.get_cmap("viridis")

def _tip_text(ds: xr.Dataset) -> str:
    """The first rod's tip, computed from the positions (mm)."""
    tip = _first_rod_nodes(ds).values[-1]
    return (f"tip of {ds['rod'].values[0]}: x, y, z = "
            + ", ".join(f"{1e3 * v:.4g}" for v in tip) + " mm")


def run_figure(ds: xr.Dataset, colour: str | None = None,
               hide: frozenset[str] = frozenset()) -> Figure:
    """A run: its rods, tendons (paths, routing points, terminations), obstacles, loads
    and contact forces (``rodsim.app.figures.scene_drawing``) in x–y, and in x–z and
    y–z too when the scene leaves the x–y plane (with tendon friction, a last panel: the
    tension along each tendon); the title names the tip, computed from the positions.
    ``colour``: the rods (or the tendons) coloured by curvature, strain or tension, with a
    colour bar (``rodsim.app.figures.colouring``); ``hide``: the layers left out
    (``rodsim.app.figures.layers``)."""
    friction = "tension_profile" in ds
    parts = scene_parts(ds)
    colours = colouring(ds, colour, parts) if colour else None
    views = projections(parts.points())
    count = len(views)
    panels = count + int(friction)
    figure, axes = plt.subplots(1, panels, figsize=(4.2 * panels + 0.6 if panels > 1
                                                    else 6.4, 5.2),
                                constrained_layout=True, squeeze=False)
    for panel, view in zip(axes[0][:count], views, strict=True):
        draw_parts(panel, parts, view, hide=hide, colours=colours)
    if colours is not None:
        colour_bar(figure, list(axes[0][:count]), colours, colour_scale(colours),
                   shrink=0.9 if panels == 1 else 0.5,
                   location="right" if panels == 1 else "bottom")
    if friction:
        _tension_along(axes[0][-1], ds)
    handles, names = axes[0][0].get_legend_handles_labels()
    if names:
        figure.legend(handles, names, loc="outside lower center",
                      ncols=min(len(names), 4 if panels > 1 else 3))
    figure.suptitle(f"{ds.attrs.get('title', '')}\n{_tip_text(ds)}")
    return figure


# Inverse tools (docs/inverse.md) --------------------------------------------------------


def _first_rod_nodes(ds: xr.Dataset) -> xr.DataArray:
    first = ds["rod"].values[0]
    return ds["position"].sel(node=ds["rod"] == first)


#: The most steps whose shapes a track's figure draws: evenly chosen, with every step where
#: the ramp turns (a 121-step insertion drew 121 catheters over each other); the tip's
#: path and the response panels keep every step.
TRACK_SHAPES = 24


def drawn_steps(values: np.ndarray, legs: list[Leg]) -> list[int]:
    """The steps of a track (its ramped ``values``, their ``legs``) whose shapes are drawn:
    ``TRACK_SHAPES`` evenly chosen, the first and last among them, and each leg's ends."""
    ends = {int(end) for leg in legs for end in (leg.steps[0], leg.steps[-1])}
    return sorted(set(evenly(len(values), TRACK_SHAPES)) | ends)


def track_figure(ds: xr.Dataset, colour: str | None = None,
                 hide: frozenset[str] = frozenset()) -> Figure:
    """A track: its steps (all, or ``TRACK_SHAPES`` of a long one: ``drawn_steps``) drawn
    as the run figure draws its state
    (``rodsim.app.figures.state_series``: every rod, tendon path and spacer disk, the last
    step with its loads, contact forces and obstacles) with the tip's path through them,
    and the tip's displacement from step 0 against the first ramped value, the actuation
    against the response (``rodsim.app.figures.ramp_legs``: a ramp that rises and falls is
    drawn leg by leg, solid rising and dashed falling; the title states the hysteresis, the
    largest tip distance at equal actuation); with friction a third panel, the termination
    tension against the ramp (the pull–release loop). Each step in one colour, by its
    ramped value (by its step on a ramp that turns), with a colour bar; with ``colour``,
    the lines coloured by that quantity on one scale shared by the steps instead. ``hide``:
    the layers left out. The shapes are drawn in x–y, and in x–z and y–z too when what is
    drawn leaves the x–y plane (the run figure's rule, ``rodsim.app.figures.projections``):
    then the projections fill a first row and the other panels a second."""
    friction = "tension_profile" in ds
    nodes = _first_rod_nodes(ds).values
    ramp = list(json.loads(ds.attrs["ramp_json"]))[0]
    values = key_variable(ds, ramp).values
    legs = ramp_legs(values)
    picked = drawn_steps(values, legs)
    states, colourings, scale = coloured_states(ds, picked, colour)
    views = projections(np.concatenate([parts.points() for parts in states]))
    figure, shapes, (tips, *loop) = panel_grid(views, 1 + friction, True,
                                               (10.0 + 4.6 * friction, 4.4))
    panels = list(zip(shapes, views, strict=True))
    if layers.SHAPE not in hide:
        for panel, (a, b) in panels:
            panel.plot(nodes[:, -1, a], nodes[:, -1, b], color="k", lw=0.8, marker="o",
                       ms=2.5, zorder=6, gid="tip-path", label="tip path (o: each step)")
    by, label = _step_scale(ds, ramp, values, legs)
    tinted, norm = tints(by, STEPS)
    drawn = draw_states(panels, states, colourings, scale, hide,
                        None if colour else [tinted[k] for k in picked])
    if drawn is not None:
        colour_bar(figure, shapes, *drawn)
    else:
        tint_bar(figure, shapes, norm, STEPS, label, "step")
    shapes[0].set_title(f"each of {len(values)} steps" if len(picked) == len(values)
                        else f"{len(picked)} of {len(values)} steps")
    contact = _track_contact(panels, ds, hide)
    _response(tips, ds, nodes[:, -1], values, legs)
    tips.set_xlabel(_ramp_label(ds, ramp))
    if friction:
        _termination_loop(loop[0], ds, values, _ramp_label(ds, ramp))
    last = nodes[-1, -1] if len(values) else np.full(3, np.nan)
    unit = key_variable(ds, ramp).attrs.get("units", "")
    cycle = hysteresis(values, nodes[:, -1])
    apart = ("" if cycle is None else f"\nhysteresis: the tip {1e3 * cycle.distance:.3g} mm "
             f"apart at equal {short_key(ramp)} (steps {cycle.first} and {cycle.second})")
    figure.suptitle(f"{ds.attrs.get('title', '')}\ntip of {ds['rod'].values[0]} at "
                    f"{short_key(ramp)} = {values[-1]:.4g} {unit}: x, y, z = "
                    + ", ".join(f"{1e3 * v:.4g}" for v in last) + " mm" + contact + apart)
    return figure


def _track_contact(panels: list[tuple[plt.Axes, tuple[int, int]]], ds: xr.Dataset,
                   hide: frozenset[str]) -> str:
    """The title's words on a track's contact forces (its last step's, drawn by
    ``draw_states``); each shape panel's aspect held equal."""
    for panel, _ in panels:
        panel.set_aspect("equal", adjustable="datalim")
    pressed = "contact_force" in ds and int(ds.sizes.get("step", 0)) > 0
    if pressed and layers.CONTACT not in hide:
        resultant = float(np.linalg.norm(ds["contact_resultant"].values[-1]))
        return f"; contact resultant {1e3 * resultant:.3g} mN (the last step's forces)"
    return ""


def _step_scale(ds: xr.Dataset, ramp: str, values: np.ndarray, legs: list[Leg]
                ) -> tuple[np.ndarray, str]:
    """What colours a track's steps and the colour bar's label: the ramped value on a
    ramp of one leg, the step on a ramp that turns (the same value on two legs)."""
    if len(legs) > 1:
        turns = " → ".join(f"{values[leg.steps[0]]:g}" for leg in legs)
        unit = key_variable(ds, ramp).attrs.get("units", "")
        return (np.arange(len(values), dtype=float),
                f"step ({turns} → {values[-1]:g} {unit})")
    return np.asarray(values, dtype=float), _ramp_label(ds, ramp)


def _response(panel: plt.Axes, ds: xr.Dataset, tips: np.ndarray, values: np.ndarray,
              legs: list[Leg]) -> None:
    """The tip's displacement from step 0 [m] against the ramped value, each coordinate
    that moves (all three when none does), leg by leg: solid rising, dashed falling; each
    line's gid ``response:<axis>:<leg index>``."""
    moved = tips - tips[:1]
    size = max(float(np.max(np.abs(moved), initial=0.0)), 1e-300)
    shown = [k for k in range(3) if np.ptp(moved[:, k]) > 1e-6 * size] or [0, 1, 2]
    seen: set[str] = set()
    for k in shown:
        for index, leg in enumerate(legs):
            label = f"tip {'xyz'[k]}" + ("" if len(legs) == 1 else
                                          (", rising" if leg.rises else ", falling"))
            panel.plot(values[leg.steps], moved[leg.steps, k], color=f"C{k}", marker=".",
                       ms=4, ls="-" if leg.rises else "--", gid=f"response:{'xyz'[k]}:{index}",
                       label=None if label in seen else label)
            seen.add(label)
    panel.set_ylabel("tip displacement from step 0 [m]")
    panel.set_title("actuation against response")
    panel.legend(loc="best", fontsize="small")


def _termination_loop(panel: plt.Axes, ds: xr.Dataset, values: np.ndarray, label: str
                      ) -> None:
    """Each friction tendon's termination tension (its last chord's) against the ramped
    value, step after step: the pull–release loop and its dead zone."""
    tendons = ds["chord_tendon"].values.astype(str)
    for name in dict.fromkeys(tendons):
        last = np.flatnonzero(tendons == name)[-1]
        panel.plot(values, ds["tension_profile"].values[:, last], marker=".", ms=4, lw=0.9,
                   label=f"{name} at its termination")
    panel.set_xlabel(label)
    panel.set_ylabel("tendon tension [N]")
    panel.set_title("termination tension (friction)")
    panel.legend(loc="best")


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


def _tension_along(panel: plt.Axes, ds: xr.Dataset) -> None:
    """The tension of each chord of every tendon with friction against its arc length."""
    tendons = ds["chord_tendon"].values.astype(str)
    for name in dict.fromkeys(tendons):
        mine = tendons == name
        panel.plot(ds["chord_s"].values[mine], ds["tension_profile"].values[mine],
                   marker=".", ms=3, lw=0.9, label=name)
    panel.set_xlabel("rest arc length s [m]")
    panel.set_ylabel("tendon tension [N]")
    panel.set_title("tension along the tendons (friction)")
    panel.legend(loc="best")


def _views(ds: xr.Dataset, extra: np.ndarray, panels: int = 0
           ) -> tuple[Figure, list[tuple[plt.Axes, tuple[int, int]]]]:
    """The run's rods in x–y, and in x–z and y–z when the shape or ``extra`` points leave
    the x–y plane (a 3D shape seen from one side only can hide a whole bend); ``panels``
    more axes after them (the figure's last axes)."""
    views = list(projections(np.concatenate([ds["position"].values, extra])))
    count = len(views)
    three_d = count > 1
    figure, axes = plt.subplots(1, count + panels,
                                figsize=(4.4 * (count + panels) + 1.0 if three_d or panels
                                         else 6.4, 4.8),
                                constrained_layout=True, squeeze=False)
    for panel, (h, v) in zip(axes[0][:count], views, strict=True):
        for rod in np.unique(ds["rod"].values):
            nodes = ds["position"].sel(node=ds["rod"] == rod).values
            panel.plot(nodes[:, h], nodes[:, v], marker=".", ms=3, lw=0.9, label=str(rod))
        panel.set_xlabel(f"{'xyz'[h]} [m]")
        panel.set_ylabel(f"{'xyz'[v]} [m]")
        panel.set_aspect("equal", adjustable="datalim")
    figure.suptitle(ds.attrs.get("title", ""))
    return figure, list(zip(axes[0][:count], views, strict=True))


def _unit(variable: xr.DataArray) -> str:
    unit = variable.attrs.get("units", "")
    return f" {unit}" if unit not in ("", "1") else ""


def fit_figure(ds: xr.Dataset) -> Figure:
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


def reach_figure(ds: xr.Dataset) -> Figure:
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
