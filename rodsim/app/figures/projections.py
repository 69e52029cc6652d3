"""The projections a figure draws a shape in: x–y, and x–z and y–z too when the shape leaves
the x–y plane (a 3D shape seen from one side only can hide a whole bend). The run figure,
the track and trajectory figures, the fit and reach figures and the movie decide by the one
rule here (``projections``)."""

from __future__ import annotations

import numpy as np

__all__ = ["PROJECTIONS", "out_of_plane", "projections"]

#: The projections of a 3D shape: (horizontal, vertical) world axes of each panel.
PROJECTIONS = ((0, 1), (0, 2), (1, 2))


def out_of_plane(positions: np.ndarray) -> bool:
    """Whether points (…, 3) [m] leave the x–y plane: their z spreads over more than 1e-6
    of their x extent."""
    return bool(np.ptp(positions[..., 2]) > 1e-6 * max(np.ptp(positions[..., 0]), 1e-12))


def projections(points: np.ndarray) -> tuple[tuple[int, int], ...]:
    """The views of a figure that draws ``points`` (…, 3) [m]: x–y alone, or all three
    ``PROJECTIONS`` when the points leave the x–y plane (``out_of_plane``)."""
    return PROJECTIONS if out_of_plane(points) else PROJECTIONS[:1]
