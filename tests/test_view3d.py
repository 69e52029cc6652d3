"""The interactive 3-D view (issue 36): for every shipped scene it draws every rod, tendon,
obstacle, load and contact force by name and its opening camera frames every node; string
tendons and the vessel (translucent) are drawn; a track is animated with one frame per
step and a trajectory with one per output time."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rodsim
from rodsim.app.figures.scene_parts import scene_parts
from rodsim.core.obstacles import registered_obstacles
from rodsim.core.scene import scene_paths
from rodsim.io.run_dataset import run_dataset

go = pytest.importorskip("plotly.graph_objects",
                         reason="plotly is the optional extra rodsim[view3d]")
from test_figure_parts import COARSER, expected_gids  # noqa: E402

from rodsim.app.figures import view3d  # noqa: E402


def projected(figure, points: np.ndarray, width_over_height: float) -> np.ndarray:
    """Normalised device coordinates (n, 2) of ``points`` seen by the figure's camera: a
    perspective of vertical field of view 45° looking from ``eye`` at ``center`` with
    ``up``, the scene box spanning ± its aspect ratio (the wider reading of plotly's
    units); |x|, |y| <= 1 is on screen."""
    scene = figure.layout.scene
    lo = np.array([scene[f"{n}axis"].range[0] for n in "xyz"])
    hi = np.array([scene[f"{n}axis"].range[1] for n in "xyz"])
    ratio = np.array([scene.aspectratio[n] for n in "xyz"])
    units = (2 * (points - lo) / (hi - lo) - 1) * ratio  # the box at ± ratio
    camera = scene.camera
    eye = np.array([camera.eye[n] for n in "xyz"])
    centre = np.array([camera.center[n] for n in "xyz"])
    up = np.array([camera.up[n] for n in "xyz"])
    forward = (centre - eye) / np.linalg.norm(centre - eye)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    rel = units - eye
    depth = rel @ forward
    assert np.all(depth > 0), "a point behind the camera"
    f = 1 / math.tan(math.pi / 8)
    return np.stack([f / width_over_height * (rel @ right) / depth,
                     f * (rel @ true_up) / depth], axis=1)


def view_gids(figure) -> tuple[set[str], set[str]]:
    """What the view draws: the names of its line traces (a rod's or a tendon's trace is
    named as the rod or tendon), and the rest named as the run figure names its artists:
    ``termination:`` and ``obstacle:`` by their traces' names (an obstacle's: its type,
    then its name), loads and contact forces by the gids their arrow heads carry."""
    lines, named = set(), set()
    for trace in figure.data:
        name = str(trace.name)
        if name in ("loads", "contact forces"):
            heads = [g for g in trace.customdata if g]
            assert len(heads) == len(set(heads)), heads
            named |= set(heads)
        elif name.startswith("termination "):
            named.add(f"termination:{name.removeprefix('termination ')}")
        elif name.split(" ")[0] in registered_obstacles():
            named.add(f"obstacle:{name.split(' ', 1)[1]}")
        elif name != "spacer disks":
            lines.add(name)
    return lines, named


@pytest.mark.parametrize("scene", sorted(scene_paths()))
def test_every_shipped_scene_is_drawn_whole_and_framed_by_the_opening_camera(scene):
    """Every rod, tendon (with its termination), obstacle, load and contact force the scene
    holds (test_figure_parts.expected_gids, read from the archive's scene, not from the
    drawing) has a trace or an arrow of that name; the opening camera frames every node
    and tendon point in landscape and square windows."""
    ds = run_dataset(rodsim.solve(scene, overrides=COARSER.get(scene, [])))
    figure = view3d.view_figure(ds)
    expected = expected_gids(ds)
    assert any(g.startswith("rod:") for g in expected)
    lines, named = view_gids(figure)
    missing = {g for g in expected if g not in named
               and not (g.startswith(("rod:", "tendon:")) and g.split(":", 1)[1] in lines)}
    assert not missing, f"{scene}: not in the 3D view: {sorted(missing)}"
    points = np.concatenate([ds["position"].values, scene_parts(ds).points()])
    layout = figure.layout.scene
    for k, name in enumerate("xyz"):
        low, high = layout[f"{name}axis"].range
        assert low <= points[:, k].min() and points[:, k].max() <= high, name
    assert layout.aspectmode == "manual"
    for aspect in (4 / 3, 1.0, 16 / 9):  # landscape and square windows
        ndc = projected(figure, points, aspect)
        assert np.max(np.abs(ndc)) < 1.0, (aspect, np.max(np.abs(ndc)))


def test_string_tendons_and_a_translucent_vessel_are_drawn():
    figure = view3d.view_figure(run_dataset(rodsim.solve("tdcr-two-segment")))
    names = {trace.name for trace in figure.data}
    assert {"s1a", "s1b", "s1c", "s2a", "s2b", "s2c", "backbone", "loads"} <= names
    vessel = view3d.view_figure(run_dataset(rodsim.solve("vessel-insertion")))
    (mesh,) = [t for t in vessel.data if isinstance(t, go.Mesh3d)]
    assert mesh.name == "tube vessel" and 0 < mesh.opacity < 1


def test_a_track_is_animated_one_frame_per_step(tmp_path):
    forces = np.linspace(0.0, 0.5, 6)
    path = rodsim.track(rodsim.load_scene("table1-50g", ["nodes=8"]),
                        {"tip_load.mass": forces / 9.81}, estimates=False)
    assert path.success, path.message
    from rodsim.io.archive import read_dataset, write_dataset

    ds = read_dataset(write_dataset(path.to_xarray(), tmp_path / "track.nc"))  # the archive
    figure = view3d.view_figure(ds)
    assert len(figure.frames) == len(forces) == ds.sizes["step"]
    (slider,) = figure.layout.sliders
    assert len(slider.steps) == len(forces)
    assert figure.layout.updatemenus[0].buttons[0].label == "play"
    # each frame holds that step's rod
    rod = ds["position"].values
    for step, frame in enumerate(figure.frames):
        np.testing.assert_allclose(frame.data[0].y, rod[step, :, 1])
    # and the camera frames every step
    every = rod.reshape(-1, 3)
    assert np.max(np.abs(projected(figure, every, 4 / 3))) < 1.0
    page = view3d.write_html(ds, tmp_path / "track.html").read_text(encoding="utf-8")
    assert page.count('"name":"5"') >= 1 and "Plotly.addFrames" in page


def test_a_trajectory_is_animated_one_frame_per_output_time():
    """A release of table1-50g (N = 8) over 0.05 s, 11 output times: 11 frames, each the
    rod at that time, the slider labelled with the times; the camera frames every one."""
    run = rodsim.simulate("table1-50g", 0.05, output_dt=0.005, overrides=["nodes=8"],
                          initial={"tip_load.mass": 0.1})
    assert run.success, run.message
    ds = run.to_xarray()
    figure = view3d.view_figure(ds)
    times = ds["time"].values
    assert len(figure.frames) == len(times) == 11
    (slider,) = figure.layout.sliders
    assert [float(step.label) for step in slider.steps] == pytest.approx(times, rel=1e-3)
    assert slider.currentvalue.prefix == "t [s] = "
    rod = ds["position"].values
    for k, frame in enumerate(figure.frames):
        np.testing.assert_allclose(frame.data[0].y, rod[k, :, 1])
    assert np.max(np.abs(projected(figure, rod.reshape(-1, 3), 4 / 3))) < 1.0
