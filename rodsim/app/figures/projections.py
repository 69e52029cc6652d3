"""The projections a figure draws a shape in: x–y, and x–z and y–z too when the shape leaves
the x–y plane (a 3D shape seen from one side only can hide a whole bend). The run figure,
the track and trajectory figures, the fit and reach figures and the movie decide by the one
rule here (``projections``); the track and trajectory figures lay their panels out with
``panel_grid``."""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

__all__ = ["PROJECTIONS", "out_of_plane", "projections", "panel_grid"]

#: The projections of a 3D shape: (horizontal, vertical) world axes of each panel.
PROJECTIONS = ((0, 1), (0, 2), (1, 2))


def out_of_plane(positions: np.ndarray) -> bool:
    """Whether points (…, 3) [m] leave the x–y plane: their z spreads over more than 1e-6
    of their x extent."""
    return bool(np.ptp(positions[..., 2]) > 1e-6 * max(np.ptp(positions[..., 0]), 1e-12))


def projections(points: np.ndarray) -> tuple[tuple[int, int], ...]:
    """The views of a figure that draws ``points`` (…, 3) [m]: x–y alone, or all three
    ``PROJECTIONS`` when the points leave the x–y plane (``out_of_plane``; no points:
    x–y)."""
    if not np.size(points):
        return PROJECTIONS[:1]
    return PROJECTIONS if out_of_plane(points) else PROJECTIONS[:1]


def panel_grid(views: Sequence[tuple[int, int]], others: int, views_first: bool,
               planar: tuple[float, float]
               ) -> tuple[Figure, list[plt.Axes], list[plt.Axes]]:
    """A figure with a panel for each of ``views`` and ``others`` more (1 or 2 beside the
    projections): returns it, the projections' panels and the others'. With one view or
    none, one row of size ``planar`` [in], the projection first (``views_first``) or last;
    with three, two rows: the projections side by side, above the others
    (``views_first``) or below them, the others sharing the row's width (one alone spans
    its middle two thirds)."""
    if len(views) <= 1:
        figure, axes = plt.subplots(1, len(views) + others, figsize=planar,
                                    constrained_layout=True, squeeze=False)
        row = list(axes[0])
        count = len(views)
        return ((figure, row[:count], row[count:]) if views_first
                else (figure, row[len(row) - count:], row[:len(row) - count]))
    figure = plt.figure(figsize=(4.4 * len(views) + 1.0, 8.6), layout="constrained")
    grid = figure.add_gridspec(2, 6)
    top, bottom = (0, 1) if views_first else (1, 0)
    width = 6 // len(views)
    shapes = [figure.add_subplot(grid[top, k * width:(k + 1) * width])
              for k in range(len(views))]
    spans = [(1, 5)] if others == 1 else [(k * 6 // others, (k + 1) * 6 // others)
                                          for k in range(others)]
    rest = [figure.add_subplot(grid[bottom, a:b]) for a, b in spans]
    return figure, shapes, rest
