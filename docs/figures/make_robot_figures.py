"""Draw the figures of the shipped robot scenes for docs/scenes.md.

    python docs/figures/make_robot_figures.py     # writes docs/figures/scene-<name>.png

Each figure solves the scene as shipped (``static``) and draws, seen from the side (x–y) and
from above (x–z), the catheter's centerline, its string tendons' paths (each routing point
ρ(s) placed on the frame of the segment it lies in, from entry to termination), and the
Rucker–Webster reference centerline (rodsim/core/analytic/tendon_bvp.py) as dots: an
independent check drawn beside the result.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import rodsim  # noqa: E402
from rodsim.core.analytic.tendon_bvp import scene_reference  # noqa: E402
from rodsim.core.rod.quaternion import directors  # noqa: E402
from rodsim.core.routing import Routing, string_span  # noqa: E402

HERE = Path(__file__).parent
SCENES = {
    "tdcr-two-segment": "two segments bent into an S (s1a 3 N, s2b 2 N), tip force 0.02 N in −z",
    "catheter-pull-ring": "pull wire at 1 N bends the soft distal 4 cm (pull ring at 0.09 m)",
    "catheter-helical": "one helical tendon at 4 N: the tip leaves the plane x–y",
}


def tendon_paths(scene, result, rod: str) -> dict[str, np.ndarray]:
    """World points of each string tendon's path, one per segment midpoint in its span."""
    positions = result.rods[rod].positions
    quaternions = result.rods[rod].quaternions
    frames = directors(quaternions / np.linalg.norm(quaternions, axis=1)[:, None])
    length = scene.rods[rod].length
    s_mid = (np.arange(len(quaternions)) + 0.5) * length / len(quaternions)
    midpoints = 0.5 * (positions[1:] + positions[:-1])
    paths = {}
    for name, options in scene.tendons.items():
        string = scene.term_options("tendons", name, "tendon_string")
        start, end = string_span(string, length)
        inside = (s_mid >= start) & (s_mid <= end)
        rho = Routing.of(options.offset, options.direction, string).offsets(s_mid[inside])
        frame = frames[inside]
        paths[name] = (midpoints[inside] + rho[:, :1] * frame[:, 0]
                       + rho[:, 1:2] * frame[:, 1])
    return paths


def draw(name: str, caption: str) -> Path:
    scene = rodsim.load_scene(name)
    rod = next(iter(scene.rods))
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    centerline = result.rods[rod].positions
    reference = scene_reference(scene, s=np.linspace(0.0, scene.rods[rod].length, 21))
    paths = tendon_paths(scene, result, rod)
    figure, panels = plt.subplots(1, 2, figsize=(10, 4.2))
    for axes, (k, label) in zip(panels, ((1, "y"), (2, "z")), strict=True):
        axes.plot(centerline[:, 0], centerline[:, k], "k-", lw=2.5, label=f"{rod} (rodsim)")
        for tendon, path in paths.items():
            axes.plot(path[:, 0], path[:, k], "-", lw=1.0, label=f"tendon {tendon}")
        axes.plot(reference.positions[:, 0], reference.positions[:, k], "o", ms=4, mfc="none",
                  color="tab:red", label="Rucker–Webster reference")
        axes.set_xlabel("x [m]")
        axes.set_ylabel(f"{label} [m]")
        axes.set_title("side view (x–y)" if k == 1 else "top view (x–z)")
        axes.set_aspect("equal", adjustable="datalim")
        axes.grid(True, alpha=0.3)
    panels[0].legend(fontsize=7, loc="best")
    error = np.linalg.norm(centerline[-1] - reference.tip) / scene.rods[rod].length
    figure.suptitle(f"{name}: {caption}\nN = {scene.rods[rod].nodes}, tip "
                    f"{error:.1e} L from the reference", fontsize=10)
    figure.tight_layout()
    path = HERE / f"scene-{name}.png"
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


if __name__ == "__main__":
    for scene_name in sys.argv[1:] or SCENES:
        print(draw(scene_name, SCENES[scene_name]))
