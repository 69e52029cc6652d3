"""A track's and a trajectory's shapes in three projections when they leave the x–y plane
(issue 36), by the run figure's rule (rodsim/app/figures/projections.py); a planar scene
keeps the planar layout. Every drawn line is checked against the archive's positions."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
import pytest

import rodsim
from rodsim.app.figures import draw_figure, style
from rodsim.app.figures.projections import PROJECTIONS
from rodsim.app.figures.trajectory import SHAPES
from rodsim.core.scene import Scene
from rodsim.io.archive import read_dataset, write_dataset

E, RADIUS, LENGTH, OFFSET = 54e9, 0.7e-3, 0.2, 0.01
TENSION = "tendons.a.tendon_string.tension"
RAMP = [0.5, 1.5, 3.0]
LABELS = [("x [m]", "y [m]"), ("x [m]", "z [m]"), ("y [m]", "z [m]")]


def pulled(direction: list[float]) -> Scene:
    """A nitinol backbone pulled by a string tendon on spacers, 10 mm off its axis in the
    cross-section ``direction`` (d1, d2): [1, 0] bends it in x–y, [0.6, 0.8] out of it."""
    area = math.pi * RADIUS**2
    return Scene.from_dict({"name": "pulled", "rods": {"backbone": {
        "length": LENGTH, "radius": RADIUS, "youngs_modulus": E, "stretch_modulus": E,
        "density": 6450.0, "nodes": 9, "terms": ["stretch", "bend_twist", "centerline"],
        "centerline": {"K_P": E / 2.6 * area}}},
        "tendons": {"a": {"catheter": "backbone", "coupling": "string", "offset": OFFSET,
                          "direction": direction,
                          "tendon_string": {"tension": 1.0, "spacers": True}}},
        "solver": {"integrator": "static"}})


@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    """Tracks over the tension (skew: out of the x–y plane; flat: in it) and a trajectory
    of the skew scene let go from straight, each written and read back."""
    folder = tmp_path_factory.mktemp("projections")
    out = {}
    for name, direction in (("skew", [0.6, 0.8]), ("flat", [1.0, 0.0])):
        track = rodsim.track(pulled(direction), {TENSION: RAMP}, estimates=False)
        out[name] = read_dataset(write_dataset(track.to_xarray(), folder / f"{name}.nc"))
        motion = rodsim.simulate(pulled(direction), 0.004, output_dt=0.002)
        assert motion.success, motion.message
        out[f"{name}-motion"] = read_dataset(write_dataset(motion.to_xarray(),
                                                           folder / f"{name}-motion.nc"))
    return out


def panels(ds, **options):
    """Each panel of the figure of ``ds`` as (x label, y label, {gid: [xy data of each line
    with that gid, in drawing order]}, title); colour bars left out."""
    with style():
        figure = draw_figure(ds, **options)
        try:
            out = []
            for axes in figure.axes:
                if str(axes.get_gid()).startswith("colourbar:"):
                    continue
                lines: dict[str, list[np.ndarray]] = {}
                for line in axes.get_lines():
                    if line.get_gid():
                        lines.setdefault(line.get_gid(), []).append(line.get_xydata())
                out.append((axes.get_xlabel(), axes.get_ylabel(), lines, axes.get_title()))
        finally:
            plt.close(figure)
    return out


def check_projections(drawn, positions: np.ndarray, gid: str) -> None:
    """The three projection panels come first, in x–y, x–z, y–z, and each draws, line by
    line, every state's nodes ``positions`` (states, nodes, 3) in its plane."""
    assert [(x, y) for x, y, _, _ in drawn[:3]] == LABELS
    for (_, _, lines, _), (a, b) in zip(drawn[:3], PROJECTIONS, strict=True):
        assert len(lines[gid]) == len(positions)
        for xy, nodes in zip(lines[gid], positions, strict=True):
            np.testing.assert_array_equal(xy, nodes[:, [a, b]])


@pytest.mark.parametrize("options", [{}, {"colour": "tension"}, {"hide": ["load"]}])
def test_a_3d_track_draws_every_step_in_three_projections(archives, options):
    ds = archives["skew"]
    positions = ds["position"].values
    tips = positions[:, -1]
    assert np.ptp(tips[:, 2]) > 0.1 * np.ptp(tips[:, 0])  # a z the x–y view alone hides
    drawn = panels(ds, **options)
    check_projections(drawn, positions, "rod:backbone")
    for (_, _, lines, _), (a, b) in zip(drawn[:3], PROJECTIONS, strict=True):
        (path,) = lines["tip-path"]
        np.testing.assert_array_equal(path, tips[:, [a, b]])
    # the response panel is kept: each coordinate's displacement against the tension
    response = drawn[3][2]
    np.testing.assert_array_equal(response["response:z:0"][0],
                                  np.stack([RAMP, tips[:, 2] - tips[0, 2]], axis=1))
    assert drawn[3][0] == "tension (a) [N]"
    # the tendon of each step too, as the run figure draws it, by default as well
    for (_, _, lines, _), (a, b) in zip(drawn[:3], PROJECTIONS, strict=True):
        assert len(lines.get("termination:a", [])) == len(RAMP), (a, b)


def test_a_3d_trajectory_draws_its_shapes_in_three_projections(archives):
    ds = archives["skew-motion"]
    positions = ds["position"].values
    assert 1 < len(positions) <= SHAPES and np.ptp(positions[..., 2]) > 1e-3
    for options in ({}, {"hide": ["load"]}):  # the shapes are drawn by default too
        drawn = panels(ds, **options)
        check_projections(drawn, positions, "rod:backbone")
        assert drawn[0][3].startswith("shapes at t = 0, 0.002, 0.004 s")
        assert [(x, y) for x, y, _, _ in drawn[3:]] == [("t [s]", "tip of backbone [m]"),
                                                         ("t [s]", "energy [J]")]


def test_a_planar_scene_keeps_the_planar_layout(archives):
    track = archives["flat"]
    positions = track["position"].values
    assert np.ptp(positions[..., 2]) < 1e-12 * LENGTH  # round-off only
    for options in ({}, {"colour": "tension"}):
        drawn = panels(track, **options)
        labels = [(x, y) for x, y, _, _ in drawn]
        assert labels[:2] == [("x [m]", "y [m]"),
                              ("tension (a) [N]", "tip displacement from step 0 [m]")]
        assert not any("z [m]" in pair for pair in labels), labels
        for xy, nodes in zip(drawn[0][2]["rod:backbone"], positions, strict=True):
            np.testing.assert_array_equal(xy, nodes[:, :2])
    motion = archives["flat-motion"]
    labels = [(x, y) for x, y, _, _ in panels(motion, hide=["load"])]
    assert labels == [("t [s]", "tip of backbone [m]"), ("t [s]", "energy [J]"),
                      ("x [m]", "y [m]")]


def test_a_3d_trajectory_gets_the_3d_view_by_default_as_a_3d_run_does(archives):
    """`rodsim plot` adds the html view for archives whose shapes leave the x–y plane: a
    trajectory's too since the view draws trajectories (the planar one still does not)."""
    from rodsim.app.figures import three_dimensional

    assert three_dimensional(archives["skew-motion"]) and three_dimensional(archives["skew"])
    assert not three_dimensional(archives["flat-motion"])
    assert not three_dimensional(archives["flat"])
