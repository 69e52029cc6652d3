"""Fitting (rodsim/app/inverse/fit.py, ``rodsim fit``): synthetic data from known values are
recovered, the standard errors describe the scatter, and bad data or unidentifiable
parameters are refused with one line and exit 2."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

import rodsim
from rodsim.app.inverse.fit import FitError, Points, fit, read_points
from rodsim.io.archive import read_dataset


def synthetic(scene, truth: dict, *, count: int = 30, noise: float = 0.0, seed: int = 0,
              with_s: bool = False, rod: str | None = None) -> Points:
    """Points on the equilibrium at the ``truth`` values (set with ``--set``, solved cold),
    at random rest arc lengths between the nodes, with Gaussian noise in x and y [m]."""
    result = rodsim.solve(scene.with_overrides([f"{k}={v}" for k, v in truth.items()]),
                          "static")
    assert result.success
    shape = result.rods[rod or next(iter(result.rods))]
    rng = np.random.default_rng(seed)
    s = np.sort(rng.uniform(0.0, shape.s[-1], count))
    xyz = np.column_stack([np.interp(s, shape.s, shape.positions[:, i]) for i in range(3)])
    xyz[:, :2] += rng.normal(0.0, noise, (count, 2))
    return Points(xyz, s if with_s else None)


@pytest.fixture(scope="module")
def cantilever():
    return rodsim.load_scene("table1-50g", ["nodes=20"])


@pytest.mark.parametrize("with_s", [False, True])
def test_a_modulus_is_recovered_exactly_from_exact_data(cantilever, with_s):
    result = fit(cantilever, synthetic(cantilever, {"youngs_modulus": 5.0e6}, with_s=with_s),
                 ["youngs_modulus"])
    assert result.values[0] == pytest.approx(5.0e6, rel=1e-6)
    assert result.residual_rms < 1e-9
    assert result.result.success  # the fitted scene's own equilibrium


def test_standard_errors_describe_the_scatter_of_noisy_fits(cantilever):
    """Ten noise draws: the true value within two standard errors in most, and the
    normalised errors (fit − truth)/SE scatter with a standard deviation near 1."""
    z = []
    for seed in range(10):
        points = synthetic(cantilever, {"youngs_modulus": 5.0e6}, noise=1e-4, seed=seed)
        result = fit(cantilever, points, ["youngs_modulus"])
        z.append((result.values[0] - 5.0e6) / result.errors[0])
        assert result.degrees_of_freedom == len(points.xyz)  # planar: 1 per point
    z = np.array(z)
    assert np.mean(np.abs(z) < 2.0) >= 0.8
    assert 0.5 < np.std(z) < 1.6


def test_two_parameters_at_once(cantilever):
    truth = {"youngs_modulus": 5.0e6, "tip_load.force[0]": 0.2}
    keys = list(truth)
    exact = fit(cantilever, synthetic(cantilever, {"youngs_modulus": 5.0e6,
                                                   "tip_load.force": [0.2, 0, 0]}), keys)
    np.testing.assert_allclose(exact.values, [5.0e6, 0.2], rtol=1e-6)
    noisy = fit(cantilever, synthetic(cantilever, {"youngs_modulus": 5.0e6,
                                                   "tip_load.force": [0.2, 0, 0]},
                                      noise=1e-4, seed=3, with_s=True), keys)
    assert np.all(np.abs(noisy.values - [5.0e6, 0.2]) < 2 * noisy.errors)


@pytest.mark.parametrize(("key", "truth"), [("K_E", 1200.0),
                                            ("tendon_actuation.force", 1.6)])
def test_tendon_scene_values_are_recovered(key, truth):
    scene = rodsim.load_scene("table3-catheter1")
    points = synthetic(scene, {key: truth}, noise=2e-4, seed=1)
    result = fit(scene, points, [key])
    assert abs(result.values[0] - truth) < 2 * result.errors[0]
    assert result.errors[0] < 0.05 * truth


def test_a_parameter_that_does_not_move_the_shape_is_refused(cantilever):
    with pytest.raises(FitError, match="does not influence the shape"):
        fit(cantilever, synthetic(cantilever, {}), ["density"])  # no gravity term


def test_fewer_points_than_parameters_is_refused(cantilever):
    points = synthetic(cantilever, {}, count=1)
    with pytest.raises(FitError, match="1 data points for 2 parameters"):
        fit(cantilever, points, ["youngs_modulus", "tip_load.mass"])


def _write(path, text: str):
    path.write_text(text)
    return path


@pytest.mark.parametrize(("text", "message"), [
    ("x,y\n0,0\n", "columns 'x,y'"),
    ("x,y,w\n0,0,0\n", "columns 'x,y,w'"),
    ("x,y,z\n0.1,nan,0\n", "not a finite number"),
    ("x,y,z\n0.1,abc,0\n", "'abc' is not a number"),
    ("x,y,z\n0.1,0\n", "2 values, expected 3"),
    ("", "is empty"),
    ("x,y,z,s\n", "a header and no points"),  # found by tests/test_fuzz.py in CI
])
def test_bad_data_files_are_refused(tmp_path, text, message):
    with pytest.raises(FitError, match=message):
        read_points(_write(tmp_path / "bad.csv", text))


def test_arc_lengths_outside_the_rod_are_refused(cantilever):
    points = synthetic(cantilever, {}, with_s=True)
    shifted = Points(points.xyz, points.s + 0.05)  # past the 0.12 m rod for some points
    with pytest.raises(FitError, match="outside the rest arc length"):
        fit(cantilever, shifted, ["youngs_modulus"])


@pytest.mark.parametrize(("xyz", "s", "message"), [
    (np.empty((0, 3)), None, "no data points"),
    (np.empty((0, 3)), np.empty(0), "no data points"),
    (np.zeros((2, 3)), np.zeros(3), "one per point"),
    (np.zeros((2, 3)), np.array([0.0, np.nan]), "one per point"),
])
def test_points_without_data_or_with_bad_arc_lengths_are_refused(cantilever, xyz, s, message):
    with pytest.raises(FitError, match=message):
        fit(cantilever, Points(xyz, s), ["youngs_modulus"])


def test_a_data_file_with_s_in_any_column_order_is_read(tmp_path):
    points = read_points(_write(tmp_path / "p.csv", "s,z,x,y\n0.01,0,0.01,0.002\n"))
    np.testing.assert_array_equal(points.xyz, [[0.01, 0.002, 0.0]])
    np.testing.assert_array_equal(points.s, [0.01])


@pytest.mark.slow  # a command-line run that draws its figure: 2-4 s of CPU
def test_fit_command_writes_the_fitted_scene_and_a_figure(tmp_path, capsys, cli):
    scene = rodsim.load_scene("table1-50g", ["nodes=20"])
    points = synthetic(scene, {"youngs_modulus": 5.0e6}, noise=5e-5, seed=2)
    data = tmp_path / "points.csv"
    np.savetxt(data, points.xyz, delimiter=",", header="x,y,z", comments="")
    output = tmp_path / "fitted.nc"
    code = cli(["fit", "table1-50g", "--set", "nodes=20", "--data", str(data),
                "--param", "youngs_modulus", "-o", str(output)])
    out = capsys.readouterr().out
    assert code == 0
    assert "fitted      rods.catheter.youngs_modulus = " in out
    assert (tmp_path / "fitted.png").exists()
    with xr.open_dataset(output) as ds:
        fitted = float(ds["rods_catheter_youngs_modulus"])  # no dots in names (CF)
        assert abs(fitted - 5.0e6) < 2 * float(ds["rods_catheter_youngs_modulus_standard_error"])
        assert ds["rods_catheter_youngs_modulus"].attrs["units"] == "Pa"
        assert ds["rods_catheter_youngs_modulus"].attrs["scene_key"] == (
            "rods.catheter.youngs_modulus")
        for name in list(ds.data_vars) + list(ds.coords):
            assert "long_name" in ds[name].attrs, name
        assert ds.attrs["kind"] == "fit"
    stored = read_dataset(output)  # the archive contract holds
    scene_json = json.loads(stored.attrs["scene_json"])
    assert scene_json["rods"]["catheter"]["youngs_modulus"] == fitted  # the fitted scene
    assert cli(["rerun", str(output)]) == 0  # the archive holds the fitted scene
    assert cli(["plot", str(output), "-o", str(tmp_path / "again")]) == 0


@pytest.mark.parametrize(("contents", "params", "message"), [
    ("x,y\n0,0\n0.1,0\n", ["youngs_modulus"], "columns"),
    ("x,y,z\n0.1,nan,0\n0.05,0,0\n", ["youngs_modulus"], "not a finite number"),
    ("x,y,z\n0.1,-0.01,0\n", ["youngs_modulus", "tip_load.mass"], "1 data points"),
    ("x,y,z\n0.1,-0.01,0\n0.05,-0.005,0\n", ["density"], "does not influence"),
    ("x,y,z\n0.1,-0.01,0\n", ["nodes"], "discretisation"),
])
def test_fit_command_bad_input_exits_2_with_one_line_and_writes_nothing(
        tmp_path, capsys, cli, contents, params, message):
    data = _write(tmp_path / "points.csv", contents)
    output = tmp_path / "out" / "fit.nc"
    output.parent.mkdir()
    argv = ["fit", "table1-50g", "--set", "nodes=12", "--data", str(data), "-o", str(output)]
    assert cli(argv + [arg for p in params for arg in ("--param", p)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert list(output.parent.iterdir()) == []


def test_a_fit_starts_from_the_scene_values_whatever_their_sign(least_squares_starts):
    """The start is the scaled scene value (−1 for a negative one, tests/test_reach.py has
    the zero case); it used to be +1 for every parameter, +0.02 m here instead of −0.02 m."""
    scene = rodsim.load_scene("table1-50g", ["nodes=10", "origin=[0.0, -0.02, 0.0]"])
    result = fit(scene, synthetic(scene, {"origin": "[0.0, -0.021, 0.0]"}, noise=1e-6),
                 ["origin[1]"])
    assert least_squares_starts[0][0] == -1.0
    assert result.values[0] == pytest.approx(-0.021, abs=1e-5)


def test_fit_reports_progress_after_each_equilibrium():
    """Issue 22: `rodsim fit` printed nothing while it ran. The callback (the CLI's progress
    printer) hears of every equilibrium with the residual so far."""
    scene = rodsim.load_scene("table1-50g", ["nodes=10"])
    truth = rodsim.solve(scene.with_overrides(["youngs_modulus=5e6"]), "static")
    heard = []
    found = rodsim.fit(scene, Points(truth.positions("catheter")[1:], None),
                       ["youngs_modulus"], progress=lambda f, status: heard.append(status))
    assert len(heard) >= 2 and all(s.startswith("fit: equilibrium ") for s in heard)
    assert "residual RMS" in heard[-1] and len(heard) <= found.evaluations


def test_a_fit_stalled_by_refused_trial_values_is_a_failure_not_a_result(monkeypatch):
    """Every trial value but the start has no equilibrium (forced here): least_squares
    shrinks its trust region to nothing and says 'xtol satisfied' at the start, 20 % from the
    modulus the data were made with. That is not a fit: it must raise, naming the refusals."""
    from rodsim.app.inverse.continuation import EquilibriumFailure, ScaledEquilibria

    scene = rodsim.load_scene("table1-50g", ["nodes=10", "youngs_modulus=4e6"])
    truth = rodsim.solve(scene.with_overrides(["youngs_modulus=5e6"]), "static")
    reached = ScaledEquilibria.reached

    def only_the_start(self, u):
        if not np.array_equal(u, self.start):
            self.failures += 1
            self.last_failure = "refused by the test"
            return False
        return reached(self, u)

    monkeypatch.setattr(ScaledEquilibria, "reached", only_the_start)
    with pytest.raises(EquilibriumFailure, match="stopped short of a minimum.*refused by the "
                       "test"):
        fit(scene, Points(truth.positions("catheter")[1:], None), ["youngs_modulus"])
