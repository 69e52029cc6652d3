"""Several states of a track (its steps) or a trajectory (its output times) on one panel
per projection (``rodsim.app.figures.projections``), as the track and trajectory figures
draw them: each state as the run figure draws it
(``rodsim.app.figures.scene_drawing.draw_parts``), the last with its loads, contact
forces, obstacles and spacer disks, the others with their rods and tendons only; the lines
of every state coloured (``rodsim.app.figures.colouring``, the run figure's computation at
each state) on one scale shared by all (``shared_scale``), with one colour bar. Without a
colouring (the figures' default), each state is drawn in one colour of its own, its step
or time on a colour map (``tints``, ``tint_bar``): rods solid, tendons dashed."""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Colormap, ListedColormap, Normalize
from matplotlib.figure import Figure

from rodsim.app.figures import layers
from rodsim.app.figures.colouring import Colouring, colouring, shared_scale
from rodsim.app.figures.scene_drawing import draw_parts
from rodsim.app.figures.scene_parts import SceneParts, scene_parts

__all__ = ["state_colours", "coloured_states", "draw_states", "colour_bar", "evenly",
           "MAX_FRAMES", "LIGHT_TO_DARK", "tints", "tint_bar"]

#: The most frames drawn of a trajectory, in its movie and its 3D view (its output times
#: are subsampled evenly).
MAX_FRAMES = 120

#: The colour map of a trajectory's output times: light (early) to dark (late), the
#: lightest still visible on white (the upper 70 % of matplotlib's "Blues").
LIGHT_TO_DARK = ListedColormap(plt.get_cmap("Blues")(np.linspace(0.3, 1.0, 256)),
                               name="light-to-dark")

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
                scale: tuple[Normalize, Colormap] | None, hide: frozenset[str],
                tinted: Sequence[tuple[float, ...]] | None = None
                ) -> tuple[Colouring, tuple[Normalize, Colormap]] | None:
    """Draw the states ``states`` (``coloured_states``: their parts, colourings and shared
    scale) on each of ``panels``, a panel and the plane (two world axes) it shows (module
    docstring), limits around every state; ``tinted``: each state's one colour where
    it has no colouring (``tints``). Returns the last state's colouring and the shared
    scale (None without colours). The first panel's legend, repeated entries merged."""
    extent = np.concatenate([parts.points() for parts in states])
    for panel, view in panels:
        for number, (parts, colours) in enumerate(zip(states, colourings, strict=True)):
            last = number == len(states) - 1
            draw_parts(panel, parts, view, extent=extent,
                       hide=hide if last else hide | LAST_ONLY, colours=colours,
                       scale=scale, diameter=len(states) == 1,
                       tint=None if tinted is None else tinted[number], disks=last)
    first = panels[0][0]
    handles, names = first.get_legend_handles_labels()
    unique = dict(zip(names, handles, strict=True))
    if unique:
        first.legend(unique.values(), unique.keys(), loc="best", fontsize="small")
    last_colours = colourings[-1]
    return None if last_colours is None or scale is None else (last_colours, scale)


def tints(values: Sequence[float] | np.ndarray, cmap: Colormap
          ) -> tuple[list[tuple[float, ...]], Normalize]:
    """The colour of each of ``values`` (a state's step or time) on ``cmap``, and the
    scale from the first to the last (one value: a scale of width 1 around it)."""
    low, high = (float(values[0]), float(values[-1])) if len(values) else (0.0, 1.0)
    norm = Normalize(low, high) if high > low else Normalize(low - 0.5, low + 0.5)
    return [tuple(cmap(norm(float(v)))) for v in values], norm


def tint_bar(figure: Figure, axes: list[plt.Axes], norm: Normalize, cmap: Colormap,
             label: str, what: str, ticks: Sequence[float] | np.ndarray | None = None
             ) -> None:
    """The colour bar of the states' tints (``tints``) beside ``axes``, labelled
    ``label``, ticks at ``ticks`` (gid ``colourbar:<what>``)."""
    bar = figure.colorbar(ScalarMappable(norm, cmap), ax=axes, label=label)
    if ticks is not None:
        bar.set_ticks(list(ticks), labels=[f"{v:.3g}" for v in ticks])
    bar.ax.set_gid(f"colourbar:{what}")


def colour_bar(figure: Figure, axes: list[plt.Axes], colours: Colouring,
               scale: tuple[Normalize, Colormap], **options: object) -> None:
    """The colour bar of ``colours`` on ``scale`` beside ``axes``, labelled with the
    quantity and its unit (gid ``colourbar:<quantity>``)."""
    bar = figure.colorbar(ScalarMappable(*scale), ax=axes, label=colours.label,
                          **options)  # type: ignore[arg-type]
    bar.ax.set_gid(f"colourbar:{colours.quantity}")
