"""Rules across tables (issue 23, item 7): radius vs length, a tendon's length vs its
catheter's, a lumen offset vs the radii. A ``--set`` (or a ramp) of one value that makes
another table's value invalid was blamed on the value the user never gave, and a ramp was
found out only at the breaking step, after the earlier steps' work. Now the message names
what the user set, and a ramp is checked before any work."""

from __future__ import annotations

import pytest

import rodsim
import rodsim.app.api
from rodsim.app.inverse.track import track
from rodsim.core.schema import SceneError

ROD_NODES = ["--set", "rods.catheter.nodes=10", "--set", "rods.tendon.nodes=10"]

CASES = [  # scene, what the user sets, the value it makes invalid
    ("table1-50g", "length=0.001", "rods.catheter.radius = 0.006"),
    ("table3-catheter1", "rods.catheter.length=0.05", "rods.tendon.length = 0.16"),
    ("table3-catheter1", "rods.catheter.radius=0.0004", "tendons.tendon.offset = 0.003"),
    ("table3-catheter1", "rods.catheter.radius=0.00301", "tendons.tendon.offset = 0.003"),
]


@pytest.mark.parametrize(("scene", "assignment", "broken"), CASES)
def test_a_set_that_breaks_another_tables_value_is_named(scene, assignment, broken, tmp_path,
                                                         cli, capsys):
    output = tmp_path / "out.nc"
    assert cli(["run", scene, "--set", assignment, "-o", str(output)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"rodsim: error: --set {assignment}: makes {broken} (the "
                             "scene's value, not set) invalid; allowed: "), err
    assert not output.exists()


@pytest.mark.parametrize(("scene", "assignment", "broken"), CASES)
def test_the_python_api_names_the_set_key_too(scene, assignment, broken):
    with pytest.raises(SceneError) as raised:
        rodsim.load_scene(scene, [assignment])
    key = raised.value.key
    assert key.endswith(assignment.partition("=")[0]) and raised.value.assignment == assignment
    assert str(raised.value).startswith(f"{key} = {assignment.partition('=')[2]} makes "
                                        f"{broken} ")


def test_setting_the_value_a_rule_names_keeps_the_plain_message(tmp_path, cli, capsys):
    """The user set the offending value itself: it is the one named, as before."""
    assert cli(["run", "table3-catheter1", "--set", "tendons.tendon.offset=0.05",
                "-o", str(tmp_path / "o.nc")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rodsim: error: tendons.tendon.offset = 0.05: the lumen lies "
                          "outside the catheter"), err


@pytest.mark.parametrize(("values", "step"), [([1.0, 0.6, 0.3, 0.003], 3),
                                              ([1.0, 0.003, 1.0], 1)])
def test_a_ramp_that_breaks_a_rule_is_refused_before_any_work(values, step, monkeypatch):
    """The breaking step is found before step 0 is solved (a solve fails the test), and the
    ramp is blamed, not the radius it made invalid."""
    def no_solve(*args, **kwargs):
        raise AssertionError("solved before the ramp was checked")

    monkeypatch.setattr(rodsim.app.api, "solve", no_solve)
    scene = rodsim.load_scene("table1-50g", ["nodes=10"])
    with pytest.raises(SceneError) as raised:
        track(scene, {"length": values})
    assert str(raised.value).startswith(
        f"--ramp rods.catheter.length reaches 0.003 at step {step}, which makes "
        "rods.catheter.radius = 0.006 (the scene's value, not set) invalid"), raised.value


def test_a_ramp_through_the_cli_is_one_line_exit_2(tmp_path, cli, capsys):
    assert cli(["track", "table3-catheter1", *ROD_NODES, "--ramp",
                "rods.catheter.radius=0.006:0.001:5", "-o", str(tmp_path / "t.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(
        "rodsim: error: --ramp rods.catheter.radius reaches 0.001 at step 4, which makes "
        "tendons.tendon.offset = 0.003"), err
