"""One style for every rodsim figure: the style file (``rodsim.mplstyle``: no text below
8 pt, readable lines, a colour-blind-safe cycle), the line styles, markers and colours
(the labels a figure reads from its archive: ``rodsim.app.figures.labels``)."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt

LINE_STYLES = ("-", "--", ":", "-.")
MARKERS = ("o", "s", "^", "v", "D", "P")
DPI = 100
#: The style file of every rodsim figure (package data).
STYLE = Path(__file__).with_name("rodsim.mplstyle")


__all__ = ["STYLE", "DPI", "LINE_STYLES", "MARKERS", "style", "colours_for"]


def style() -> contextlib.AbstractContextManager[None]:
    """rodsim's figure style (``rodsim/app/figures/rodsim.mplstyle``: no text below 8 pt, readable
    lines, a colour cycle whose neighbours differ) for the figures drawn inside it."""
    return plt.style.context(STYLE)


def colours_for(count: int, numeric: bool) -> list[Any]:
    """Sequential colours for five or more ordered values (the trend reads as a gradient),
    the categorical cycle otherwise."""
    if numeric and count >= 5:
        cmap = plt.get_cmap("viridis")
        return [cmap(0.85 * i / (count - 1)) for i in range(count)]
    cycle = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    return [cycle[i % len(cycle)] for i in range(count)]
