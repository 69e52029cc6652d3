"""The layers of a run's figure a user can hide (``rodsim plot --hide``) or pick
(``rodsim plot --show``): the layers terms are drawn in
(``rodsim.core.terms.base.FIGURE_LAYERS``, each term's ``Term.figure_layer``) and the
obstacles' outlines.

- ``shape``: the rods' centerlines (the elastic and constraint terms' layer);
- ``tendon``: the tendons' paths and terminations, and the spacer disks;
- ``load``: the load arrows (tip loads, point and distributed loads, gravity, actuation);
- ``contact``: the contact forces on the rods;
- ``obstacle``: the obstacles' outlines.

What no layer holds is always drawn, whichever layers are shown: the panels with their
axes, labels and limits (framed around the whole scene, hidden layers included, so a
figure of one layer sits where it sits in the full figure), the title (the tip, computed
from the positions), the figure's colour bar of ``--colour`` (the html view's sits on
a coloured trace and goes with its layer), and a track's or trajectory's
panels other than the shapes' (the response, the tension loop, the tip and energy
against time). The arrows' scale notes go with their layer.
"""

from __future__ import annotations

from collections.abc import Iterable

from rodsim.app.figures.errors import PlotError
from rodsim.core.terms.base import FIGURE_LAYERS

__all__ = ["LAYERS", "SHAPE", "TENDON", "LOAD", "CONTACT", "OBSTACLE", "hidden_layers",
           "layers_left_out"]

#: The layers terms are drawn in (``Term.figure_layer``).
SHAPE, TENDON, LOAD, CONTACT = FIGURE_LAYERS
#: The obstacles' outlines: a layer of its own (obstacles are no term).
OBSTACLE = "obstacle"
#: Every layer a run's figure draws, in drawing order.
LAYERS = (*FIGURE_LAYERS, OBSTACLE)


def hidden_layers(names: str | Iterable[str]) -> frozenset[str]:
    """The layers ``names`` (e.g. ``["load", "contact"]`` or ``"load,contact"``; blanks
    skipped) checked against ``LAYERS``; raises ``PlotError`` naming the allowed ones."""
    if isinstance(names, str):
        names = names.split(",")
    wanted = {name.strip().lower() for name in names if name.strip()}
    unknown = sorted(wanted - set(LAYERS))
    if unknown:
        raise PlotError(f"unknown figure layer {unknown[0][:40]!r}; layers: "
                        + ", ".join(LAYERS))
    return frozenset(wanted)


def layers_left_out(show: str | Iterable[str] | None = None,
                    hide: str | Iterable[str] = ()) -> frozenset[str]:
    """The layers a figure leaves out: with ``show`` (``--show``, the layers drawn; None:
    not given) every layer it does not name, else those ``hide`` (``--hide``) names. Both
    are read and checked by ``hidden_layers``. Raises ``PlotError`` (one line) for an
    unknown name, for ``show`` and ``hide`` both naming layers, and for a ``show`` that
    names none."""
    hidden = hidden_layers(hide)
    if show is None:
        return hidden
    shown = hidden_layers(show)
    if hidden:
        raise PlotError("--show and --hide do not combine: give the layers to draw "
                        "(--show) or those to leave out (--hide)")
    if not shown:
        raise PlotError("--show names no layer; layers: " + ", ".join(LAYERS))
    return frozenset(LAYERS) - shown
