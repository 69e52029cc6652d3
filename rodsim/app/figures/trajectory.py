"""The figure of a trajectory archive (``rodsim simulate``; docs/dynamics.md): the first
rod's tip coordinates against time, and the energies against time with the balance
T + V + D − W − (T₀ + V₀), the integrator's own error (docs/dynamics.md, "Energy"); with
``rodsim plot --colour`` or ``--hide`` a third panel, the shapes at ``SHAPES`` output times
(``rodsim.app.figures.state_series``), in x–y, and in x–z and y–z too when they leave the
x–y plane (the run figure's rule: ``rodsim.app.figures.projections``)."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from rodsim.app.figures.projections import panel_grid, projections
from rodsim.app.figures.state_series import colour_bar, coloured_states, draw_states, evenly

__all__ = ["trajectory_figure", "SHAPES"]

#: The most output times whose shapes the third panel draws (evenly spaced, the first and
#: the last among them).
SHAPES = 8


def trajectory_figure(ds: xr.Dataset, colour: str | None = None,
                      hide: frozenset[str] = frozenset()) -> Figure:
    """Two panels: the tip's x, y, z [m] against t [s]; the kinetic energy T, the potential
    energy's change V − V₀, the dissipated energy D, the work W and the balance error [J]
    (the last two and V only where the scene is conservative: NaN is not drawn). With
    ``colour`` or ``hide``, a third: the shapes at ``SHAPES`` output times in x–y, as
    a run's figure draws them (each with its programs' values), coloured on one scale,
    the layers ``hide`` left out; when the shapes leave the x–y plane, three panels in
    x–y, x–z and y–z, a row below the two time panels."""
    shown = bool(colour or hide) and int(ds.sizes["time"]) > 0
    picked = evenly(int(ds.sizes["time"]), SHAPES) if shown else []
    states, colourings, scale = coloured_states(ds, picked, colour if shown else None)
    views = projections(np.concatenate([parts.points() for parts in states])) if shown else ()
    figure, shapes, (motion, energy) = panel_grid(views, 2, False, (11.0 + 4.6 * shown, 4.2))
    if shown:
        drawn = draw_states(list(zip(shapes, views, strict=True)), states, colourings, scale,
                            hide)
        if drawn is not None:
            colour_bar(figure, shapes, *drawn)
        shown_times = ", ".join(f"{t:.3g}" for t in ds["time"].values[picked])
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
