"""Inverse kinematics (rodsim/app/inverse/reach.py, ``rodsim reach``): tensions recovered from
the tip they produce, on a catheter with several tendons in 3D; unreachable targets fail
with the closest tip found."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import rodsim
from rodsim.io.archive import read_dataset

TENDONS = ("tendon_py", "tendon_pz", "tendon_my", "tendon_mz")
SMALL = [f"{rod}.nodes=10" for rod in ("catheter", *TENDONS)]
FORCE = "{}.tendon_actuation.force"


@pytest.fixture(scope="module")
def four_tendons():
    return rodsim.load_scene("four-tendons", SMALL)


def _tip(scene, forces: dict[str, float]) -> np.ndarray:
    """The catheter tip solved cold (static) with the given tendon tensions."""
    result = rodsim.solve(scene.with_overrides([f"{FORCE.format(t)}={f}"
                                                for t, f in forces.items()]), "static")
    assert result.success
    return result.tip("catheter")


def test_two_tensions_are_recovered_from_the_3d_tip_they_produce(four_tendons):
    truth = {"tendon_py": 3.0, "tendon_pz": 2.0}
    target = _tip(four_tendons, truth)
    assert abs(target[1]) > 1e-3 and abs(target[2]) > 1e-3  # a 3D target
    found = rodsim.reach(four_tendons, target, [FORCE.format(t) for t in truth])
    assert found.success, found.message
    np.testing.assert_allclose(found.values, list(truth.values()), rtol=1e-6)
    assert found.distance < 1e-6


@pytest.mark.slow
def test_four_tendons_reach_a_target_with_tensions_that_reproduce_it(four_tendons):
    """With four tendons the tensions that reach a tip are not unique: the ones found are
    checked by solving forward with them."""
    target = _tip(four_tendons, {"tendon_py": 4.0, "tendon_pz": 1.0, "tendon_my": 1.0,
                                 "tendon_mz": 2.5})
    found = rodsim.reach(four_tendons, target, [FORCE.format(t) for t in TENDONS])
    assert found.success, found.message
    assert np.all(found.values >= 0.0)
    again = _tip(four_tendons, dict(zip(TENDONS, found.values, strict=True)))
    assert np.linalg.norm(again - target) < 1e-6


def test_a_target_beyond_the_catheter_is_out_of_reach_with_the_closest_tip(four_tendons):
    found = rodsim.reach(four_tendons, [0.3, 0.0, 0.0], [FORCE.format(t) for t in TENDONS])
    assert not found.success
    assert "out of reach" in found.message
    # Pulling any tendon shortens the reach along x: the closest tip is the straight rod's,
    # with every tension at its bound 0.
    np.testing.assert_allclose(found.values, 0.0, atol=1e-9)
    assert found.distance == pytest.approx(0.3 - 0.16, abs=1e-6)


def test_a_planar_catheter_cannot_reach_out_of_its_plane():
    found = rodsim.reach(rodsim.load_scene("table3-catheter1"), [0.13, 0.08, 0.01],
                         ["tendon_actuation.force"])
    assert not found.success
    assert found.distance == pytest.approx(0.0102, abs=2e-4)
    assert abs(found.tip[2]) < 1e-12


@pytest.mark.slow  # a command-line run that draws its figure: 2-4 s of CPU
def test_reach_command_writes_the_archive_and_a_figure(tmp_path, capsys, cli):
    scene = rodsim.load_scene("four-tendons", SMALL)
    target = _tip(scene, {"tendon_py": 2.0, "tendon_mz": 1.5})
    output = tmp_path / "reach.nc"
    argv = ["reach", "four-tendons", "--tip", ",".join(f"{c:.12g}" for c in target),
            "--actuate", FORCE.format("tendon_py"), "--actuate", FORCE.format("tendon_mz"),
            "-o", str(output)]
    for override in SMALL:
        argv += ["--set", override]
    assert cli(argv) == 0, capsys.readouterr().err
    assert (tmp_path / "reach.png").exists()
    with xr.open_dataset(output) as ds:
        found = ds["tendons_tendon_py_tendon_actuation_force"]  # no dots in names (CF)
        assert float(found) == pytest.approx(2.0, rel=1e-6)
        assert found.attrs["scene_key"] == "tendons.tendon_py.tendon_actuation.force"
        assert ds["target"].attrs["units"] == "m"
        for name in list(ds.data_vars) + list(ds.coords):
            assert "long_name" in ds[name].attrs, name
        assert ds.attrs["kind"] == "reach"
    read_dataset(output)
    assert cli(["rerun", str(output)]) == 0
    assert cli(["plot", str(output), "-o", str(tmp_path / "drawn")]) == 0


def test_reach_command_out_of_reach_exits_1_and_writes_nothing(tmp_path, capsys, cli):
    code = cli(["reach", "table3-catheter1", "--tip", "0.3,0,0", "--actuate",
                "tendon_actuation.force", "-o", str(tmp_path / "r.nc")])
    assert code == 1
    err = capsys.readouterr().err
    assert "out of reach" in err and "closest tip" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("argv", "message"), [
    (["--tip", "0.1,0"], "three finite numbers"),
    (["--tip", "0.1,0,x"], "X,Y,Z"),
    (["--tip", "0.1,0,0", "--actuate", "catheter.nodes"], "discretisation"),
    (["--tip", "0.1,0,0", "--actuate", "no_such_key"], "unknown key"),
])
def test_reach_command_bad_input_exits_2(tmp_path, capsys, cli, argv, message):
    base = ["reach", "table3-catheter1", "-o", str(tmp_path / "r.nc")]
    if "--actuate" not in argv:
        argv = [*argv, "--actuate", "tendon_actuation.force"]
    try:
        code = cli(base + argv)
    except SystemExit as exc:  # argparse's usage errors (one line, exit 2)
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("origin", [-0.02, 0.0])
def test_reach_starts_from_the_scene_values_whatever_their_sign(origin, least_squares_starts):
    """Parameters are scaled by their magnitude (1 where they are 0), so the start is the
    scaled scene value: −1 for a negative one, 0 for a zero one. It used to be 1 for every
    parameter, i.e. +0.02 m instead of −0.02 m, and 1 m instead of 0 here."""
    scene = rodsim.load_scene("table1-50g", ["nodes=10", f"origin=[0.0, {origin}, 0.0]"])
    target = rodsim.solve(scene, "static").tip()
    found = rodsim.reach(scene, target, ["origin[1]"])
    assert found.success, found.message
    assert least_squares_starts[0][0] == (np.sign(origin) if origin else 0.0)
    assert found.values[0] == pytest.approx(origin, abs=1e-9)


def test_reach_reports_progress_after_each_equilibrium():
    """Issue 22: `rodsim reach` printed nothing while it ran (164 s on four-tendons)."""
    scene = rodsim.load_scene("table3-catheter1", ["catheter.nodes=10", "tendon.nodes=6"])
    key = "tendons.tendon.tendon_actuation.force"
    target = rodsim.solve(scene.with_overrides([f"{key}=1.5"]), "static").tip("catheter")
    heard = []
    found = rodsim.reach(scene, target, [key], progress=lambda f, status: heard.append(status))
    assert found.success and len(heard) >= 2
    assert all(s.startswith("reach: equilibrium ") and "from the target" in s for s in heard)
