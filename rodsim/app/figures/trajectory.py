"""The figure of a trajectory archive (``rodsim simulate``; docs/dynamics.md): the shapes at
``SHAPES`` output times at most (``rodsim.app.figures.state_series``), in x–y, and in x–z
and y–z too when they leave the x–y plane (the run figure's rule:
``rodsim.app.figures.projections``); the first rod's tip coordinates against time, and the
energies against time with the balance T + V + D − W − (T₀ + V₀), the integrator's own
error (docs/dynamics.md, "Energy"); under error control (an archive with ``step_size``) a
third panel: each accepted step's length at its end time, each rejected attempt's at its
start, against time (log scale)."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from rodsim.app.figures.projections import panel_grid, projections
from rodsim.app.figures.state_series import (
    LIGHT_TO_DARK,
    colour_bar,
    coloured_states,
    draw_states,
    evenly,
    tint_bar,
    tints,
)

__all__ = ["trajectory_figure", "SHAPES"]

#: The most output times whose shapes the shapes' panels draw (evenly spaced, the first
#: and the last among them).
SHAPES = 8


def trajectory_figure(ds: xr.Dataset, colour: str | None = None,
                      hide: frozenset[str] = frozenset()) -> Figure:
    """Two time panels: the tip's x, y, z [m] against t [s]; the kinetic energy T, the
    potential energy's change V − V₀, the dissipated energy D, the work W and the balance
    error [J] (the last two and V only where the scene is conservative: NaN is not drawn).
    Beside them the shapes at ``SHAPES`` output times at most (evenly chosen), in x–y, as
    a run's figure draws them (each with its programs' values): each time in one colour,
    light (early) to dark (late), with a colour bar of t ticked at the times drawn; with
    ``colour``, coloured by that quantity on one scale instead; the layers ``hide`` left
    out. When the shapes leave the x–y plane, three panels in x–y, x–z and y–z, a row
    below the two time panels. Under error control a third time panel: the step sizes."""
    shown = int(ds.sizes["time"]) > 0
    picked = evenly(int(ds.sizes["time"]), SHAPES) if shown else []
    states, colourings, scale = coloured_states(ds, picked, colour if shown else None)
    views = projections(np.concatenate([parts.points() for parts in states])) if shown else ()
    stepped = "step_size" in ds.variables
    figure, shapes, panels = panel_grid(views, 2 + stepped, False,
                                        (11.0 + 4.6 * shown + 5.0 * stepped, 4.2))
    motion, energy = panels[:2]
    if stepped:
        _step_sizes(panels[2], ds)
    if shown:
        at = ds["time"].values[picked]
        tinted, norm = tints(at, LIGHT_TO_DARK)
        drawn = draw_states(list(zip(shapes, views, strict=True)), states, colourings, scale,
                            hide, None if colour else tinted)
        if drawn is not None:
            colour_bar(figure, shapes, *drawn)
        else:
            tint_bar(figure, shapes, norm, LIGHT_TO_DARK, "t [s] (shapes drawn)", "time",
                     ticks=at)
        shown_times = ", ".join(f"{t:.3g}" for t in at)
        shapes[0].set_title(f"shapes at t = {shown_times} s", fontsize="small")
    times = ds["time"].values
    rods = ds["rod"].values.astype(str)
    first = rods[0]
    tip = int(np.flatnonzero(rods == first)[-1])
    for axis, name in enumerate("xyz"):
        motion.plot(times, ds["position"].values[:, tip, axis], label=name, color=f"C{axis}")
    motion.set_xlabel("t [s]")
    motion.set_ylabel(f"tip of {first} [m]")
    motion.legend(loc="best")
    kinetic = ds["kinetic_energy"].values
    potential = ds["potential_energy"].values - ds["potential_energy"].values[0]
    dissipated = ds["dissipated_energy"].values
    work = ds["work"].values
    balance = kinetic + potential + dissipated - work
    for values, label, style in ((kinetic, "kinetic T", "-"),
                                 (potential, "potential V - V0", "-"),
                                 (dissipated, "dissipated D", "--"),
                                 (work, "work W", ":"),
                                 (balance, "balance T + V + D - W - (T0 + V0)", "-")):
        if np.any(np.isfinite(values)):
            energy.plot(times, values, ls=style, label=label)
    energy.set_xlabel("t [s]")
    energy.set_ylabel("energy [J]")
    energy.legend(loc="best", fontsize="small")
    title = ds.attrs.get("title", "")
    if not int(ds.attrs.get("complete", 1)):
        title += f" (incomplete: {str(ds.attrs.get('message', ''))[:80]})"
    figure.suptitle(title)
    return figure


def _step_sizes(axes: Axes, ds: xr.Dataset) -> None:
    """The error control's step lengths against time: accepted at their ends, rejected
    attempts at their starts."""
    axes.semilogy(ds["step_end"].values, ds["step_size"].values, ".-", ms=2, lw=0.6,
                  label=f"accepted ({ds.sizes['accepted']})")
    if ds.sizes["rejected"]:
        axes.semilogy(ds["rejected_time"].values, ds["rejected_size"].values, "x",
                      color="C3", ms=4, label=f"rejected ({ds.sizes['rejected']})")
    axes.set_xlabel("t [s]")
    axes.set_ylabel("step [s]")
    axes.set_title(str(ds.attrs.get("error_control", "error control")), fontsize="small")
    axes.legend(loc="best", fontsize="small")
