"""Spacer disks in a figure: where a string tendon rides on spacer disks
(``[tendons.<name>.tendon_string] spacers = true``, rodsim/core/terms/tendon_string.py),
the catheter carries a disk at each of its routing points (the entry, every node inside the
span, the termination: rodsim/core/terms/_string_points.py). The model has no disk size: a
disk's radius is the tendon's ``[tendons.<name>.tendon_string] disk_radius`` when the
scene gives it (at least the routing's largest offset: the holes sit inside the disk),
else ``DISK_MARGIN`` times the routing offset |ρ(s)|; where several tendons on spacers
pass, the largest of theirs.

A disk is the catheter's cross-section at its arc length s: centred on the centerline r(s),
its normal the section's d3 (the directors interpolated as the tendons' routing points
are: ``rodsim.app.figures.scene_parts``). A projection shows it edge-on, as a short line
segment perpendicular to the backbone (``disk_segment``): its diameter along the
direction of the disk's plane that lies in the view's plane; a disk seen nearly face-on
(its normal within ``FACE_ON`` of the view's axis) is drawn as its ring, thin and faint
(many rings seen end-on would hide the rest). A series of states (a track, a trajectory)
draws the disks of its last state only (``rodsim.app.figures.state_series``). The 3D view
draws
each as a thin ring (``disk_ring``). Each drawn collection has the gid
``disk:<catheter>``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import to_rgba

__all__ = ["DISK_MARGIN", "FACE_ON", "Disk", "disk_segment", "disk_ring", "draw_disks"]

#: A disk's radius over the largest routing offset at its arc length.
DISK_MARGIN = 1.2

#: The sine of the angle between a disk's normal and the view's axis below which the
#: disk is seen face-on and drawn as its ring.
FACE_ON = 0.2

#: Colour of the disks.
COLOUR = "0.25"


@dataclass(frozen=True)
class Disk:
    """A spacer disk on ``catheter`` at rest arc length ``s`` [m]: its centre (3,) [m] on
    the centerline, its unit normal (3,) (the section's d3) and its radius [m];
    ``from_scene``: the radius is the scene's disk_radius (else ``DISK_MARGIN`` times the
    routing offset)."""

    catheter: str
    s: float
    centre: np.ndarray
    normal: np.ndarray
    radius: float
    from_scene: bool = False


def disk_ring(disk: Disk, points: int = 25) -> np.ndarray:
    """The disk's rim (points, 3) [m], closed (the first point repeated last)."""
    n = disk.normal / np.linalg.norm(disk.normal)
    helper = np.eye(3)[int(np.argmin(np.abs(n)))]
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    phi = np.linspace(0.0, 2.0 * np.pi, points)
    return disk.centre + disk.radius * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)


def disk_segment(disk: Disk, view: tuple[int, int]) -> np.ndarray:
    """The disk as the projection ``view`` (two world axes) shows it, (k, 3) [m]: edge-on,
    the diameter (2, 3) along w = e_c × d3 / |e_c × d3| (e_c the axis out of the view: w
    lies in the view's plane and in the disk's, so it is perpendicular to the backbone's
    tangent and to its projection); face-on (|e_c × d3| < ``FACE_ON``), the ring."""
    out_of_view = np.eye(3)[3 - view[0] - view[1]]
    w = np.cross(out_of_view, disk.normal / np.linalg.norm(disk.normal))
    if np.linalg.norm(w) < FACE_ON:
        return disk_ring(disk)
    w /= np.linalg.norm(w)
    return np.stack([disk.centre - disk.radius * w, disk.centre + disk.radius * w])


def draw_disks(ax: plt.Axes, disks: list[Disk], view: tuple[int, int],
               colour: str | tuple[float, ...] | None = None, label: bool = True) -> None:
    """Each catheter's disks on ``ax`` in the plane ``view``, one collection per catheter
    (gid ``disk:<catheter>``), in ``colour`` (by default ``COLOUR``); ``label``: a legend
    entry stating the diameter and where it comes from."""
    a, b = view
    for catheter in dict.fromkeys(d.catheter for d in disks):
        mine = [d for d in disks if d.catheter == catheter]
        lines = [disk_segment(d, view)[:, [a, b]] for d in mine]
        edge_on = [len(line) == 2 for line in lines]  # a ring (face-on): thin and faint
        base: Any = COLOUR if colour is None else colour
        ax.add_collection(LineCollection(
            lines, colors=[to_rgba(base, 1.0 if edge else 0.3) for edge in edge_on],
            linewidths=[1.4 if edge else 0.4 for edge in edge_on], zorder=4.5,
            gid=f"disk:{catheter}", capstyle="butt",
            label=_legend(mine) if label else None),
            autolim=False)


def _legend(disks: list[Disk]) -> str:
    """The legend entry of one catheter's disks: their count, largest diameter and its
    source (the scene's disk_radius, the rule, or both)."""
    given = {d.from_scene for d in disks}
    source = ("disk_radius" if given == {True} else f"{DISK_MARGIN:g} × routing offset"
              if given == {False} else f"disk_radius or {DISK_MARGIN:g} × routing offset")
    return (f"spacer disks ({len(disks)}, ⌀ {2e3 * max(d.radius for d in disks):.3g} mm"
            f" = {source})")
