"""Tracking (rodsim/app/inverse/track.py, ``rodsim track``): warm-started equilibria along a
path agree with cold solves, cost a fraction of them, halve failing steps and report the
failures they cannot pass."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import rodsim
from rodsim.app.inverse.continuation import Continuation
from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with
from rodsim.core.model import Model
from rodsim.io.archive import read_dataset


def _cold(scene, values: dict, integrator: str = "static"):
    result = rodsim.solve(scene.with_values(values), integrator)
    assert result.success, result.message
    return np.concatenate([shape.positions for shape in result.rods.values()]), result


def test_every_step_is_the_equilibrium_a_cold_solve_finds():
    scene = rodsim.load_scene("table1-50g", ["nodes=20"])
    masses = [0.0, 0.03, 0.06, 0.09]
    path = rodsim.track(scene, {"tip_load.mass": masses}, "static", estimates=False)
    assert path.success and path.steps == 4
    for step, mass in enumerate(masses):
        cold, _ = _cold(scene, {"rods.catheter.tip_load.mass": mass})
        assert np.abs(path.positions[step] - cold).max() < 1e-8 * 0.12


def test_several_keys_ramp_together():
    scene = rodsim.load_scene("table1-50g", ["nodes=20"])
    path = rodsim.track(scene, {"tip_load.mass": [0.05, 0.08],
                                "youngs_modulus": [5.9e6, 4e6]}, "static",
                        estimates=False)
    assert path.success
    cold, _ = _cold(scene, {"rods.catheter.tip_load.mass": 0.08,
                            "rods.catheter.youngs_modulus": 4e6})
    assert np.abs(path.positions[-1] - cold).max() < 1e-8 * 0.12


def test_a_tendon_track_keeps_the_registration_and_costs_a_few_newton_iterations():
    scene = rodsim.load_scene("table3-catheter1")
    path = rodsim.track(scene, {"tendon_actuation.force": np.linspace(1.0, 2.0, 11)},
                        estimates=False)
    assert path.success
    cold, result = _cold(scene, {"tendons.tendon.tendon_actuation.force": 2.0})
    assert np.abs(path.positions[-1] - cold).max() < 1e-8 * 0.16
    # A cold static solve takes tens of Newton iterations (load and penalty continuation:
    # 29 since the retraction of static.py, 88 before); a warm step a handful.
    assert max(path.iterations[1:]) <= result.stats["newton_iters"] / 4


@pytest.mark.parametrize("integrator", ["cvode", "paper"])
def test_pseudo_dynamic_integrators_start_from_the_previous_equilibrium(integrator):
    # At a tolerance above the round-off floor: the paper integrator comes to rest after
    # three steps below it, and at the floor of the offset state (2.2e-9 here, 5.5e-9 at
    # 27422c4) its warm and cold runs both took 12 steps; at 1e-8 (both versions) 10 and 12.
    scene = rodsim.load_scene("table1-50g", ["nodes=20", "tolerance=1e-8"])
    path = rodsim.track(scene, {"tip_load.mass": [0.04, 0.05]}, integrator, estimates=False)
    assert path.success
    cold, result = _cold(scene, {"rods.catheter.tip_load.mass": 0.05}, integrator)
    assert np.abs(path.positions[-1] - cold).max() < 1e-6 * 0.12
    assert path.iterations[1] < result.stats["steps"]  # fewer steps than from rest


def test_a_step_too_large_for_newton_is_passed_in_halved_increments():
    scene = rodsim.load_scene("table3-catheter1")
    path = rodsim.track(scene, {"tendon_actuation.force": [0.5, 3.0]}, estimates=False)
    assert path.success
    assert path.halvings[1] > 0
    cold, _ = _cold(scene, {"tendons.tendon.tendon_actuation.force": 3.0})
    assert np.abs(path.positions[-1] - cold).max() < 1e-8 * 0.16


def test_a_step_that_cannot_be_passed_is_reported_not_skipped():
    scene = rodsim.load_scene("table3-catheter1")
    path = rodsim.track(scene, {"tendon_actuation.force": [0.5, 1.0, 5000.0, 1.0]},
                        estimates=False)
    assert not path.success
    assert path.failed_step == 2 and path.steps == 2
    assert "step 2" in path.message and "5000" in path.message


def test_track_command_writes_a_self_describing_archive_and_a_figure(tmp_path, capsys, cli):
    output = tmp_path / "path.nc"
    code = cli(["track", "table1-50g", "--set", "nodes=12", "--ramp", "tip_load.mass=0:0.1:5",
                "--ramp", "tip_load.force[0]=0:0.2:5", "-o", str(output)])
    assert code == 0, capsys.readouterr().err
    assert (tmp_path / "path.png").exists()
    with xr.open_dataset(output) as ds:
        assert ds.sizes["step"] == 5
        mass = ds["rods_catheter_tip_load_mass"]  # no dots in names (CF)
        assert mass.attrs["scene_key"] == "rods.catheter.tip_load.mass"
        np.testing.assert_allclose(mass.values, np.linspace(0, 0.1, 5))
        assert mass.attrs["units"] == "kg"
        assert ds["rods_catheter_tip_load_force_0"].attrs["units"] == "N"
        for name in list(ds.data_vars) + list(ds.coords):
            assert "long_name" in ds[name].attrs, name
        for name in ("position", "wall_time", "residual"):
            assert "units" in ds[name].attrs, name
        assert ds.attrs["kind"] == "track" and ds.attrs["scene_json"]
    read_dataset(output)  # the archive contract holds
    assert cli(["plot", str(output), "-o", str(tmp_path / "drawn")]) == 0
    assert (tmp_path / "drawn.png").exists()
    assert cli(["rerun", str(output)]) == 0
    assert "re-ran 5 steps" in capsys.readouterr().out


@pytest.mark.parametrize(("ramp", "message"), [
    (["tip_load.mass=0:0.1"], "KEY=START:STOP:COUNT"),
    (["tip_load.mass=0:x:3"], "must be numbers"),
    (["tip_load.mass=0:0.1:3", "K_P=1e4:1e5:4"], "same number of values"),
    (["tip_load.mass=-1:0.1:3"], "out of range"),
    (["nodes=10:20:3"], "discretisation"),
])
def test_bad_ramps_exit_2_with_one_line_and_write_nothing(tmp_path, capsys, cli, ramp,
                                                          message):
    output = tmp_path / "bad.nc"
    argv = ["track", "table1-50g"] + [arg for r in ramp for arg in ("--ramp", r)]
    assert cli([*argv, "-o", str(output)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_a_failed_track_exits_1_and_keeps_its_finished_steps(tmp_path, capsys, cli):
    output = tmp_path / "fail.nc"
    code = cli(["track", "table3-catheter1", "--ramp", "tendon_actuation.force=0.5:5000:2",
                "-o", str(output)])
    assert code == 1
    assert "step 1" in capsys.readouterr().err
    assert read_dataset(output).attrs["complete"] == 0  # step 0, marked incomplete


def test_a_track_whose_first_step_fails_writes_nothing(tmp_path, capsys, cli):
    code = cli(["track", "table3-catheter1", "--ramp", "tendon_actuation.force=5000:1:2",
                "-o", str(tmp_path / "fail.nc")])
    assert code == 1
    assert "step 0" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_string_tendon_tracking_steps_are_solved_by_chord_iterations_without_newton():
    # A continuation step of static factors J at its start and again where the chord
    # iterations stall (rodsim/solvers/static.py, Static._chord); with the factorisation
    # kept from the last step they stalled on every other step of this ramp and Newton
    # (a Jacobian and a factorisation per iteration, a line search on the energy) took over.
    scene = rodsim.load_scene("tdcr-two-segment")
    keys = numeric_keys(scene, ["tendons.s1a.tendon_string.tension"])
    values = np.linspace(0.5, 1.5, 21)
    first = rodsim.solve(scene_with(scene, keys, [values[0]]), "static")
    continuation = Continuation(Model(first.scene), first.state)
    previous, with_newton = None, 0
    for value in values[1:]:
        predictor = None if previous is None else 2.0 * continuation.x - previous
        last = continuation.x
        assert continuation.solve(scene_with(scene, keys, [value]), predictor).success
        previous = last
        with_newton += continuation.state.counts["newton_iters"] > 0
    assert with_newton <= 2
    cold = rodsim.solve(scene_with(scene, keys, [values[-1]]), "static")
    model = continuation.model
    length = max(rod.length for rod in model.rods.values())
    for rod in model.rods:
        assert np.abs(model.positions(continuation.x, rod)
                      - model.positions(cold.state, rod)).max() < 1e-8 * length


def test_static_turns_the_predictor_as_rigid_frames_where_its_retraction_does():
    # The secant predictor x_k + dx extrapolates turning segments along straight lines,
    # which stretches them; static's "frames" retraction turns them (Static.predicted).
    scene = rodsim.load_scene("tdcr-two-segment")
    keys = numeric_keys(scene, ["tendons.s1a.tendon_string.tension"])
    path = rodsim.track(scene, {"tendons.s1a.tendon_string.tension": [1.0, 1.5, 2.0]},
                        estimates=False)
    assert path.success
    model = Model(scene_with(scene, keys, [2.5]))
    x0, x1 = (model.state_of(state) for state in path.states[1:])
    dx = x1 - x0
    integrator = rodsim.solvers.integrator_named("static").for_scene(scene)
    turned, straight = integrator.predicted(model, x1, dx), x1 + dx

    def stretch(x):  # largest relative change of a backbone segment's length
        r = model.positions(x, "backbone")
        length = np.linalg.norm(np.diff(r, axis=0), axis=1)
        rest = np.linalg.norm(np.diff(model.positions(x1, "backbone"), axis=0), axis=1)
        return np.max(np.abs(length / rest - 1.0))

    # measured: half the stretch and half the residual at this coarse step (0.5 N)
    assert stretch(turned) < 0.6 * stretch(straight)
    residual = model.force_residual
    assert residual(model.force(turned)) < 0.6 * residual(model.force(straight))
    # where the retraction is "lengths" (a tendon that is a rod) the straight line is kept
    table3 = rodsim.load_scene("table3-catheter1")
    other = Model(table3)
    np.testing.assert_array_equal(
        integrator.predicted(other, other.x0, np.full(other.n, 1e-6)), other.x0 + 1e-6)
