"""No traceback on odd input (issue 37, item 6): a vessel csv with two points 1e-20 m
apart, a section area of 1e-320, `plot` of a contact track archive with a NaN, empty key
lists for fit and reach, numpy integers as counts."""

from __future__ import annotations

import json

import numpy as np
import pytest

import rodsim
from rodsim.app.inverse.fit import FitError, Points
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.io.archive import read_dataset, write_dataset


def _vessel(tmp_path, rows, name):
    path = tmp_path / f"{name}.csv"
    path.write_text("".join(",".join(repr(float(v)) for v in row) + "\n" for row in rows))
    return str(path)


def test_vessel_points_1e_20_apart_are_solved_or_refused_in_one_line(tmp_path):
    """Main already refuses coincident points; points 1e-20 m apart but not equal: on a
    straight centerline the tube is the one without the extra point (same tip to 1e-9 L),
    on a bent one a clear SceneError (the spline bends tighter than the vessel)."""
    straight = [[0, 0, 0, 0.002], [1e-20, 0, 0, 0.002], [0.2, 0, 0, 0.002]]
    plain = [[0, 0, 0, 0.002], [0.2, 0, 0, 0.002]]
    tips = []
    for name, rows in (("near", straight), ("plain", plain)):
        scene = rodsim.load_scene("vessel-insertion", [
            f"obstacles.vessel.file={_vessel(tmp_path, rows, name)}", "nodes=11",
            "origin=[0.001,0,0]"])
        result = rodsim.solve(scene, "static")
        assert result.success, result.message
        tips.append(result.tip())
    assert np.abs(tips[0] - tips[1]).max() < 1e-9 * 0.1
    bent = [[0, 0, 0, 0.002], [1e-20, 0, 0, 0.002], [0.04, 0, 0, 0.002],
            [0.06, 0.01, 0, 0.002], [0.07, 0.03, 0, 0.002]]
    with pytest.raises(SceneError, match="bends tighter"):
        rodsim.load_scene("vessel-insertion", [
            f"obstacles.vessel.file={_vessel(tmp_path, bent, 'bent')}"])


@pytest.mark.parametrize("name", ["area", "second_moment", "polar_moment"])
def test_a_subnormal_section_value_is_refused(name, cli, capsys):
    """1e-320 m² (a subnormal: its reciprocal is infinite) made every force NaN; now one
    line, exit 2. The smallest normal double is still accepted."""
    assert cli(["run", "catheter-pull-ring", "--set", f"rods.catheter.sections.0.{name}="
                "1e-320", "-o", "/nonexistent/x.nc"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "too small" in err[0] and name in err[0]
    rodsim.load_scene("catheter-pull-ring", [f"rods.catheter.sections.0.{name}=3e-308"])


@pytest.mark.slow  # a command-line run that draws its figure: 2-4 s of CPU
def test_plot_of_a_contact_track_with_a_nan_position(tmp_path, cli, capsys):
    """A contact track archive with one NaN control point was a matplotlib traceback
    ("Axis limits cannot be NaN or Inf"); now it is drawn without that point."""
    out = tmp_path / "t.nc"
    assert cli(["track", "tip-on-tissue", "--set", "nodes=12", "--ramp",
                "youngs_modulus=3e7:2e7:3", "-o", str(out)]) == 0, capsys.readouterr().err
    for name in ("position", "contact_force"):
        stored = read_dataset(out)
        stored[name].values[1, 3, 0] = np.nan
        write_dataset(stored, tmp_path / f"{name}.nc")
        capsys.readouterr()
        assert cli(["plot", str(tmp_path / f"{name}.nc"), "-o",
                    str(tmp_path / f"{name}-drawn")]) == 0, capsys.readouterr().err
        assert (tmp_path / f"{name}-drawn.png").exists()


def test_empty_key_lists_are_one_line_errors():
    """fit(params=[]) and reach(actuate=[]) failed unpacking (ValueError)."""
    scene = rodsim.load_scene("table1-50g", ["nodes=8"])
    with pytest.raises(FitError, match="non-empty list"):
        rodsim.fit(scene, Points(np.array([[0.05, 0, 0], [0.1, 0, 0]])), [])
    with pytest.raises(SceneError, match="non-empty list"):
        rodsim.reach(scene, [0.1, 0, 0], [])
    with pytest.raises(SceneError, match="non-empty list"):
        rodsim.reach(scene, [0.1, 0, 0], 3)


@pytest.mark.parametrize("kind", [np.int64, np.int32, np.uint16])
def test_numpy_integers_are_node_counts(kind):
    """A count from numpy (np.arange, a table) was refused as "wrong type"; it is the same
    scene as with the Python int. numpy floats are numbers too; a bool is not a count."""
    data = json.loads(rodsim.load_scene("table1-50g").to_json())
    data["rods"]["catheter"]["nodes"] = kind(9)
    data["rods"]["catheter"]["length"] = np.float32(0.125)
    scene = Scene.from_dict(data)
    assert scene.rods["catheter"].nodes == 9
    assert type(scene.data["rods"]["catheter"]["nodes"]) is int
    data["rods"]["catheter"]["nodes"] = np.bool_(True)
    with pytest.raises(SceneError, match="wrong type"):
        Scene.from_dict(data)
