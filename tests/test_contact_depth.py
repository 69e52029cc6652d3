"""Contact is a rigid wall only within the penalty law's validity (rodsim/core/contact_depth.py,
DEPTH_LIMIT radii; docs/contact.md): a deeper equilibrium is a failure with its reason, a
held node inside a solid obstacle and facing planes with no room are refused, and a rest
shape through a wall gets a warning (issue 37, item 3c)."""

from __future__ import annotations

import types
from pathlib import Path

import numpy as np
import pytest

import rodsim
from rodsim.app.contact_report import contact_warnings
from rodsim.core.contact_depth import DEPTH_LIMIT, rest_crossings
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError

DATA = Path(__file__).parent / "data"
RADIUS = 0.0015
PLANE_Y = 0.004


def pressed(scale: float, force: float = 0.05, **rod) -> Scene:
    """A polymer cantilever whose tip force pushes it up onto a plane 4 mm above its axis."""
    table = {"length": 0.1, "radius": RADIUS, "youngs_modulus": 3e7, "stretch_modulus": 3e7,
             "density": 1100.0, "nodes": 21, "clamp": "frame",
             "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
             "tip_load": {"force": [0.0, force, 0.0]}} | rod
    return Scene.from_dict({"name": "press", "rods": {"c": table}, "obstacles": {"tissue": {
        "type": "plane", "rods": ["c"], "point": [0.0, PLANE_Y, 0.0], "normal": [0.0, -1.0, 0.0],
        "stiffness_scale": scale}}})


@pytest.mark.parametrize("integrator", ["static", "ida"])
def test_an_equilibrium_deeper_than_the_law_is_a_failure_with_its_reason(integrator):
    """With a soft penalty (stiffness_scale 0.1) the tip sinks 0.27 r into the plane,
    measured from the returned positions; with 1 it sinks 0.035 r and is accepted."""
    deep = rodsim.solve(pressed(0.1), integrator)
    depth = (deep.rods["c"].positions[:, 1].max() + RADIUS - PLANE_Y) / RADIUS
    assert depth > DEPTH_LIMIT
    assert not deep.success
    assert "radii inside obstacle 'tissue'" in deep.message
    assert "contact law's validity" in deep.message
    shallow = rodsim.solve(pressed(1.0), integrator)
    assert shallow.success, shallow.message
    depth = (shallow.rods["c"].positions[:, 1].max() + RADIUS - PLANE_Y) / RADIUS
    assert 0.0 < depth < DEPTH_LIMIT


def test_the_issue_plane_through_the_base_is_refused():
    """tip-on-tissue with its plane at y = -5 mm: exit 0 "stable" with the rod 4.3 radii
    inside rigid tissue, before."""
    with pytest.raises(SceneError, match=r"holds its base .* 4\.33 radii inside"):
        rodsim.load_scene("tip-on-tissue", ["obstacles.tissue.point=[0,-0.005,0]"])


def test_the_cli_refuses_the_issue_scene_with_exit_2(capsys):
    from rodsim.app.cli.main import main

    assert main(["run", "tip-on-tissue", "--set", "obstacles.tissue.point=[0,-0.005,0]"]) == 2
    assert "radii inside the obstacle" in capsys.readouterr().err


def test_a_rod_based_inside_a_sphere_is_refused():
    data = pressed(1e3).data | {"obstacles": {"ball": {
        "type": "sphere", "rods": ["c"], "center": [0.0, 0.001, 0.0], "radius": 0.003}}}
    with pytest.raises(SceneError, match="holds its base"):
        Scene.from_dict(data)


def test_a_support_forcing_a_node_into_a_plane_is_refused():
    """A node support lifting the tip 20 mm, 12 radii past the plane 4 mm above."""
    with pytest.raises(SceneError, match="support 'tip'"):
        pressed(1e3, supports={"tip": {"s": 0.1, "displacement": [0.0, 0.02, 0.0]}})
    pressed(1e3, supports={"tip": {"s": 0.1, "displacement": [0.0, 0.001, 0.0]}})


@pytest.mark.parametrize(("gap", "refused"), [(-0.001, True), (0.002, True), (0.0035, False)])
def test_facing_planes_that_leave_no_room_are_refused(gap, refused):
    """A floor at y = -1.5 mm and a ceiling ``gap`` above it (the rod is 3 mm thick)."""
    data = pressed(1e3).data
    data["obstacles"] = {
        "floor": {"type": "plane", "rods": ["c"], "point": [0.0, -0.0016, 0.0],
                  "normal": [0.0, 1.0, 0.0]},
        "ceiling": {"type": "plane", "rods": ["c"], "point": [0.0, -0.0016 + gap, 0.0],
                    "normal": [0.0, -1.0, 0.0]}}
    if refused:
        with pytest.raises(SceneError, match="no free space"):
            Scene.from_dict(data)
    else:
        Scene.from_dict(data)


def test_a_rest_shape_through_the_wall_is_warned_about():
    """The user's guidewire: its straight rest shape leaves its 90-degree vessel."""
    scene = rodsim.load_scene(str(DATA / "guidewire.toml"))
    crossings = rest_crossings(Model(scene))
    assert len(crossings) == 1 and "crosses obstacle 'vessel'" in crossings[0]
    lines = contact_warnings(types.SimpleNamespace(scene=scene, rods={}))
    assert lines and lines[0].startswith("warning     the rest shape of rod 'wire'")
    # The shipped contact scenes start clear of their walls.
    for name in ("tip-on-tissue", "vessel-insertion"):
        assert rest_crossings(Model(rodsim.load_scene(name))) == []


@pytest.mark.parametrize("name", ["tip-on-tissue", "vessel-insertion"])
def test_shipped_contact_scenes_stay_within_the_law(name):
    result = rodsim.solve(rodsim.load_scene(name))
    assert result.success, result.message
    model = Model(result.scene)
    from rodsim.core.terms.contact import Contact

    full = model.full(result.state)
    deepest = max(float(np.max(t.penetration(full))) / t.radius for t in model.terms
                  if isinstance(t, Contact))
    assert deepest < DEPTH_LIMIT


def test_a_failure_from_a_rest_shape_through_the_wall_says_so(tmp_path, cli, capsys):
    """`rodsim track guidewire.toml --ramp rods.wire.base.insertion=…` failed at step 0 with
    static, advising a smaller load step or IDA, without a word of the cause a successful
    run warns about: the wire's rest shape crosses its vessel. The one failure line now
    names it."""
    code = cli(["track", str(DATA / "guidewire.toml"), "--ramp",
                "rods.wire.base.insertion=0:0.01:2", "-o", str(tmp_path / "t.nc")])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1, err
    assert "solver failure" in err and "rest shape of rod 'wire' crosses obstacle 'vessel'" in err
    assert err.count("crosses obstacle") == 1, err  # named once, by the advice


def test_static_advises_a_start_inside_not_smaller_steps_from_a_rest_shape_through_the_wall():
    """The user's guidewire (straight rest shape 191 radii through its vessel): static's
    failure advised a smaller first load step or ida, and named the crossing only on the
    command line. A 100x smaller step and 200 Newton iterations fail the same way, ida
    spends its budget (benchmarks/results/default-integrator.md). The failure itself now
    names the crossing and the remedy, in Python too."""
    result = rodsim.solve(rodsim.load_scene(str(DATA / "guidewire.toml")), "static")
    assert not result.success
    assert "rest shape of rod 'wire' crosses obstacle 'vessel'" in result.message
    assert "track the insertion" in result.message
    assert "first_load_step" not in result.message and "(ida)" not in result.message


def test_a_run_in_physical_time_that_fails_from_a_rest_shape_through_the_wall_says_so():
    """The user's guidewire simulated from rest: its first midpoint step diverged against
    the vessel its straight rest shape crosses (152 radii deep), and the run's message
    advised only a smaller step. It now names the crossing, once."""
    result = rodsim.simulate(str(DATA / "guidewire.toml"), 0.002, output_dt=0.001)
    assert not result.success
    assert result.message.count("rest shape of rod 'wire' crosses obstacle 'vessel'") == 1
    assert "track the insertion" in result.message
