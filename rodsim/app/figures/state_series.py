"""Several states of a track (its steps) or a trajectory (its output times) on one panel
per projection (``rodsim.app.figures.projections``), as ``rodsim plot --colour`` and
``--hide`` draw them: each state as the run figure draws it
(``rodsim.app.figures.scene_drawing.draw_parts``), the last with its loads, contact
forces and obstacles, the others with their rods and tendons only; the lines of every
state coloured (``rodsim.app.figures.colouring``, the run figure's computation at each
state) on one scale shared by all (``shared_scale``), with one colour bar."""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Colormap, Normalize
from matplotlib.figure import Figure

from rodsim.app.figures import layers
from rodsim.app.figures.colouring import Colouring, colouring, shared_scale
from rodsim.app.figures.scene_drawing import draw_parts
from rodsim.app.figures.scene_parts import SceneParts, scene_parts

__all__ = ["state_colours", "coloured_states", "draw_states", "colour_bar", "evenly", "MAX_FRAMES"]

#: The most frames drawn of a trajectory, in its movie and its 3D view (its output times
#: are subsampled evenly).
MAX_FRAMES = 120

#: What only the last state of a series draws.
LAST_ONLY = frozenset({layers.LOAD, layers.CONTACT, layers.OBSTACLE})


def evenly(count: int, most: int) -> list[int]:
    """At most ``most`` of the indices 0 … count − 1, evenly spaced, the first and the last
    among them."""
    return [int(k) for k in np.unique(np.rint(np.linspace(0, count - 1, min(count, most))))]


def state_colours(ds: xr.Dataset, quantity: str, indices: Sequence[int],
                  states: Sequence[SceneParts]
                  ) -> tuple[list[Colouring], tuple[Normalize, Colormap]]:
    """The colouring of each state ``indices`` (drawn as ``states``) and their shared
    scale."""
    colourings = [colouring(ds, quantity, parts, k)
                  for k, parts in zip(indices, states, strict=True)]
    return colourings, shared_scale(colourings)


def coloured_states(ds: xr.Dataset, indices: Sequence[int], colour: str | None
                    ) -> tuple[list[SceneParts], list[Colouring | None],
                               tuple[Normalize, Colormap] | None]:
    """The parts of the states ``indices`` of ``ds`` and, with ``colour``, each one's
    colouring and their shared scale (``state_colours``; None each, and no scale,
    without)."""
    states = [scene_parts(ds, k) for k in indices]
    if not colour:
        return states, [None] * len(states), None
    found, scale = state_colours(ds, colour, indices, states)
    return states, list(found), scale


def draw_states(panels: Sequence[tuple[plt.Axes, tuple[int, int]]],
                states: Sequence[SceneParts], colourings: Sequence[Colouring | None],
                scale: tuple[Normalize, Colormap] | None, hide: frozenset[str]
                ) -> tuple[Colouring, tuple[Normalize, Colormap]] | None:
    """Draw the states ``states`` (``coloured_states``: their parts, colourings and shared
    scale) on each of ``panels``, a panel and the plane (two world axes) it shows (module
    docstring), limits around every state; returns the last state's colouring and the
    shared scale (None without colours). The first panel's legend, repeated entries
    merged."""
    extent = np.concatenate([parts.points() for parts in states])
    for panel, view in panels:
        for number, (parts, colours) in enumerate(zip(states, colourings, strict=True)):
            last = number == len(states) - 1
            draw_parts(panel, parts, view, extent=extent,
                       hide=hide if last else hide | LAST_ONLY, colours=colours,
                       scale=scale, diameter=len(states) == 1)
    first = panels[0][0]
    handles, names = first.get_legend_handles_labels()
    unique = dict(zip(names, handles, strict=True))
    if unique:
        first.legend(unique.values(), unique.keys(), loc="best", fontsize="small")
    last_colours = colourings[-1]
    return None if last_colours is None or scale is None else (last_colours, scale)


def colour_bar(figure: Figure, axes: list[plt.Axes], colours: Colouring,
               scale: tuple[Normalize, Colormap], **options: object) -> None:
    """The colour bar of ``colours`` on ``scale`` beside ``axes``, labelled with the
    quantity and its unit (gid ``colourbar:<quantity>``)."""
    bar = figure.colorbar(ScalarMappable(*scale), ax=axes, label=colours.label,
                          **options)  # type: ignore[arg-type]
    bar.ax.set_gid(f"colourbar:{colours.quantity}")
