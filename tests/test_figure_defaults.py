"""What the track and trajectory figures draw by default (issue 36): a trajectory's shapes
at a few evenly chosen output times, light to dark, with the times on a colour bar; a
track's every rod and string tendon at each step, as the run figure draws a state. Each
drawn line is checked against the archive or the model's own tendon path."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.colors import to_rgb
from test_figure_projections import OFFSET
from test_figure_projections import pulled as pulled_towards

import rodsim
from rodsim.app.figures import draw_figure, style
from rodsim.app.figures.trajectory import SHAPES
from rodsim.core.scene import Scene
from rodsim.core.terms.tendon_string import TendonString
from rodsim.io.archive import read_dataset, write_dataset

TENSION = "tendons.a.tendon_string.tension"
RAMP = [0.5, 1.5, 3.0, 1.5]


def pulled() -> Scene:
    """A nitinol backbone pulled by a string tendon on spacers 10 mm off its axis, bent in
    x–y (tests/test_figure_projections.py's scene in the plane)."""
    return pulled_towards([1.0, 0.0])


def figure_data(ds):
    """{gid: [xy of each line with that gid, in drawing order]} of the x–y panel, each
    line's colour by gid, the first panel's title and the colour bars {gid: (label, tick
    values)}."""
    with style():
        figure = draw_figure(ds)
        try:
            (first,) = [ax for ax in figure.axes if ax.get_xlabel() == "x [m]"]
            lines: dict[str, list[np.ndarray]] = {}
            colours: dict[str, list[tuple[float, ...]]] = {}
            for line in first.get_lines():
                if line.get_gid():
                    lines.setdefault(line.get_gid(), []).append(line.get_xydata())
                    colours.setdefault(line.get_gid(), []).append(to_rgb(line.get_color()))
            bars = {str(ax.get_gid()): (ax.get_ylabel(), np.asarray(ax.get_yticks()))
                    for ax in figure.axes if str(ax.get_gid()).startswith("colourbar:")}
            return lines, colours, first.get_title(), bars
        finally:
            plt.close(figure)


@pytest.fixture(scope="module")
def motion(tmp_path_factory):
    """The backbone let go from straight under the tendon's pull: 21 output times."""
    result = rodsim.simulate(pulled(), 0.02, output_dt=0.001)
    assert result.success, result.message
    path = tmp_path_factory.mktemp("defaults") / "motion.nc"
    return read_dataset(write_dataset(result.to_xarray(), path))


def test_the_default_trajectory_figure_draws_the_shapes_at_a_few_times(motion):
    times = motion["time"].values
    assert len(times) == 21 > SHAPES
    lines, colours, title, bars = figure_data(motion)
    shown = lines["rod:backbone"]
    assert 2 <= len(shown) <= SHAPES
    # each drawn shape is the archive's at one output time, in time order, first and last
    positions = motion["position"].values[:, :, :2]
    picked = [int(np.flatnonzero([np.array_equal(xy, p) for p in positions])[0])
              for xy in shown]
    assert picked[0] == 0 and picked[-1] == len(times) - 1
    gaps = np.diff(picked)
    assert np.all(gaps > 0) and np.ptp(gaps) <= 1  # evenly chosen
    assert title == "shapes at t = " + ", ".join(f"{t:.3g}" for t in times[picked]) + " s"
    # the tendon at each of those times, light (early) to dark (late), on a bar of t
    assert len(lines["tendon:a"]) == len(shown)
    luminance = [0.3 * r + 0.59 * g + 0.11 * b for r, g, b in colours["rod:backbone"]]
    assert np.all(np.diff(luminance) < 0)
    label, ticks = bars["colourbar:time"]
    assert label.startswith("t [s]")
    np.testing.assert_allclose(ticks, times[picked], rtol=0, atol=1e-15)


def test_the_default_track_figure_draws_the_tendon_of_each_step():
    track = rodsim.track(pulled(), {TENSION: RAMP}, estimates=False)
    assert track.success, track.message
    ds = track.to_xarray()
    lines, _, title, bars = figure_data(ds)
    positions = ds["position"].values
    assert len(lines["rod:backbone"]) == len(RAMP)
    for xy, nodes in zip(lines["rod:backbone"], positions, strict=True):
        np.testing.assert_array_equal(xy, nodes[:, :2])
    # each step's tendon: the model's own path at that step's state
    (term,) = [t for t in track.model.terms if isinstance(t, TendonString)]
    assert len(lines["tendon:a"]) == len(lines["termination:a"]) == len(RAMP)
    for drawn, end, state in zip(lines["tendon:a"], lines["termination:a"], track.states,
                                 strict=True):
        path = term.path(state)[:, :2]  # a track's states are full states
        assert drawn.shape == path.shape
        np.testing.assert_allclose(end[0], path[-1], rtol=0, atol=1e-12)
        # 3.7 % of the offset at most, measured, on these 9 nodes: the figure interpolates
        # the frame between segment midpoints, clamped before the first; the model starts
        # from the base frame at s = 0 (tests/test_figure_parts.py: 2 % on finer scenes)
        assert np.max(np.abs(drawn - path)) < 0.05 * OFFSET
    # a ramp that turns: the steps coloured by step, named on the bar
    label, _ = bars["colourbar:step"]
    assert label.startswith("step (0.5 → 3 → 1.5")
    assert title == f"each of {len(RAMP)} steps"


def test_the_default_track_figure_draws_every_rod_at_each_step():
    """A catheter with a rod tendon (tendon-conserving: two rods): both at each step, the
    tendon rod drawn as the tendon's path (its control points), and its actuation force at
    the last step only."""
    force = "tendons.tendon.tendon_actuation.force"
    track = rodsim.track(rodsim.load_scene("tendon-conserving"), {force: [0.5, 1.0, 2.0]},
                         estimates=False)
    assert track.success, track.message
    ds = track.to_xarray()
    lines, _, _, _ = figure_data(ds)
    rods = ds["rod"].values.astype(str)
    for name, gid in (("catheter", "rod:catheter"), ("tendon", "tendon:tendon")):
        assert len(lines[gid]) == 3, gid
        for xy, nodes in zip(lines[gid], ds["position"].values[:, rods == name],
                             strict=True):
            np.testing.assert_array_equal(xy, nodes[:, :2])
    with style():
        figure = draw_figure(ds)
        try:
            loads = [a for a in figure.axes[0].findobj()
                     if a.get_gid() == "load:tendon:tendon_actuation"]
        finally:
            plt.close(figure)
    assert len(loads) == 1  # the last step's


def test_a_long_track_draws_a_subset_of_its_steps_with_its_turn():
    """A 41-step pull and release: ``TRACK_SHAPES`` (24) evenly chosen steps and the step
    where the ramp turns (20) are drawn, each equal to the archive's nodes; the tip's path
    keeps all 41."""
    from rodsim.app.figures.inverse import TRACK_SHAPES

    ramp = np.concatenate([np.linspace(0.5, 3.0, 21), np.linspace(3.0, 0.5, 21)[1:]])
    track = rodsim.track(pulled(), {TENSION: ramp}, estimates=False)
    assert track.success, track.message
    ds = track.to_xarray()
    lines, _, title, _ = figure_data(ds)
    positions = ds["position"].values
    drawn = lines["rod:backbone"]
    assert TRACK_SHAPES <= len(drawn) <= TRACK_SHAPES + 1 < len(ramp)
    assert title == f"{len(drawn)} of {len(ramp)} steps"
    picked = [k for k in range(len(ramp))
              if any(np.array_equal(xy, positions[k][:, :2]) for xy in drawn)]
    assert {0, 20, len(ramp) - 1} <= set(picked) and len(picked) == len(drawn)
    assert len(lines["tip-path"][0]) == len(ramp)
