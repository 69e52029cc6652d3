"""Measured points for ``fit`` (rodsim/app/inverse/fit.py): a CSV of ``x,y,z`` (and
optionally ``s``) read and checked (``read_points``), matched to a shape's nodes
(``match``), and refused where no shape of the rod comes near them
(``check_plausible``)."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rodsim.core.scene import Scene
from rodsim.io.input_file import InputError, check_input_file

__all__ = ["FitError", "Points", "check_plausible", "match", "read_points", "span_dimension",
           "MAX_POINTS", "MAX_DATA_BYTES", "MAX_REACH"]

#: Largest number of points a data file may hold.
MAX_POINTS = 1_000_000
#: Largest data file read [bytes] (a million points of three 25-digit numbers).
MAX_DATA_BYTES = 128 * 1024 ** 2
#: Data farther than this many rod lengths from the rod's origin are refused.
MAX_REACH = 10.0
#: Unit mistakes :func:`check_plausible` recognises: (factor to metres, what the data were).
UNIT_GUESSES = ((1e-3, "millimetres"), (1e-2, "centimetres"), (0.0254, "inches"))


class FitError(ValueError):
    """Bad data or parameters: unreadable file, wrong columns, too few points, parameters
    the shape does not determine."""


@dataclass(frozen=True)
class Points:
    """Measured points (m, 3) [m], with their rest arc lengths (m,) [m] or None."""

    xyz: np.ndarray
    s: np.ndarray | None = None


def read_points(path: str | Path) -> Points:
    """Points from a CSV file with header ``x,y,z`` (and optionally ``s``); FitError names
    the first problem (missing or unknown columns, a value that is not a finite number). A
    FIFO, a device (``/dev/zero``), a folder or a file over ``MAX_DATA_BYTES`` is
    refused before it is opened."""
    try:
        check_input_file(path, "data", MAX_DATA_BYTES)
    except InputError as exc:
        raise FitError(str(exc)) from None
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            rows = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError) as exc:
        raise FitError(f"cannot read data {str(path)!r}: {exc}") from None
    except csv.Error as exc:
        raise FitError(f"data {str(path)!r}: not CSV ({exc})") from None
    rows = [row for row in rows if any(cell.strip() for cell in row)]
    if not rows:
        raise FitError(f"data {str(path)!r} is empty; expected a header x,y,z[,s]")
    header = [cell.strip() for cell in rows[0]]
    if sorted(header) not in (["x", "y", "z"], ["s", "x", "y", "z"]):
        raise FitError(f"data {str(path)!r}: columns {','.join(header)[:60]!r}; expected "
                       "x,y,z (metres) and optionally s (rest arc length, metres)")
    if len(rows) == 1:
        raise FitError(f"data {str(path)!r} has a header and no points")
    if len(rows) - 1 > MAX_POINTS:
        raise FitError(f"data {str(path)!r}: more than {MAX_POINTS} points")
    values = np.empty((len(rows) - 1, len(header)))
    for i, row in enumerate(rows[1:]):
        if len(row) != len(header):
            raise FitError(f"data {str(path)!r} line {i + 2}: {len(row)} values, expected "
                           f"{len(header)}")
        for j, cell in enumerate(row):
            try:
                values[i, j] = float(cell)
            except ValueError:
                raise FitError(f"data {str(path)!r} line {i + 2}: {cell.strip()[:30]!r} is "
                               "not a number") from None
            if not math.isfinite(values[i, j]):
                raise FitError(f"data {str(path)!r} line {i + 2}: {header[j]} = "
                               f"{cell.strip()[:30]} is not a finite number")
    column = {name: values[:, header.index(name)] for name in header}
    xyz = np.column_stack([column["x"], column["y"], column["z"]])
    return Points(xyz, column.get("s"))


def match(nodes: np.ndarray, s_nodes: np.ndarray, points: Points
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(segment index j, fraction t, interior) of each point's match on the polyline through
    ``nodes`` (N, 3): the nearest point, or the point at the rest arc length ``points.s``
    (``s_nodes`` the nodes' rest arc lengths). ``interior`` marks nearest-point matches
    strictly inside a segment (their residual is normal to it)."""
    if points.s is not None:
        j = np.clip(np.searchsorted(s_nodes, points.s, side="right") - 1, 0, len(s_nodes) - 2)
        t = (points.s - s_nodes[j]) / (s_nodes[j + 1] - s_nodes[j])
        return j, t, np.zeros(len(j), dtype=bool)
    a, e = nodes[:-1], np.diff(nodes, axis=0)                       # segments a + t e
    rel = points.xyz[:, None, :] - a[None, :, :]                     # (m, N−1, 3)
    t = np.clip(np.einsum("mkc,kc->mk", rel, e) / np.einsum("kc,kc->k", e, e), 0.0, 1.0)
    gap = rel - t[:, :, None] * e[None, :, :]
    j = np.argmin(np.einsum("mkc,mkc->mk", gap, gap), axis=1)
    t = t[np.arange(len(j)), j]
    return j, t, (t > 0.0) & (t < 1.0)


def check_plausible(points: Points, scene: Scene, rod: str) -> None:
    """FitError when a data point lies farther than ``MAX_REACH`` lengths of ``rod``
    from its origin (no shape of the rod comes near it), guessing the unit mistake."""
    origin = np.asarray(scene.rods[rod].origin, dtype=float)
    length = float(scene.rods[rod].length)
    reach = float(np.max(np.abs(points.xyz - origin)))  # no overflow at 1e300
    if reach <= MAX_REACH * length:
        return
    guess = ""
    for factor, unit in UNIT_GUESSES:
        if 0.2 * length <= reach * factor <= 1.5 * length:  # then a rod-sized extent
            guess = (f"; in {unit} they would be {reach * factor:.3g} m away: convert them "
                     "to metres")
            break
    raise FitError(f"data up to {reach:.3g} m from the origin of rod {rod!r}, {reach / length:.3g} "
                   f"times its length {length:g} m: no shape of the rod comes near them (the "
                   f"data must be in metres{guess})")


def span_dimension(points: np.ndarray) -> int:
    """Dimension (1–3) of the affine span of ``points``."""
    centred = points - points.mean(axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    return max(1, int(np.sum(singular > 1e-9 * max(singular[0], 1e-300))))


