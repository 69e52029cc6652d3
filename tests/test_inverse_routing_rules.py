"""track, fit and reach never solve a scene that run refuses: a string tendon's routing rules
(rodsim/core/routing.py: an end beyond the tip or before the start, routing outside the
catheter, a helix its nodes alias) bound every ramp value and every fit or reach unknown
before any work (issue 37, item 3b)."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.app.cli.main import main
from rodsim.app.inverse.fit import Points
from rodsim.app.inverse.parameter_keys import numeric_key
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError


def test_the_issue_track_is_refused_before_any_work_and_writes_nothing(tmp_path, capsys):
    """`track catheter-helical --ramp helix_radius=0.003:0.01:3` solved three steps, then
    crashed with a traceback and wrote nothing."""
    out = tmp_path / "t.nc"
    code = main(["track", "catheter-helical", "--ramp", "helix_radius=0.003:0.01:3",
                 "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "helix_radius = 0.0065" in err and "inside the catheter's radius" in err
    assert not out.exists()


@pytest.mark.parametrize(("ramp", "words"), [
    ({"tendons.wire_up.tendon_string.start": [0.0, 0.05, 0.1]}, "start < end"),
    ({"tendons.wire_up.tendon_string.end": [0.09, 0.1, 0.11]}, "end <= L"),
    ({"tendons.wire_up.tendon_string.end": [0.09, 0.0]}, "end = 0 names the tip"),
])
def test_python_track_refuses_a_ramp_that_breaks_a_routing_rule(ramp, words):
    scene = rodsim.load_scene("catheter-pull-ring")
    with pytest.raises(SceneError, match=words):
        rodsim.track(scene, ramp)


def test_a_helix_ramp_is_checked_at_every_step_for_the_sampling_rule():
    """A pitch ramp that crosses zero passes through aliased helices between its ends."""
    scene = rodsim.load_scene("catheter-helical")
    with pytest.raises(SceneError, match="4 segments"):
        rodsim.track(scene, {"helix_pitch": [0.32, 0.01, 0.32]})
    with pytest.raises(SceneError, match="4 segments"):
        rodsim.track(scene, {"helix_pitch": [0.32, -0.32]})


def test_a_table_ramp_is_checked_at_every_step():
    """A knot's offset whose spline overshoots the wall only in the middle of the ramp."""
    data = {"name": "table-ramp", "rods": {"c": {
        "length": 0.1, "radius": 0.004, "youngs_modulus": 5e6, "stretch_modulus": 5e6,
        "density": 1100.0, "nodes": 21, "clamp": "frame",
        "terms": ["stretch", "bend_twist", "centerline"]}},
        "tendons": {"t": {"catheter": "c", "coupling": "string", "tendon_string": {
            "tension": 0.5, "routing": "table", "table_s": [0.0, 0.03, 0.06, 0.1],
            "table_y": [0.001, 0.001, 0.001, 0.001], "table_z": [0.0, 0.0, 0.0, 0.0]}}}}
    scene = Scene.from_dict(data)
    # table_y[1] within the wall at each knot (|y| < 4 mm) at every value, but the spline
    # through (1, 3.9, -3.9, 1) mm overshoots the wall between the knots.
    values = np.array([[0.001, 0.001], [0.0039, -0.0039], [0.001, 0.001]])
    with pytest.raises(SceneError, match="step 1"):
        rodsim.track(scene, {"table_y[1]": values[:, 0], "table_y[2]": values[:, 1]})


def test_fit_and_reach_bounds_come_from_the_routing_rules():
    ring = rodsim.load_scene("catheter-pull-ring")
    assert numeric_key(ring, "wire_up.tendon_string.end").bounds()[1] == pytest.approx(0.1)
    low, _ = numeric_key(ring, "wire_up.tendon_string.end").bounds()
    assert low > ring.get("tendons.wire_up.tendon_string.start")
    helical = rodsim.load_scene("catheter-helical")
    assert numeric_key(helical, "helix_radius").bounds()[1] < 0.006
    assert numeric_key(helical, "helix_pitch").bounds()[0] == pytest.approx(4 * 0.16 / 40)


def test_reach_with_an_end_beyond_the_tip_stays_on_the_catheter():
    """The issue's reach was an IndexError (the optimiser moved the end past L = 0.1 m)."""
    scene = rodsim.load_scene("catheter-pull-ring")
    result = rodsim.reach(scene, [0.05, 0.05, 0.0], ["wire_up.tendon_string.end"],
                          max_evaluations=8)
    end = float(np.asarray(result.values)[0])
    assert 0.0 < end <= 0.1


def test_fit_of_a_tip_termination_is_refused_before_any_work():
    """end = 0 names the tip; a fit starting there moved the end past the tip."""
    scene = rodsim.load_scene("catheter-helical")
    points = np.array([[0.1, 0.01, 0.0], [0.15, 0.02, 0.0]])
    with pytest.raises(SceneError, match="end = 0 names the tip"):
        rodsim.fit(scene, Points(points, None), ["helix.tendon_string.end"])


def test_a_multi_leg_ramp_is_checked_in_every_leg(tmp_path, capsys):
    """parse_ramp's later legs (KEY=START:STOP:COUNT:STOP:COUNT): the second leg goes down to
    an aliased pitch (0.004 m: one segment per turn at N = 41)."""
    out = tmp_path / "t.nc"
    code = main(["track", "catheter-helical", "--ramp", "helix_pitch=0.32:0.1:3:0.004:2",
                 "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "4 segments" in err and "Traceback" not in err
    assert not out.exists()
