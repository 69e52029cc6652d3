"""``rodsim plot --colour`` and ``--hide`` (issue 36) on runs, tracks, trajectories, their
movies and the 3-D view, and the track figure's loop.

The colours are checked against closed forms: a cantilever under a pure tip moment M bends
into a circle of curvature M/(E I); under an axial tip force F it stretches uniformly by
F/(E A); a string tendon with friction pulled in from slack carries T(s) = T₀/(1 + c s),
c = μ T₀ ρ/(E I) (docs/tendon.md). The curvature is also checked against two independent
computations from the same archive: the relative rotation angle θ of consecutive
quaternions (u = 2 sin(θ/2)/l̄) and the circle through three consecutive nodes.
"""

from __future__ import annotations

import json
import math
import warnings

import matplotlib.pyplot as plt
import numpy as np
import pytest

import rodsim
from rodsim.app.figures import PlotError, draw_figure, plot_dataset, style
from rodsim.app.figures.colouring import COLOURINGS, colouring, node_curvature
from rodsim.app.figures.layers import LAYERS
from rodsim.core.scene import Scene
from rodsim.io.archive import read_dataset, write_dataset
from rodsim.io.run_dataset import run_dataset

LENGTH, RADIUS, YOUNG = 0.1, 1e-3, 1e7
INERTIA, AREA = math.pi * RADIUS**4 / 4, math.pi * RADIUS**2
MOMENT, PULL = 1e-4, 0.5  # N m (a bend of 1.27 rad), N

#: The friction benchmark of tests/test_tendon_friction.py: nitinol backbone, tendon 10 mm off.
F_E, F_RADIUS, F_LENGTH, F_OFFSET, MU, T0 = 54e9, 0.7e-3, 0.2, 0.01, 0.2, 3.0
TENSION = "tendons.a.tendon_string.tension"


def cantilever(load: dict) -> dict:
    return {"name": "colour-cantilever", "rods": {"catheter": {
        "length": LENGTH, "radius": RADIUS, "nodes": 21, "youngs_modulus": YOUNG,
        "density": 1100.0, "terms": ["stretch", "bend_twist", "centerline", *load],
        **load}}}


def friction_catheter(friction: float) -> dict:
    area = math.pi * F_RADIUS**2
    return {"name": "colour-friction", "rods": {"backbone": {
        "length": F_LENGTH, "radius": F_RADIUS, "youngs_modulus": F_E, "stretch_modulus": F_E,
        "density": 6450.0, "nodes": 21, "terms": ["stretch", "bend_twist", "centerline"],
        "centerline": {"K_P": F_E / 2.6 * area}}},
        "tendons": {"a": {"catheter": "backbone", "coupling": "string", "offset": F_OFFSET,
                          "direction": [1.0, 0.0], "tendon_string": {
                              "tension": T0, "spacers": True, "friction": friction}}},
        "solver": {"integrator": "static"}}


@pytest.fixture(scope="module")
def bent():
    """A cantilever under a pure tip moment: a circle of curvature M/(E I)."""
    result = rodsim.solve(cantilever({"point_loads": {"loads": [
        {"s": LENGTH, "force": [0.0, 0.0, 0.0], "moment": [0.0, 0.0, MOMENT]}]}}), "static")
    assert result.success, result.message
    return run_dataset(result)


@pytest.fixture(scope="module")
def rubbing():
    result = rodsim.solve(Scene.from_dict(friction_catheter(MU)))
    assert result.success, result.message
    return run_dataset(result)


def drawn(ds, **options):
    """(gids of every artist, the figure's colour bars by gid, the coloured collections by
    gid) of the run figure of ``ds``."""
    with style():
        figure = draw_figure(ds, **options)
        try:
            gids = {a.get_gid() for a in figure.findobj() if a.get_gid()}
            bars = {ax.get_gid(): ax.get_ylabel() or ax.get_xlabel()  # right or below
                    for ax in figure.axes if ax.get_gid()}
            lines = {c.get_gid(): np.asarray(c.get_array()) for ax in figure.axes
                     for c in ax.collections if c.get_array() is not None and c.get_gid()}
        finally:
            plt.close(figure)
    return gids, bars, lines


def test_the_curvature_of_a_pure_moment_is_m_over_ei_everywhere(bent):
    gids, bars, lines = drawn(bent, colour="curvature")
    values = lines["rod:catheter"]
    # 12.73 1/m; the discrete bending energy of Eq. (3) balances M at u = M/(E I cos(θ/2)),
    # θ = κ l the turn of one segment: 5.1e-4 above the closed form at N = 21.
    closed = MOMENT / (YOUNG * INERTIA)
    assert values == pytest.approx(closed, rel=1e-3)
    assert "[1/m]" in bars["colourbar:curvature"] and "rod:catheter" in gids
    # The same from the positions alone: the circle through three consecutive nodes.
    p = bent["position"].values
    a, b, c = p[:-2], p[1:-1], p[2:]
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    menger = 2 * area2 / (np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - b, axis=1)
                          * np.linalg.norm(c - a, axis=1))
    assert menger == pytest.approx(closed, rel=1e-3)


def test_the_curvature_is_eq3_between_consecutive_quaternions(bent):
    """u = 2 sin(θ/2)/l̄, θ the relative rotation of two segments (from their dot product,
    no B_k), at every inner node; each end node takes its neighbour's."""
    q = bent["quaternion"].values
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    theta = 2 * np.arccos(np.clip(np.abs(np.sum(q[:-1] * q[1:], axis=1)), 0.0, 1.0))
    expected = 2 * np.sin(theta / 2) / np.diff(bent["segment_s"].values)
    values = node_curvature(bent["quaternion"].values, bent["segment_s"].values)
    np.testing.assert_allclose(values[1:-1], expected, rtol=1e-9)
    assert values[0] == values[1] and values[-1] == values[-2]
    # A straight rod: zero.
    straight = np.tile(bent["quaternion"].values[:1], (5, 1))
    np.testing.assert_allclose(node_curvature(straight, np.arange(5) * 0.01), 0.0, atol=1e-12)


def test_the_strain_of_an_axial_pull_is_f_over_ea():
    ds = run_dataset(rodsim.solve(cantilever({"tip_load": {"mass": 0.0,
                                                           "force": [PULL, 0.0, 0.0]}}),
                                  "static"))
    _, bars, lines = drawn(ds, colour="strain")
    assert lines["rod:catheter"] == pytest.approx(PULL / (YOUNG * AREA), rel=1e-6)
    assert "[m/m]" in bars["colourbar:strain"]


def test_the_tension_of_a_friction_tendon_is_the_capstan_closed_form(rubbing):
    _, bars, lines = drawn(rubbing, colour="tension")
    values = lines["tendon:a"]
    np.testing.assert_array_equal(values, rubbing["tension_profile"].values)  # chord by chord
    c = MU * T0 * F_OFFSET / (F_E * math.pi * F_RADIUS**4 / 4)
    closed = T0 / (1 + c * rubbing["chord_s"].values)
    np.testing.assert_allclose(values, closed, rtol=1e-2)
    assert values[0] > values[-1] and "[N]" in bars["colourbar:tension"]


def test_a_tendon_without_friction_carries_its_tension():
    ds = run_dataset(rodsim.solve(Scene.from_dict(friction_catheter(0.0))))
    assert "tension_profile" not in ds
    assert drawn(ds, colour="tension")[2]["tendon:a"] == pytest.approx(T0, rel=1e-12)


def test_a_rod_tendon_carries_its_actuation_force():
    """tendon-conserving: a rod tendon pulled by F_A = 2 N at its base, no friction, its
    axial force E_s π r² (|r′| − 1) is F_A along its whole length."""
    ds = run_dataset(rodsim.solve("tendon-conserving", "static", overrides=[
        "rods.catheter.nodes=15", "rods.tendon.nodes=15"]))
    values = drawn(ds, colour="tension")[2]["tendon:tendon"]
    assert len(values) == 14 and values == pytest.approx(2.0, rel=1e-3)


def test_an_archive_without_the_optional_arc_lengths_draws_or_says_why(rubbing, tmp_path,
                                                                       cli, capsys):
    """``segment_s`` and ``s`` are not part of the archive contract (a fuzzed track without
    ``segment_s`` crashed ``rodsim plot`` with a KeyError): without ``segment_s`` the figure
    is drawn, the string tendon's path with it left out; a rod tendon's tension colouring
    without ``s`` is one line and exit 2."""
    archive = write_dataset(rubbing.drop_vars("segment_s"), tmp_path / "no-segment-s.nc")
    assert cli(["plot", str(archive), "--format", "svg"]) == 0
    assert (tmp_path / "no-segment-s.svg").exists()
    gids = drawn(read_dataset(archive))[0]
    assert "rod:backbone" in gids and "tendon:a" not in gids
    ds = run_dataset(rodsim.solve("tendon-conserving", "static", overrides=[
        "rods.catheter.nodes=15", "rods.tendon.nodes=15"]))
    archive = write_dataset(ds.drop_vars("s"), tmp_path / "no-s.nc")
    assert cli(["plot", str(archive), "--colour", "tension"]) == 2
    err = capsys.readouterr().err
    assert "rest arc length" in err and len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


@pytest.mark.parametrize("value", [np.inf, np.nan, 1e300])
def test_a_point_not_finite_is_left_out_of_the_figure(tmp_path, cli, capsys, value):
    """A shape with an infinite, NaN or 1e300 m coordinate (fuzzed run archives of
    table1-50g, its tip load drawn as an arrow) is drawn without that point, as a NaN one
    is (tests/test_api_tracebacks.py), and without numpy's "invalid value" or "overflow"
    warnings, which the infinite and the 1e300 m ones raised."""
    ds = run_dataset(rodsim.solve("table1-50g", "static", overrides=["nodes=12"]))
    positions = ds["position"].values.copy()
    positions[0, 0] = value
    archive = write_dataset(ds.assign(position=(ds["position"].dims, positions)),
                            tmp_path / "infinite.nc")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert cli(["plot", str(archive), "--format", "svg"]) == 0, capsys.readouterr().err
    assert (tmp_path / "infinite.svg").exists()


def test_no_tendon_no_tension_one_line(bent, tmp_path, cli, capsys):
    with pytest.raises(PlotError, match="has no tendon"):
        drawn(bent, colour="tension")
    archive = write_dataset(bent, tmp_path / "bent.nc")
    assert cli(["plot", str(archive), "--colour", "tension"]) == 2
    err = capsys.readouterr().err
    assert "no tendon" in err and len(err.strip().splitlines()) == 1
    assert "Traceback" not in err and not (tmp_path / "bent.png").exists()
    with pytest.raises(SystemExit) as refused:  # argparse's choices: exit 2, one line
        cli(["plot", str(archive), "--colour", "torsion"])
    assert refused.value.code == 2
    err = capsys.readouterr().err
    assert "curvature" in err and len(err.strip().splitlines()) == 1


def test_the_command_line_offers_every_colouring(cli, capsys):
    with pytest.raises(SystemExit):
        cli(["plot", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "{" + ",".join(COLOURINGS) + "}" in text


#: The gid prefixes of each layer (rodsim/app/figures/scene_drawing.py).
PREFIXES = {"shape": ("rod:",), "tendon": ("tendon:", "termination:"), "load": ("load:",),
            "contact": ("contact:",), "obstacle": ("obstacle:",)}


@pytest.fixture(scope="module")
def everything(rubbing):
    """The friction run with a point moment on its stored scene, an obstacle and a contact
    force on its tip added (the figure draws the archive: no contact solve needed)."""
    ds = rubbing.copy()
    scene = json.loads(ds.attrs["scene_json"])
    rod = scene["rods"]["backbone"]
    rod["terms"] = [*rod["terms"], "point_loads"]
    rod["point_loads"] = {"loads": [{"s": F_LENGTH, "force": [0.0, -1.0, 0.0],
                                     "moment": [0.0, 0.0, 0.0]}]}
    scene["obstacles"] = {"wall": {"type": "plane", "rods": ["backbone"],
                                   "point": [0.0, 0.1, 0.0], "normal": [0.0, -1.0, 0.0]}}
    ds.attrs["scene_json"] = json.dumps(scene)
    force = np.zeros((ds.sizes["node"], 3))
    force[-1] = [0.0, -0.1, 0.0]
    ds["contact_force"] = (("node", "axis"), force, {"units": "N"})
    return ds


def test_hidden_layers_are_absent_and_the_others_drawn(everything):
    every, _, _ = drawn(everything)
    for layer, prefixes in PREFIXES.items():
        assert any(g.startswith(prefixes) for g in every), layer
    assert set(PREFIXES) == set(LAYERS)
    for layer, prefixes in PREFIXES.items():
        gids, _, _ = drawn(everything, hide=[layer])
        assert not any(g.startswith(prefixes) for g in gids), layer
        others = [p for name, ps in PREFIXES.items() if name != layer for p in ps]
        assert {g for g in every if g.startswith(tuple(others))} <= gids, layer
    gids, _, _ = drawn(everything, hide=["load", "contact"], colour="curvature")
    assert not any(g.startswith(("load:", "contact:")) for g in gids)
    assert "rod:backbone" in gids and "colourbar:curvature" in gids


def test_an_unknown_layer_is_one_line_naming_the_allowed(everything, tmp_path, cli, capsys):
    with pytest.raises(PlotError, match="layers: " + ", ".join(LAYERS)):
        drawn(everything, hide=["rods"])
    assert "load:backbone:point_loads" not in drawn(everything, hide="load,contact")[0]
    archive = write_dataset(everything.drop_vars("contact_force"), tmp_path / "run.nc")
    assert cli(["plot", str(archive), "--hide", "load,loads"]) == 2
    err = capsys.readouterr().err
    assert "'loads'" in err and ", ".join(LAYERS) in err and len(err.strip().splitlines()) == 1


def test_vector_output_still_works(rubbing, tmp_path, cli, capsys):
    paths = plot_dataset(rubbing, tmp_path / "fig", ["pdf", "svg"], colour="tension",
                         hide=["shape"])
    assert [p.suffix for p in paths] == [".pdf", ".svg"]
    assert paths[0].read_bytes().startswith(b"%PDF")
    svg = paths[1].read_text(encoding="utf-8")
    assert 'id="tendon:a"' in svg and 'id="rod:backbone"' not in svg
    archive = write_dataset(rubbing, tmp_path / "run.nc")
    assert cli(["plot", str(archive), "--colour", "curvature", "--hide", "tendon",
                "--format", "svg", "-o", str(tmp_path / "cli")]) == 0
    assert "cli.svg" in capsys.readouterr().out


@pytest.fixture(scope="module")
def cycles(tmp_path_factory):
    """A pull–release track of the friction catheter, and the same without friction."""
    folder = tmp_path_factory.mktemp("cycle")
    out = []
    for friction in (MU, 0.0):
        track = rodsim.track(Scene.from_dict(friction_catheter(friction)),
                             {TENSION: [0.5, 1.5, 3.0, 1.5, 0.5]}, estimates=False)
        out.append(read_dataset(write_dataset(track.to_xarray(), folder / f"{friction}.nc")))
    return out


def test_the_track_figure_draws_the_tip_path_and_the_loop(cycles, tmp_path, cli, capsys):
    rubbing, smooth = cycles
    tips = rubbing["position"].values[:, -1]
    with style():
        figure = draw_figure(rubbing)
        try:
            artists = {a.get_gid(): a for a in figure.findobj() if a.get_gid()}
            title = figure._suptitle.get_text()
            np.testing.assert_array_equal(artists["tip-path"].get_xydata(), tips[:, :2])
            rising, falling = artists["response:y:0"], artists["response:y:1"]
            np.testing.assert_array_equal(rising.get_xdata(), [0.5, 1.5, 3.0])
            np.testing.assert_array_equal(falling.get_xdata(), [3.0, 1.5, 0.5])
            np.testing.assert_allclose(falling.get_ydata(), tips[2:, 1] - tips[0, 1])
            assert rising.get_linestyle() == "-" and falling.get_linestyle() == "--"
        finally:
            plt.close(figure)
    # The largest tip distance at equal tension, computed here: steps 1 and 3 (1.5 N) or
    # 0 and 4 (0.5 N).
    gaps = {(1, 3): np.linalg.norm(tips[1] - tips[3]), (0, 4): np.linalg.norm(tips[0] - tips[4])}
    (first, second), gap = max(gaps.items(), key=lambda item: item[1])
    assert f"{1e3 * gap:.3g} mm apart" in title and f"(steps {first} and {second})" in title
    assert gap > 1e-3 * F_LENGTH  # friction holds the bend on the way back
    smooth_tips = smooth["position"].values[:, -1]
    assert np.linalg.norm(smooth_tips[1] - smooth_tips[3]) < 1e-3 * gap  # no friction, no loop
    fit = rubbing.copy()
    fit.attrs["kind"] = "fit"  # the figures of other archives refuse the options
    with pytest.raises(PlotError, match="not to a fit archive"):
        drawn(fit, colour="curvature")
    with pytest.raises(PlotError, match="not to a fit archive"):
        drawn(fit, hide=["load"])


def series(figure_lines, gid):
    """The coloured collections of ``gid`` in drawing order (one per state)."""
    return [values for name, values in figure_lines if name == gid]


def drawn_all(ds, **options):
    """(every coloured collection as (gid, values) in drawing order, the colour bars'
    (gid, limits)) of the figure of ``ds``."""
    with style():
        figure = draw_figure(ds, **options)
        try:
            lines = [(c.get_gid(), np.asarray(c.get_array())) for ax in figure.axes
                     for c in ax.collections if c.get_array() is not None and c.get_gid()]
            bars = [(ax.get_gid(), ax.get_ylim()) for ax in figure.axes
                    if str(ax.get_gid()).startswith("colourbar:")]
        finally:
            plt.close(figure)
    return lines, bars


@pytest.fixture(scope="module")
def smooth_run():
    """The catheter without friction at T = 3 N, solved as a run."""
    return run_dataset(rodsim.solve(Scene.from_dict(friction_catheter(0.0))))


def test_a_tracks_steps_are_coloured_as_runs_on_one_scale(cycles, smooth_run):
    """Each step's colours are the run figure's computation at that step: the curvature of
    the step at T = 3 N equals that of the same scene solved as a run (no friction: the
    path does not matter); each step's tendon carries the ramped tension, not the stored
    scene's; one colour bar spans every step's values."""
    rubbing, smooth = cycles
    ramp = [0.5, 1.5, 3.0, 1.5, 0.5]
    lines, bars = drawn_all(smooth, colour="tension")
    tendon = series(lines, "tendon:a")
    assert len(tendon) == 5 and [bars[0][0]] == [b[0] for b in bars] == ["colourbar:tension"]
    for values, tension in zip(tendon, ramp, strict=True):
        assert values == pytest.approx(tension, rel=1e-12)
    assert bars[0][1] == pytest.approx((0.5, 3.0))
    lines, bars = drawn_all(smooth, colour="curvature")
    rod = series(lines, "rod:backbone")
    run_lines, _ = drawn_all(smooth_run, colour="curvature")
    np.testing.assert_allclose(rod[2], series(run_lines, "rod:backbone")[0], rtol=1e-5)
    every = np.concatenate(rod)
    assert len(bars) == 1 and bars[0][1] == pytest.approx((every.min(), every.max()))
    # with friction: each step the quaternions' curvature (Eq. (3)) of that step
    lines, _ = drawn_all(rubbing, colour="curvature", hide=["tendon"])
    for step, values in enumerate(series(lines, "rod:backbone")):
        expected = node_curvature(rubbing["quaternion"].values[step],
                                  rubbing["segment_s"].values)
        np.testing.assert_array_equal(values, np.stack([expected[:-1], expected[1:]],
                                                       axis=1).reshape(-1))
    assert not series(lines, "tendon:a")


def test_the_3d_view_colours_the_line_trace_and_hides_layers(everything, cycles):
    pytest.importorskip("plotly", reason="plotly is the optional extra rodsim[view3d]")
    from rodsim.app.figures.scene_parts import scene_parts
    from rodsim.app.figures.view3d import view_figure

    figure = view_figure(everything, "curvature")
    (rod,) = [t for t in figure.data if t.name == "backbone"]
    expected = colouring(everything, "curvature", scene_parts(everything)).lines["backbone"]
    np.testing.assert_array_equal(np.asarray(rod.line.color)[::3], expected.values)
    assert rod.line.showscale and "[1/m]" in rod.line.colorbar.title.text
    assert rod.line.cmin == pytest.approx(expected.values.min())
    names = {t.name for t in view_figure(everything).data}
    assert {"backbone", "a", "termination a", "loads", "contact forces",
            "plane wall"} <= names
    hidden = {"shape": {"backbone"}, "tendon": {"a", "termination a", "spacer disks"},
              "load": {"loads"},
              "contact": {"contact forces"}, "obstacle": {"plane wall"}}
    assert set(hidden) == set(LAYERS)
    for layer, gone in hidden.items():
        left = {t.name for t in view_figure(everything, hide=frozenset({layer})).data}
        assert not gone & left and names - gone == left, layer
    # a track: each frame's tendon coloured by its step's tension, one scale for all
    smooth = cycles[1]
    track = view_figure(smooth, "tension", frozenset({"load", "contact"}))
    frames = [[t for t in frame.data if t.name == "a"][0] for frame in track.frames]
    assert [float(np.asarray(t.line.color)[0]) for t in frames] == pytest.approx(
        [0.5, 1.5, 3.0, 1.5, 0.5])
    assert {(t.line.cmin, t.line.cmax) for t in frames} == {(0.5, 3.0)}
    assert "[N]" in frames[0].line.colorbar.title.text


@pytest.fixture(scope="module")
def pushed(tmp_path_factory):
    """The 50 g mass let go with a programmed tip force F_y(t) = −10 t N/s on top."""
    run = rodsim.simulate("table1-50g", 0.02, output_dt=0.01, overrides=["nodes=9"],
                          program={"tip_load.force[1]": ([0.0, 0.02], [0.0, -0.2])})
    assert run.success, run.message
    return read_dataset(write_dataset(run.to_xarray(),
                                      tmp_path_factory.mktemp("push") / "push.nc"))


def test_a_trajectorys_loads_are_its_programs_at_each_time(pushed, tmp_path, cli, capsys):
    from PIL import Image

    from rodsim.app.figures.scene_parts import scene_parts

    weight = 0.05 * 9.81
    for k, t in enumerate(pushed["time"].values):  # 0, 0.01, 0.02 s
        (tip,) = [a for a in scene_parts(pushed, k).loads if a.gid.endswith("tip_load")]
        assert tip.vector[1] == pytest.approx(-weight - 10.0 * t, rel=1e-12)
    lines, bars = drawn_all(pushed, colour="strain", hide=["load"])
    assert len(series(lines, "rod:catheter")) == 3 and [b[0] for b in bars] == [
        "colourbar:strain"]
    archive = tmp_path / "push.nc"
    write_dataset(pushed, archive)
    assert cli(["plot", str(archive), "--movie-format", "gif", "--colour", "curvature", "--hide",
                "load", "--format", "png"]) == 0
    assert "push.gif" in capsys.readouterr().out
    with Image.open(tmp_path / "push.gif") as gif:
        assert gif.n_frames == 3
    assert cli(["plot", str(archive), "--colour", "tension"]) == 2
    err = capsys.readouterr().err
    assert "no tendon" in err and len(err.strip().splitlines()) == 1
