"""The contact figure of a run archive with obstacles (docs/contact.md): the obstacles, the
rods and the contact force on every control point, drawn from the archive alone.

The view is the plane of the two world axes along which the rods spread most (a catheter
bent in a plane is drawn in that plane). Obstacles are cut by that plane through the rods'
mean depth, each drawing its own outline (``rodsim.core.obstacles.Obstacle.outline``):
a plane is a line, a sphere a circle, a vessel the two outlines of its wall (centerline ±
radius across the view). Rods are drawn with their
diameter; each contact force is an arrow from its node, scaled so that the largest is a
fifth of the drawing, labelled with its value in mN.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.collections import LineCollection

from rodsim.app.figures.style import STYLE
from rodsim.core.obstacles import Obstacle, build_obstacle
from rodsim.core.scene import Scene
from rodsim.io.archive_schema import stored_scene

__all__ = ["contact_figure", "draw_contact"]

AXES = ("x", "y", "z")


def contact_figure(ds: xr.Dataset, path: str | Path) -> Path:
    """Draw the contact figure of a run archive ``ds`` (with ``contact_force``) to ``path``
    (any format matplotlib writes: the suffix picks it)."""
    if "contact_force" not in ds:
        raise ValueError("the archive has no contact_force: its scene has no obstacles")
    scene = stored_scene(ds.attrs["scene_json"], "attribute 'scene_json'")
    positions = ds["position"].values
    forces = ds["contact_force"].values
    spread = np.ptp(positions, axis=0)
    a, b = (int(i) for i in sorted(np.argsort(spread)[-2:]))
    with plt.style.context(STYLE):
        fig, ax = plt.subplots(figsize=(6.4, 4.8))
        rods = ds["rod"].values.astype(str)
        size = draw_contact(ax, scene, positions, forces, (a, b))
        for rod in dict.fromkeys(rods):
            pts = positions[rods == rod]
            width = 2 * scene.data["rods"][rod]["radius"]
            ax.plot(pts[:, a], pts[:, b], color="C0", lw=1.2, label=f"rod {rod}")
            ax.plot(pts[:, a], pts[:, b], color="C0", alpha=0.25, solid_capstyle="round",
                    lw=max(1.0, 72 * width / size * 6.4 * 0.8))
        ax.set_aspect("equal")
        ax.set_xlabel(f"{AXES[a]} [m]")
        ax.set_ylabel(f"{AXES[b]} [m]")
        total = np.linalg.norm(forces.sum(axis=0))
        ax.set_title(f"{scene.name}: contact forces (red; resultant {1e3 * total:.3g} mN)")
        ax.legend(loc="best")
        path = Path(path)
        fig.savefig(path)
        plt.close(fig)
    return path


def draw_contact(ax: plt.Axes, scene: Scene, positions: np.ndarray, forces: np.ndarray,
                 view: tuple[int, int], extent: np.ndarray | None = None) -> float:
    """Draw on ``ax``, in the plane of the world axes ``view``, the scene's obstacles cut
    through the rods' mean depth and the contact ``forces`` on the control points at
    ``positions`` as arrows (the largest a fifth of the drawing, labelled in mN); set the
    limits around the rods (or around the points ``extent``, e.g. every step of a track).
    Returns the drawing's size [m] (the larger extent)."""
    a, b = view
    depth = 3 - a - b
    frame = positions if extent is None else extent.reshape(-1, 3)
    # A damaged archive's NaN point is left out (it is not drawn either), not a traceback.
    frame = frame[np.all(np.isfinite(frame), axis=1)]
    if not len(frame):
        frame = np.zeros((1, 3))
    shown_depth = positions[np.isfinite(positions[:, depth]), depth]
    level = float(np.mean(shown_depth)) if shown_depth.size else float(frame[0, depth])
    lo, hi = frame.min(axis=0), frame.max(axis=0)
    size = float(max(hi[a] - lo[a], hi[b] - lo[b], 1e-9))
    margin = 0.25 * size
    for name, table in scene.data.get("obstacles", {}).items():
        _draw_obstacle(ax, build_obstacle(name, table), a, b, depth, level,
                       (lo[a] - margin, hi[a] + margin), (lo[b] - margin, hi[b] + margin))
    magnitude = np.linalg.norm(forces, axis=1)
    magnitude[~np.isfinite(magnitude) | ~np.all(np.isfinite(positions), axis=1)] = 0.0
    largest = float(magnitude.max(initial=0.0))
    if largest > 0:
        scale = 0.2 * size / largest
        for p, f, m in zip(positions, forces, magnitude, strict=True):
            if m > 1e-3 * largest:
                ax.annotate("", xy=(p[a], p[b]), xytext=(p[a] - scale * f[a],
                                                          p[b] - scale * f[b]),
                            arrowprops={"arrowstyle": "->", "color": "C3", "lw": 1.2})
        tip = int(np.argmax(magnitude))
        ax.annotate(f"{1e3 * largest:.3g} mN", (positions[tip, a], positions[tip, b]),
                    textcoords="offset points", xytext=(6, 6), color="C3")
    ax.set_xlim(lo[a] - margin, hi[a] + margin)
    ax.set_ylim(lo[b] - margin, hi[b] + margin)
    return size


def _draw_obstacle(ax: plt.Axes, obstacle: Obstacle, a: int, b: int, depth: int,
                   level: float, xlim: tuple[float, float], ylim: tuple[float, float]
                   ) -> None:
    """The obstacle's own outline in the view (``Obstacle.outline``), named by gid."""
    lower, upper = np.full(3, level), np.full(3, level)
    lower[a], upper[a] = xlim
    lower[b], upper[b] = ylim
    curves = [c[:, [a, b]] for c in obstacle.outline((a, b), level, lower, upper)]
    ax.add_collection(LineCollection(curves, colors="0.35", lw=1.5, zorder=1,
                                     gid=f"obstacle:{obstacle.name}",
                                     label=f"{obstacle.type} {obstacle.name}"))
