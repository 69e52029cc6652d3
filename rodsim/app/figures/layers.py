"""The layers of a run's figure a user can hide (``rodsim plot --hide``): the layers terms
are drawn in (``rodsim.core.terms.base.FIGURE_LAYERS``, each term's ``Term.figure_layer``)
and the obstacles' outlines.

- ``shape``: the rods' centerlines (the elastic and constraint terms' layer);
- ``tendon``: the tendons' paths and terminations, and the spacer disks;
- ``load``: the load arrows (tip loads, point and distributed loads, gravity, actuation);
- ``contact``: the contact forces on the rods;
- ``obstacle``: the obstacles' outlines.
"""

from __future__ import annotations

from collections.abc import Iterable

from rodsim.app.figures.errors import PlotError
from rodsim.core.terms.base import FIGURE_LAYERS

__all__ = ["LAYERS", "SHAPE", "TENDON", "LOAD", "CONTACT", "OBSTACLE", "hidden_layers"]

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
