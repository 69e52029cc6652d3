"""A run's figure draws every part of its scene (issue 36): for every shipped scene, each
rod, tendon (with its termination), obstacle, load and contact force present has an artist
named by its ``gid``; every registered term says how it is drawn and every registered
obstacle type is drawn; an obstacle type added the documented way (a subclass with a new
``type`` and only its gap) is drawn by the figures too, through the obstacle's own outline.
"""

from __future__ import annotations

import json
import re
import sys

import matplotlib.pyplot as plt
import numpy as np
import pytest

import rodsim
from rodsim.app.figures import draw_figure, style
from rodsim.app.figures.contact import draw_contact
from rodsim.app.figures.scene_parts import CONTACT, LOAD, SHAPE, TENDON, term_drawings
from rodsim.core.obstacles import OBSTACLES, Obstacle, registered_obstacles
from rodsim.core.scene import scene_paths
from rodsim.core.schema import Parameter
from rodsim.core.terms import registered_terms
from rodsim.io.archive_schema import stored_scene
from rodsim.io.run_dataset import run_dataset

#: Scenes that take long at their own size, solved coarser here (the parts are the same).
COARSER = {"four-tendons": [f"rods.{rod}.nodes=12" for rod in
                            ("catheter", "tendon_py", "tendon_pz", "tendon_my", "tendon_mz")]}


def gids(figure) -> set[str]:
    """Every artist's gid in ``figure``."""
    found = set()
    for artist in figure.findobj():
        gid = artist.get_gid()
        if gid:
            found.add(gid)
    return found


def nonzero_load(term: str, table: dict) -> bool:
    """Whether the load term ``term`` of a rod or tendon table pushes at all."""
    o = table[term]
    if term == "tip_load":
        return bool(o["mass"] * o["gravity"] or np.any(o["force"]))
    if term == "point_loads":
        return any(np.any(x["force"]) or np.any(x["moment"]) for x in o["loads"])
    if term == "distributed_load":
        return bool(np.any(o["force_per_length"])
                    or any(np.any(x["force_per_length"]) for x in o["spans"]))
    if term == "gravity":
        return bool(o["gravity"])
    if term == "tendon_actuation":
        return bool(o["force"])
    raise AssertionError(f"load term {term!r} has no rule here: add one")


def expected_gids(ds) -> set[str]:
    """What the figure of run archive ``ds`` must draw, read from its scene."""
    scene = json.loads(ds.attrs["scene_json"])
    tendons = scene.get("tendons") or {}
    out = {f"rod:{name}" for name in scene["rods"] if name not in tendons}
    out |= {f"{what}:{name}" for name in tendons for what in ("tendon", "termination")}
    out |= {f"obstacle:{name}" for name in scene.get("obstacles") or {}}
    for owners in (scene["rods"], tendons):
        for name, table in owners.items():
            for term in table.get("terms", ()):
                if term_drawings()[term] == LOAD and nonzero_load(term, table):
                    out.add(f"load:{name}:{term}")
    if "contact_force" in ds:
        forces = ds["contact_force"].values
        rods = ds["rod"].values.astype(str)
        out |= {f"contact:{rod}" for rod in rods[np.linalg.norm(forces, axis=1) > 0]}
    return out


def drawn(ds) -> set[str]:
    with style():
        figure = draw_figure(ds)
        try:
            return gids(figure)
        finally:
            plt.close(figure)


@pytest.mark.parametrize("scene", sorted(scene_paths()))
def test_every_shipped_scene_draws_every_part(scene, tmp_path):
    """Drawn from the run archive written and read back, as ``rodsim plot`` draws it."""
    from rodsim.io.archive import read_dataset, write_dataset

    ds = read_dataset(write_dataset(
        run_dataset(rodsim.solve(scene, overrides=COARSER.get(scene, []))),
        tmp_path / f"{scene}.nc"))
    expected = expected_gids(ds)
    assert any(g.startswith("rod:") for g in expected)
    missing = expected - drawn(ds)
    assert not missing, f"{scene}: not drawn: {sorted(missing)}"


def test_every_registered_term_says_how_it_is_drawn():
    drawings = term_drawings()
    assert set(registered_terms()) == set(drawings)
    assert set(drawings.values()) == {SHAPE, TENDON, LOAD, CONTACT}


def scene_with(obstacles: dict[str, dict]) -> dict:
    """A soft cantilever under a tip load with the given obstacles."""
    return {"name": "obstacles", "rods": {"catheter": {
        "length": 0.1, "radius": 0.001, "nodes": 11, "youngs_modulus": 1e7, "density": 1100.0,
        "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
        "tip_load": {"mass": 0.0, "force": [0.0, -0.01, 0.0]}}},
        "obstacles": {name: {"rods": ["catheter"], **table}
                      for name, table in obstacles.items()}}


def archive_with_obstacles(obstacles: dict[str, dict]):
    """The run archive of a scene without obstacles, the obstacles then added to its stored
    scene (the figure reads the scene only: no contact kernel is needed for a new type)."""
    scene = scene_with(obstacles)
    bare = {k: v for k, v in scene.items() if k != "obstacles"}
    ds = run_dataset(rodsim.solve(bare))
    stored = json.loads(ds.attrs["scene_json"])
    stored["obstacles"] = scene["obstacles"]
    stored_scene(json.dumps(stored), "test")  # valid
    ds.attrs["scene_json"] = json.dumps(stored)
    return ds


def test_every_registered_obstacle_type_is_drawn():
    types = registered_obstacles()
    ds = archive_with_obstacles({f"my_{kind}": {"type": kind, **cls.example}
                                 for kind, cls in types.items()})
    with style():
        figure = draw_figure(ds)
        try:
            for kind in types:
                drawn = [a for a in figure.findobj() if a.get_gid() == f"obstacle:my_{kind}"]
                assert drawn and any(len(s) for a in drawn for s in a.get_segments()), kind
        finally:
            plt.close(figure)


@pytest.fixture
def ellipsoid():
    """A throwaway obstacle type with only a gap (the scaled radius: an approximate
    distance), registered for one test."""

    class Ellipsoid(Obstacle):
        type = "test_ellipsoid"
        kernel = "contact_test_ellipsoid"  # none: the figures never compile it
        parameters = (Parameter("center", "vector", None, "m", "centre", -1e3, 1e3, length=3),
                      Parameter("axes", "vector", None, "m", "semi-axes", 0.0, 1e3, length=3))

        def gap(self, points):
            c, axes = np.asarray(self.table["center"]), np.asarray(self.table["axes"])
            scaled = np.linalg.norm((points - c) / axes, axis=1)
            n = len(points)
            return ((scaled - 1.0) * float(np.min(axes)), np.zeros((n, 3)),
                    np.zeros((n, 3, 3)))

        def kernel_arguments(self):
            raise NotImplementedError

    try:
        yield Ellipsoid
    finally:
        del OBSTACLES[Ellipsoid.type]


def test_an_obstacle_type_added_without_a_drawing_is_drawn_by_its_gap(ellipsoid):
    table = {"type": "test_ellipsoid", "center": [0.05, -0.02, 0.0],
             "axes": [0.03, 0.01, 0.01]}
    ds = archive_with_obstacles({"bulge": table})
    assert "obstacle:bulge" in drawn(ds)
    # the track and contact figures' path (it assumed every other obstacle was a tube)
    scene = stored_scene(ds.attrs["scene_json"], "test")
    figure, ax = plt.subplots()
    try:
        positions = ds["position"].values
        draw_contact(ax, scene, positions, np.zeros_like(positions), (0, 1))
        (collection,) = [a for a in ax.findobj() if a.get_gid() == "obstacle:bulge"]
        points = np.concatenate(collection.get_segments())
    finally:
        plt.close(figure)
    # the outline lies on the ellipse (x − 0.05)²/0.03² + (y + 0.02)²/0.01² = 1, to a
    # grid cell
    radius = np.hypot((points[:, 0] - 0.05) / 0.03, (points[:, 1] + 0.02) / 0.01)
    assert len(points) > 20 and np.max(np.abs(radius - 1.0)) < 0.05
    # the 3D view draws its outlines (it has no surface of its own)
    pytest.importorskip("plotly", reason="plotly is the optional extra rodsim[view3d]")
    from rodsim.app.figures.view3d import view_figure

    (trace,) = [t for t in view_figure(ds).data if t.name == "test_ellipsoid bulge"]
    assert np.isfinite(np.asarray(trace.x, dtype=float)).sum() > 20


@pytest.mark.parametrize("scene", ["catheter-helical", "tdcr-two-segment",
                                   "catheter-pull-ring"])
def test_a_string_tendons_drawn_path_is_the_models(scene):
    """The routing points drawn from the archive (nodes, segment quaternions) are the
    model's own (``TendonString.path`` on the solved state): the termination exactly,
    the others to 2 % of the offset (the figure interpolates the frame between segment
    midpoints and clamps it beyond them; the model uses the base frame at s = 0)."""
    from rodsim.app.figures.scene_parts import scene_parts
    from rodsim.core.terms.tendon_string import TendonString

    result = rodsim.solve(scene)
    model = rodsim.build_model(scene)
    full = model.full(result.state)
    drawn_paths = {t.name: t.points for t in scene_parts(run_dataset(result)).tendons}
    strings = [t for t in model.terms if isinstance(t, TendonString)]
    assert strings
    for term in strings:
        expected, got = term.path(full), drawn_paths[term.tendon.name]
        offset = float(np.max(np.abs(term.points.offset)))
        assert got.shape == expected.shape
        np.testing.assert_allclose(got[-1], expected[-1], rtol=0, atol=1e-12)
        assert np.max(np.abs(got - expected)) < 0.02 * offset


@pytest.mark.slow  # a command-line run that draws its figure: 2-4 s of CPU
def test_a_tracks_movie_has_one_frame_per_step(tmp_path, cli, capsys):
    from PIL import Image

    archive = tmp_path / "track.nc"
    assert cli(["track", "table1-50g", "--set", "nodes=8", "--ramp",
                "tip_load.mass=0:0.05:5", "-o", str(archive)]) == 0
    assert cli(["plot", str(archive), "--movie-format", "gif", "--format", "png"]) == 0
    assert "track.gif" in capsys.readouterr().out
    with Image.open(tmp_path / "track.gif") as movie:
        assert movie.n_frames == 5
    run = tmp_path / "run.nc"
    assert cli(["run", "table1-50g", "--set", "nodes=8", "-o", str(run)]) == 0
    capsys.readouterr()
    assert cli(["plot", str(run), "--movie"]) == 2
    err = capsys.readouterr().err
    assert "track archive" in err and "Traceback" not in err and len(err.splitlines()) == 1
    assert not (tmp_path / "run.png").exists()  # refused before anything is drawn


@pytest.mark.slow  # a command-line run that draws its figure: 2-4 s of CPU
def test_a_trajectorys_movie_draws_its_output_times(tmp_path, cli, capsys, monkeypatch):
    """``rodsim simulate``'s archive: one frame per output time (at most MAX_FRAMES, evenly
    spaced with the first and the last), each frame the rod where the archive has it at that
    time; without Pillow the movie is refused in one line before any file is written."""
    from PIL import Image

    from rodsim.app.figures import movie
    from rodsim.app.figures.scene_parts import scene_parts
    from rodsim.io.archive import read_dataset

    archive = tmp_path / "swing.nc"
    assert cli(["simulate", "table1-50g", "--set", "nodes=9", "--t-end", "0.05",
                "--output-dt", "0.01", "-o", str(archive)]) == 0
    ds = read_dataset(archive)
    picked, captions = movie.frames(ds)
    assert picked == list(range(6)) and captions[-1].startswith("t = 0.05 s (output 6 of 6)")
    for k in (0, 3, 5):  # the falling mass: every frame in a different place
        drawn = scene_parts(ds, k).rods["catheter"]
        assert np.array_equal(drawn, ds["position"].isel(time=k).values)
    assert not np.allclose(scene_parts(ds, 0).rods["catheter"],
                           scene_parts(ds, 5).rods["catheter"])
    capsys.readouterr()
    assert cli(["plot", str(archive), "--movie-format", "gif", "--format", "png"]) == 0
    assert "swing.gif" in capsys.readouterr().out
    with Image.open(tmp_path / "swing.gif") as gif:
        assert gif.n_frames == 6
    monkeypatch.setattr(movie, "MAX_FRAMES", 4)
    assert movie.frames(ds)[0] == [0, 2, 3, 5]
    monkeypatch.setitem(sys.modules, "PIL", None)  # no GIF encoder
    assert cli(["plot", str(archive), "-o", str(tmp_path / "again"), "--movie-format",
                "gif"]) == 2
    err = capsys.readouterr().err
    assert "pip install pillow" in err and "Traceback" not in err and len(err.splitlines()) == 1
    assert not list(tmp_path.glob("again*"))


@pytest.mark.parametrize("seed", range(3))
def test_loads_of_robots_of_other_sizes_are_drawn_as_they_act(seed):
    """Seeded robots (steel, nitinol, soft polymer; 2–30 cm; mN to N loads) with a tip load,
    a world-frame point force, a distributed load on a span and gravity, one with sections:
    each load is drawn where it acts with its resultant, and the weight is the model's own
    lumped masses times g."""
    from rodsim.app.figures.scene_parts import scene_parts

    rng = np.random.default_rng(seed)
    modulus, density = [(2e11, 7850.0), (6e10, 6450.0), (2e7, 1100.0)][seed]
    length = float(rng.uniform(0.02, 0.3))
    radius = float(rng.uniform(2e-4, 1.5e-3))
    stiffness = modulus * np.pi * radius**4 / 4
    scale = float(rng.uniform(0.05, 0.3)) * stiffness / length**2  # a moderate bend
    point = [float(v) for v in rng.normal(0.0, scale, 3)]
    span_q = [0.0, -scale / length, 0.0]
    rod = {"length": length, "radius": radius, "nodes": 13, "youngs_modulus": modulus,
           "density": density,
           "terms": ["stretch", "bend_twist", "centerline", "tip_load", "point_loads",
                     "distributed_load", "gravity"],
           "tip_load": {"mass": 0.0, "force": [0.0, 0.0, scale]},
           "point_loads": {"loads": [{"s": length / 2, "force": point, "frame": "world"}]},
           "distributed_load": {"spans": [{"start": 0.25 * length, "end": 0.75 * length,
                                           "force_per_length": span_q}]}}
    if seed == 2:
        rod["sections"] = [{"start": 0.0, "end": length / 2, "inner_radius": radius / 2},
                           {"start": length / 2, "end": length}]
    scene = {"name": f"robot{seed}", "rods": {"wire": rod}}
    result = rodsim.solve(scene)
    assert result.success, result.message
    ds = run_dataset(result)
    loads = {a.gid: a for a in scene_parts(ds).loads}
    nodes = result.positions("wire")
    np.testing.assert_allclose(loads["load:wire:tip_load"].point, nodes[-1])
    np.testing.assert_allclose(loads["load:wire:tip_load"].vector, [0.0, 0.0, scale])
    middle = np.interp(length / 2, result.rods["wire"].s, np.arange(len(nodes)))
    lower = int(np.floor(middle))
    expected = nodes[lower] + (middle - lower) * (nodes[min(lower + 1, len(nodes) - 1)]
                                                  - nodes[lower])
    np.testing.assert_allclose(loads["load:wire:point_loads"].point, expected, atol=1e-12)
    np.testing.assert_allclose(loads["load:wire:point_loads"].vector, point)
    np.testing.assert_allclose(loads["load:wire:distributed_load"].vector,
                               np.array(span_q) * 0.5 * length, rtol=1e-12)
    weight = rodsim.build_model(result.scene).rods["wire"].node_masses().sum() * 9.81
    np.testing.assert_allclose(loads["load:wire:gravity"].vector, [0.0, -weight, 0.0],
                               rtol=1e-9)
    assert {f"load:wire:{t}" for t in ("tip_load", "point_loads", "distributed_load",
                                       "gravity")} <= drawn(ds)


def test_arrows_are_drawn_to_the_scale_the_panel_states():
    """A soft cantilever under a 0.3 N tip force and a 0.1 N point force at its middle (world
    frame, in the x–y plane): the panel states "forces: L mm ≙ 0.3 N" (the largest load, the
    scene's own number), the tip force's arrow is L mm long and the point force's L/3, each
    starting where it acts; the contact forces of tip-on-tissue have a scale of their own."""
    from matplotlib.text import Annotation

    rod = {"length": 0.1, "radius": 0.001, "nodes": 11, "youngs_modulus": 1e8,
           "density": 1100.0, "terms": ["stretch", "bend_twist", "centerline", "tip_load",
                                        "point_loads"],
           "tip_load": {"mass": 0.0, "force": [0.0, -0.3, 0.0]},
           "point_loads": {"loads": [{"s": 0.05, "force": [0.1, 0.0, 0.0],
                                      "frame": "world"}]}}
    ds = run_dataset(rodsim.solve({"name": "arrows", "rods": {"wire": rod}}))
    with style():
        figure = draw_figure(ds)
        try:
            (stated,) = [t.get_text() for t in figure.findobj()
                         if t.get_gid() == "scale:forces"]
            arrows = {a.get_gid(): (np.array(a.xyann), np.array(a.xy))
                      for a in figure.findobj(Annotation) if a.get_gid()}
        finally:
            plt.close(figure)
    found = re.fullmatch(r"forces: ([0-9.]+) mm ≙ ([0-9.]+) N", stated)
    assert found, stated
    length, largest = float(found[1]) * 1e-3, float(found[2])
    assert largest == pytest.approx(0.3, rel=1e-3)
    nodes = ds["position"].values
    for gid, force, point in (("load:wire:tip_load", 0.3, nodes[-1]),
                              ("load:wire:point_loads", 0.1, None)):
        tail, head = arrows[gid]
        assert np.linalg.norm(head - tail) == pytest.approx(length * force / 0.3, rel=5e-3)  # .3g
        if point is not None:
            np.testing.assert_allclose(tail, point[:2], atol=1e-12)
    tip, _ = arrows["load:wire:tip_load"]
    assert (arrows["load:wire:tip_load"][1] - tip)[1] < 0  # pointing down, as the force
    with style():
        figure = draw_figure(run_dataset(rodsim.solve("tip-on-tissue")))
        try:
            gids = {t.get_gid() for t in figure.findobj() if str(t.get_gid()).startswith(
                "scale:")}
        finally:
            plt.close(figure)
    assert {"scale:contact", "scale:moments"} <= gids
