"""Colour a run's centerlines by a quantity computed from the archive alone
(``rodsim plot --colour``): the bending curvature, the axial strain, or a tendon's tension.

- ``curvature`` [1/m]: the bending part of the Darboux vector, |(u_1, u_2)|, with the
  material strains u_k of paper Eq. (3), u_k = 2/|q|² B_k q · q′, discretised between two
  consecutive segments' quaternions a, b as the bending term does,
  u_k = (2/l̄) (B_k a)·b / (|a||b|) (``rodsim.core.terms.bend_twist.bend_kinematics``), l̄ the
  rest distance between the two segment midpoints (``segment_s``). For a rotation by θ
  between them u = 2 sin(θ/2)/l̄: a circular arc of radius R sampled every l gives
  2 sin(l/2R)/l → 1/R. Twist u_3 is left out. The value sits at the node between the two
  segments, drawn from the middle of the segment before it to the middle of the one after;
  the end nodes take their one neighbour's element.
- ``strain`` [1]: the axial strain of each segment, |r_{j+1} − r_j| / (s_{j+1} − s_j) − 1
  (the stretch of paper Eq. (6)), from the positions and the rest arc length ``s``.
- ``tension`` [N]: along each tendon's drawn path. A string tendon with friction: the chord
  tension ``tension_profile`` of the chord nearest in rest arc length; without friction the
  constant tension of the string, the archived ``tendon_tension`` under displacement
  control or the scene's ``tendon_string.tension`` (a track's at its step, a trajectory's
  program's at its time: ``rodsim.app.figures.state_scene``); a rod tendon: its axial force
  E_s π r² (|r′| − 1) per segment (Eq. (6)'s K_s times the strain).

The rods (or, for tension, the tendons) carry the colour; everything else keeps its own.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
from matplotlib import colormaps
from matplotlib.colors import Colormap, Normalize

from rodsim.app.figures.errors import PlotError
from rodsim.app.figures.scene_parts import SceneParts, at_step
from rodsim.core.terms.bend_twist import bend_kinematics

__all__ = ["COLOURINGS", "ColouredLine", "Colouring", "colouring", "colour_scale",
           "shared_scale", "node_curvature", "segment_strain"]

#: What a centerline can be coloured by, and the colour bar's label (with units).
COLOURINGS = {"curvature": "curvature |(u₁, u₂)| [1/m]",
              "strain": "axial strain |r′| − 1 [m/m]",
              "tension": "tendon tension [N]"}

#: The least span of a colour scale, in the quantity's unit.
FLOOR = {"curvature": 1e-9, "strain": 1e-9, "tension": 1e-9}


@dataclass(frozen=True)
class ColouredLine:
    """A rod's or tendon's line as pieces (m, 2, 3) [m], each with its value (m,)."""

    name: str
    pieces: np.ndarray
    values: np.ndarray


@dataclass(frozen=True)
class Colouring:
    """The coloured lines of one state and the colour bar's label."""

    quantity: str
    label: str
    lines: dict[str, ColouredLine]

    def span(self) -> tuple[float, float]:
        """(lowest, highest) value over every line."""
        values = np.concatenate([line.values for line in self.lines.values()])
        return float(np.min(values)), float(np.max(values))


def colour_scale(colours: Colouring) -> tuple[Normalize, Colormap]:
    """The colour scale of ``colours``: ``viridis`` from the lowest value to the highest,
    or, with values of both signs (a compressed segment, a slack tendon), ``coolwarm``
    symmetric about 0. Values equal to 1e-6 of their size (a uniform arc, a tendon without
    friction) run from 0 to that value instead: one colour, no round-off amplified. A scale
    never spans less than ``FLOOR`` (a strain of round-off size is drawn as 0)."""
    low, high = colours.span()
    bound = max(abs(low), abs(high), FLOOR[colours.quantity])
    if low < 0.0 < high:
        return Normalize(-bound, bound), colormaps["coolwarm"]
    if high - low <= 1e-6 * bound:
        low, high = (0.0, bound) if high >= 0.0 else (-bound, 0.0)
    return Normalize(low, high), colormaps["viridis"]


def shared_scale(colourings: Sequence[Colouring]) -> tuple[Normalize, Colormap]:
    """One colour scale for the colourings of several states (a track's steps, a
    trajectory's output times): ``colour_scale`` of all their lines together."""
    first = colourings[0]
    lines = {f"{index}:{name}": line for index, colours in enumerate(colourings)
             for name, line in colours.lines.items()}
    return colour_scale(Colouring(first.quantity, first.label, lines))


def node_curvature(quaternions: np.ndarray, segment_s: np.ndarray) -> np.ndarray:
    """The bending curvature [1/m] at each node of a rod (len(segment_s) + 1,) from its
    segments' quaternions (module docstring, Eq. (3))."""
    if len(quaternions) < 2:
        return np.zeros(len(quaternions) + 1)
    u = bend_kinematics(quaternions[:-1], quaternions[1:], np.diff(segment_s)).u
    inner = np.hypot(u[:, 0], u[:, 1])
    return np.concatenate([inner[:1], inner, inner[-1:]])


def segment_strain(nodes: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The axial strain of each segment (len(s) − 1,) (module docstring, Eq. (6))."""
    return np.linalg.norm(np.diff(nodes, axis=0), axis=1) / np.diff(s) - 1.0


def _segments(points: np.ndarray) -> np.ndarray:
    return np.stack([points[:-1], points[1:]], axis=1)


def _node_pieces(nodes: np.ndarray) -> np.ndarray:
    """Each segment's two halves (2 (N − 1), 2, 3), in order: node k's value is drawn on
    the halves that touch it (``_node_values``)."""
    middles = 0.5 * (nodes[:-1] + nodes[1:])
    first = np.stack([nodes[:-1], middles], axis=1)
    second = np.stack([middles, nodes[1:]], axis=1)
    return np.stack([first, second], axis=1).reshape(-1, 2, 3)


def _node_values(values: np.ndarray) -> np.ndarray:
    """A node value for each of ``_node_pieces``: segment j's halves carry nodes j, j + 1."""
    return np.stack([values[:-1], values[1:]], axis=1).reshape(-1)


def colouring(ds: xr.Dataset, quantity: str, parts: SceneParts, step: int | None = None
              ) -> Colouring:
    """The lines of ``parts`` (drawn from run archive ``ds``, state ``step``) coloured by
    ``quantity`` (a key of ``COLOURINGS``); raises ``PlotError`` when the archive has no
    such data (tension without a tendon, an archive without quaternions or arc length)."""
    if quantity not in COLOURINGS:
        raise PlotError(f"unknown colouring {quantity[:40]!r}; known: {', '.join(COLOURINGS)}")
    label = COLOURINGS[quantity]
    if quantity == "tension":
        return Colouring(quantity, label, _tension_lines(ds, parts, step))
    node_rod = ds["rod"].values.astype(str)
    lines = {}
    for name, nodes in parts.rods.items():
        if quantity == "curvature":
            if "quaternion" not in ds or "segment_s" not in ds:
                raise PlotError("--colour curvature needs the segments' quaternions and "
                                "segment_s: the archive has none")
            mine = ds["segment_rod"].values.astype(str) == name
            values = node_curvature(at_step(ds["quaternion"], step)[mine],
                                    ds["segment_s"].values[mine])
            lines[name] = ColouredLine(name, _node_pieces(nodes), _node_values(values))
        else:
            if "s" not in ds:
                raise PlotError("--colour strain needs the rest arc length s of the nodes: "
                                "the archive has none")
            values = segment_strain(nodes, ds["s"].values[node_rod == name])
            lines[name] = ColouredLine(name, _segments(nodes), values)
    return Colouring(quantity, label, lines)


def _tension_lines(ds: xr.Dataset, parts: SceneParts, step: int | None
                   ) -> dict[str, ColouredLine]:
    from rodsim.app.figures.state_scene import state_scene

    scene = state_scene(ds, step)
    if not parts.tendons:
        raise PlotError(f"--colour tension: scene {scene.name[:40]!r} has no tendon; colour "
                        "by curvature or strain")
    raw = json.loads(scene.to_json())
    outcome = json.loads(ds.attrs.get("tendon_tension", "{}"))
    chord_tendon = (ds["chord_tendon"].values.astype(str) if "tension_profile" in ds
                    else np.array([], dtype=str))
    lines = {}
    for tendon in parts.tendons:
        pieces = _segments(tendon.points)
        if tendon.string and tendon.s is not None and tendon.name in chord_tendon:
            mine = chord_tendon == tendon.name
            middles = 0.5 * (tendon.s[:-1] + tendon.s[1:])
            nearest = np.argmin(np.abs(middles[:, None] - ds["chord_s"].values[mine][None, :]),
                                axis=1)
            values = at_step(ds["tension_profile"], step)[mine][nearest]
        elif tendon.string:
            tension = outcome.get(tendon.name,
                                  raw["tendons"][tendon.name]["tendon_string"]["tension"])
            values = np.full(len(pieces), float(tension))
        else:
            table = raw["rods"][tendon.name]
            if table.get("sections"):
                raise PlotError(f"--colour tension: rod tendon {tendon.name[:40]!r} has "
                                "sections; its axial stiffness is not drawn")
            if "s" not in ds:
                raise PlotError(f"--colour tension of rod tendon {tendon.name[:40]!r} needs "
                                "the rest arc length s of the nodes: the archive has none")
            stiffness = (float(scene.rods[tendon.name].stretch_modulus)
                         * math.pi * float(table["radius"]) ** 2)
            node_rod = ds["rod"].values.astype(str)
            values = stiffness * segment_strain(tendon.points,
                                                ds["s"].values[node_rod == tendon.name])
        lines[tendon.name] = ColouredLine(tendon.name, pieces, np.asarray(values, float))
    return lines
