"""``rodsim fit --series`` (rodsim/app/cli/fit_series.py): a tendon's friction coefficient
from tips measured along a pull-release ramp, on the command line. The series is made by
rodsim.track at μ = 0.2 with seeded noise of 10 µm on the in-plane coordinates; the fit
starts at μ = 0.1."""

from __future__ import annotations

import json

import numpy as np
import pytest

import rodsim
from rodsim.io.archive import read_dataset

FRICTION = "tendons.s1a.tendon_string.friction"
TENSION = "tendons.s1a.tendon_string.tension"
RAMP = f"{TENSION}=0.5:3:6:0.5:5"  # up in 6 values, back down in 5
CYCLE = np.r_[np.linspace(0.5, 3.0, 6), np.linspace(2.5, 0.5, 5)]
SETTINGS = ["--set", "nodes=11"]


def _write_series(path, tips: np.ndarray, header: str = "x,y,z") -> None:
    path.write_text(header + "\n" + "\n".join(",".join(repr(float(v)) for v in tip)
                                              for tip in tips) + "\n")


@pytest.fixture(scope="module")
def measured() -> np.ndarray:
    scene = rodsim.load_scene("tdcr-two-segment", ["nodes=11", f"{FRICTION}=0.2"])
    truth = rodsim.track(scene, {TENSION: CYCLE})
    assert truth.success, truth.message
    noise = np.random.default_rng(3).standard_normal(truth.tips().shape) * [1.0, 1.0, 0.0]
    return truth.tips() + 1e-5 * noise


def test_the_friction_of_a_pull_release_series_is_fitted_within_its_error(
        tmp_path, cli, capsys, measured):
    series = tmp_path / "tips.csv"
    _write_series(series, measured)
    out = tmp_path / "fit.nc"
    code = cli(["fit", "tdcr-two-segment", *SETTINGS, "--set", f"{FRICTION}=0.1",
                "--series", str(series), "--ramp", RAMP, "--param", FRICTION,
                "-o", str(out)])
    printed = capsys.readouterr().out
    assert code == 0, printed
    archive = read_dataset(out)
    mu = json.loads(archive.attrs["fitted_values"])[FRICTION]
    error = json.loads(archive.attrs["fitted_standard_errors"])[FRICTION]
    assert abs(mu - 0.2) < 3.0 * error and error < 0.01, (mu, error)
    assert f"fitted      {FRICTION} = " in printed
    np.testing.assert_array_equal(archive["measured_tip"].values, measured)
    assert archive.attrs["kind"] == "track" and archive.sizes["step"] == len(CYCLE)


@pytest.mark.parametrize(("arguments", "header", "rows", "match"), [
    (["--ramp", RAMP], "x,y,z,s", 11, "a column s"),
    (["--ramp", RAMP], "x,y,z", 4, "one per ramp value"),
    ([], "x,y,z", 11, "--series needs the ramps"),
])
def test_bad_series_input_is_one_line_and_exit_2(tmp_path, cli, capsys, measured, arguments,
                                                 header, rows, match):
    series = tmp_path / "tips.csv"
    tips = measured[:rows]
    _write_series(series, np.c_[tips, np.zeros(rows)] if header.endswith(",s") else tips,
                  header)
    out = tmp_path / "fit.nc"
    code = cli(["fit", "tdcr-two-segment", *SETTINGS, "--series", str(series), *arguments,
                "--param", FRICTION, "-o", str(out)])
    error = capsys.readouterr().err.strip()
    assert code == 2 and match in error and "\n" not in error, error
    assert not out.exists()


def test_a_ramp_without_a_series_is_refused(tmp_path, cli, capsys):
    data = tmp_path / "points.csv"
    data.write_text("x,y,z\n0.1,0,0\n0.2,0,0\n")
    code = cli(["fit", "tdcr-two-segment", *SETTINGS, "--data", str(data), "--ramp", RAMP,
                "--param", FRICTION, "-o", str(tmp_path / "fit.nc")])
    error = capsys.readouterr().err.strip()
    assert code == 2 and "--ramp goes with --series" in error and "\n" not in error
