"""Draw one state's parts (``rodsim.app.figures.scene_parts``) on a matplotlib panel in
the plane of two world axes: rods with their diameter, tendons' paths with their routing
points and terminations, spacer disks edge-on (``rodsim.app.figures.spacer_disks``, in the
tendons' layer), obstacles (each draws its own outline:
``rodsim.core.obstacles.Obstacle.outline``), loads and contact forces as arrows.

Each artist carries a ``gid`` naming what it draws (``rod:<name>``, ``tendon:<name>``,
``termination:<name>``, ``disk:<catheter>``, ``obstacle:<name>``, ``load:<owner>:<term>``,
``contact:<rod>``): tests find them by it. Arrows are drawn to a scale stated on the panel:
the largest force a fifth of the drawing, the largest moment (right-hand rule, dashed)
likewise; contact forces have their own scale. A load starts at its point of action, a
contact force ends there; one across the view is a circle with a dot (out of the page) or a
cross (into it).
"""

from __future__ import annotations

from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import Colormap, Normalize

from rodsim.app.figures import layers
from rodsim.app.figures.colouring import ColouredLine, Colouring, colour_scale
from rodsim.app.figures.scene_parts import Arrow, SceneParts
from rodsim.app.figures.spacer_disks import draw_disks

__all__ = ["draw_parts", "frame_box"]

AXES = "xyz"
#: Colours: rods, tendons, obstacles, loads, contact forces.
ROD, OBSTACLE, LOAD, CONTACT = "C0", "0.45", "C2", "#A50F15"
#: The tendons' colours in turn (none is a rod's, a load's or a contact's).
TENDONS = ("C1", "C4", "C5", "C3", "C6", "C7")


def frame_box(points: np.ndarray, margin: float = 0.15) -> tuple[np.ndarray, np.ndarray]:
    """The box around ``points`` (n, 3), widened by ``margin`` of its largest side."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = margin * max(float(np.max(hi - lo)), 1e-9)
    return lo - pad, hi + pad


def draw_parts(ax: plt.Axes, parts: SceneParts, view: tuple[int, int],
               extent: np.ndarray | None = None, hide: frozenset[str] = frozenset(),
               colours: Colouring | None = None,
               scale: tuple[Normalize, Colormap] | None = None, diameter: bool = True,
               tint: Any = None, disks: bool = True) -> None:
    """Draw ``parts`` on ``ax`` in the plane of the world axes ``view``; limits around the
    parts (or around the points ``extent`` (n, 3), e.g. every step of a track). The layers
    ``hide`` (``rodsim.app.figures.layers.LAYERS``) are left out; the lines of ``colours``
    (``rodsim.app.figures.colouring``) are drawn in ``scale`` (by default their own,
    ``colour_scale``; several states share one: ``shared_scale``). ``diameter``: the rods'
    diameter drawn under their centerlines (left out when many states overlap). ``tint``:
    one matplotlib colour for the rods, tendons, terminations and disks not coloured by
    ``colours`` (a state of a series, coloured by its step or time); the rods' and
    tendons' legend entries then name the kind, not each one. ``disks``: the spacer disks
    drawn (with the tendons' layer)."""
    a, b = view
    frame = parts.points() if extent is None else extent.reshape(-1, 3)
    for obstacle in parts.obstacles:  # a vessel is shown whole
        mesh = obstacle.surface(*frame_box(frame)) if obstacle.encloses else None
        if mesh is not None:
            frame = np.concatenate([frame, mesh[0]])
    lower, upper = frame_box(frame)
    size = float(max(upper[a] - lower[a], upper[b] - lower[b]))
    level = float(np.mean(parts.points()[:, 3 - a - b]))
    for obstacle in () if layers.OBSTACLE in hide else parts.obstacles:
        curves = [c[:, [a, b]] for c in obstacle.outline(view, level, lower, upper)]
        ax.add_collection(LineCollection(curves, colors=OBSTACLE, lw=1.3, zorder=1,
                                         gid=f"obstacle:{obstacle.name}",
                                         label=f"{obstacle.type} {obstacle.name}"),
                          autolim=False)
    rods = {} if layers.SHAPE in hide else parts.rods
    tendons = [] if layers.TENDON in hide else parts.tendons
    lines = {} if colours is None else colours.lines
    if colours is not None and scale is None:
        scale = colour_scale(colours)
    for name, nodes in rods.items():
        if name in lines:
            _coloured(ax, lines[name], view, scale, gid=f"rod:{name}", lw=2.0, zorder=3)
        else:
            ax.plot(nodes[:, a], nodes[:, b], color=ROD if tint is None else tint, lw=1.0,
                    marker=".", ms=2.5,
                    zorder=3, gid=f"rod:{name}",
                    label=f"rod {name}" if tint is None else "rods")
    for index, tendon in enumerate(tendons):
        p = tendon.points
        colour = TENDONS[index % len(TENDONS)] if tint is None else tint
        if tendon.name in lines:
            _coloured(ax, lines[tendon.name], view, scale, gid=f"tendon:{tendon.name}",
                      lw=1.8, zorder=4, ls="--" if tendon.string else "-")
        else:
            ax.plot(p[:, a], p[:, b], ls="--" if tendon.string else "-",
                    marker="|" if tendon.string else None, ms=4, gid=f"tendon:{tendon.name}",
                    label=f"tendon {tendon.name}" if tint is None else "tendons",
                    color=colour, lw=0.9, zorder=4)
        ax.plot(p[-1, a], p[-1, b], ls="none", marker="s", ms=4, mfc="white",
                color=colour, zorder=5, gid=f"termination:{tendon.name}")
    if layers.TENDON not in hide and disks:
        draw_disks(ax, parts.disks, view, tint)
    if layers.LOAD not in hide:
        _arrows(ax, [x for x in parts.loads if not x.moment], view, 0.2 * size, LOAD, "N",
                "forces")
        _arrows(ax, [x for x in parts.loads if x.moment], view, 0.2 * size, LOAD, "N m",
                "moments", dashed=True)
    contacts = [] if layers.CONTACT in hide else parts.contacts
    _arrows(ax, contacts, view, 0.2 * size, CONTACT, "N", "contact", legend=False)
    if contacts:
        largest = max(float(np.linalg.norm(x.vector)) for x in contacts)
        ax.plot([], [], color=CONTACT, marker=">", label=f"contact forces (largest "
                f"{1e3 * largest:.3g} mN)")
    ax.dataLim.set_points(np.array([[lower[a], lower[b]], [upper[a], upper[b]]]))
    ax.autoscale_view(tight=True)
    ax.set_xlabel(f"{AXES[a]} [m]")
    ax.set_ylabel(f"{AXES[b]} [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.apply_aspect()
    # the rods' diameter, in points at the panel's present scale
    width_per_m = (ax.bbox.width / max(float(np.diff(ax.get_xlim())[0]), 1e-300)
                   * 72 / ax.figure.dpi)
    for name, nodes in rods.items() if diameter else ():
        ax.plot(nodes[:, a], nodes[:, b], color=ROD, alpha=0.2, solid_capstyle="round",
                lw=max(1.0, 2 * parts.radii[name] * width_per_m), zorder=2)


def _coloured(ax: plt.Axes, line: ColouredLine, view: tuple[int, int],
              scale: tuple[Normalize, Colormap] | None, **style: Any) -> None:
    """A line's pieces in the plane ``view``, each in the colour of its value on ``scale``
    (``colour_scale``); the colour bar names it, not the legend."""
    assert scale is not None  # a coloured line comes with its colouring's scale
    pieces = line.pieces[:, :, list(view)]
    ax.add_collection(LineCollection(list(pieces), array=line.values, norm=scale[0],
                                     cmap=scale[1], capstyle="round", **style), autolim=False)


def _arrows(ax: plt.Axes, arrows: list[Arrow], view: tuple[int, int], length: float,
            colour: str, unit: str, what: str, dashed: bool = False, legend: bool = True
            ) -> None:
    """Arrows at their points, the largest ``length`` long (its value stated on the
    panel): a load (force or moment) starts at its point of action, a contact force ends
    there (the wall pushing on the rod)."""
    if not arrows:
        return
    a, b = view
    largest = max(float(np.linalg.norm(x.vector)) for x in arrows)
    if largest == 0.0:
        return
    scale = length / largest
    seen: set[str] = set()
    for arrow in arrows:
        v = scale * arrow.vector[[a, b]]
        p = arrow.point[[a, b]]
        tail, head = (p - v, p) if arrow.gid.startswith("contact:") else (p, p + v)
        label = None
        if legend and arrow.label not in seen:
            seen.add(arrow.label)
            label = f"{arrow.label}: {np.linalg.norm(arrow.vector):.3g} {unit}"
        if np.linalg.norm(v) < 0.05 * length:  # across the view: ⊙ out of it, ⊗ into it
            out = float(arrow.vector @ np.cross(np.eye(3)[a], np.eye(3)[b])) > 0
            ax.plot(*p, ls="none", marker="o", ms=9, mfc="white", color=colour, zorder=6,
                    gid=arrow.gid)
            ax.plot(*p, ls="none", marker="." if out else "x", ms=6 if out else 5,
                    color=colour, zorder=7)
        else:
            ax.annotate("", xy=tuple(head), xytext=tuple(tail), gid=arrow.gid,
                        arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 1.2,
                                    "ls": "--" if dashed else "-", "shrinkA": 0,
                                    "shrinkB": 0}, zorder=6)
        if label:  # a legend entry for the arrow (annotations have none)
            ax.plot([], [], color=colour, ls="--" if dashed else "-", marker=">",
                    label=label)
    mm = 1e3 * length
    ax.text(0.01, 0.01 + 0.05 * ("moments", "forces", "contact").index(what),
            f"{what}: {mm:.3g} mm ≙ {largest:.3g} {unit}", transform=ax.transAxes,
            color=colour, fontsize=8, ha="left", va="bottom", gid=f"scale:{what}")
