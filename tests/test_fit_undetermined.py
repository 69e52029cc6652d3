"""A fit whose data cannot determine a value is not a success (rodsim/app/inverse/fit.py,
MAX_RELATIVE_ERROR; issue 37, item 3e: `helix_pitch = 999.9 ± 2e6 m` was reported fitted).

Independent check of the verdict: the shape itself. Where the pitch is undetermined,
halving it moves the centerline by less than the data's noise (the data cannot tell the two
apart); where it is determined, by many times the noise."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.app.inverse.fit import MAX_RELATIVE_ERROR, Points
from rodsim.io.archive import read_dataset

NOISE = 1e-4  # m
PITCH = "tendons.helix.tendon_string.helix_pitch"


def _shape(pitch: float) -> np.ndarray:
    scene = rodsim.load_scene("catheter-helical").with_values({PITCH: pitch})
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    return result.rods["catheter"].positions


def _data(pitch: float, seed: int) -> Points:
    rng = np.random.default_rng(seed)
    nodes = _shape(pitch)[::4]
    return Points(nodes + rng.normal(0.0, NOISE, nodes.shape), None)


def _moved(pitch: float) -> float:
    """RMS move of the centerline when the pitch is halved [m]."""
    return float(np.sqrt(np.mean(np.sum((_shape(pitch) - _shape(pitch / 2)) ** 2, axis=1))))


def test_a_pitch_the_shape_does_not_depend_on_is_undetermined():
    """Data from a straight routing (pitch 1000 m), fitted from there: measured 1000 ± 6.8e3
    m (seed 1), reported fitted before."""
    assert _moved(1000.0) < NOISE  # the data cannot tell 1000 m from 500 m
    start = rodsim.load_scene("catheter-helical").with_values({PITCH: 1000.0})
    fitted = rodsim.fit(start, _data(1000.0, 1), ["helix_pitch"])
    assert fitted.undetermined == [PITCH]
    assert fitted.errors[0] > MAX_RELATIVE_ERROR * abs(fitted.values[0])
    assert "the data do not determine it" in fitted.undetermined_text


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_no_fit_of_a_straight_routing_is_a_wrong_success(seed):
    """Over noise seeds the fit lands anywhere from 66 m to 1000 m (measured); each is
    either undetermined or, in the identifiable 1/pitch, within 3 σ of the truth (1e-3 /m):
    a determined answer the data support."""
    start = rodsim.load_scene("catheter-helical").with_values({PITCH: 1000.0})
    fitted = rodsim.fit(start, _data(1000.0, seed), ["helix_pitch"])
    value, error = float(fitted.values[0]), float(fitted.errors[0])
    if fitted.undetermined:
        return
    assert abs(1.0 / value - 1e-3) < 3.0 * error / value**2, (value, error)


def test_a_pitch_the_shape_depends_on_is_determined():
    assert _moved(0.32) > 30 * NOISE
    start = rodsim.load_scene("catheter-helical").with_values({PITCH: 0.3})
    fitted = rodsim.fit(start, _data(0.32, 1), ["helix_pitch"])
    assert fitted.undetermined == []
    assert abs(fitted.values[0] - 0.32) < 3 * fitted.errors[0]


def test_the_cli_exits_1_and_flags_the_archive(tmp_path, capsys, cli):
    data = tmp_path / "points.csv"
    np.savetxt(data, _data(1000.0, 1).xyz, delimiter=",", header="x,y,z", comments="")
    output = tmp_path / "fit.nc"
    code = cli(["fit", "catheter-helical", "--set", "helix_pitch=1000", "--data", str(data),
                "--param", "helix_pitch", "-o", str(output)])
    err = capsys.readouterr().err
    assert code == 1
    assert "fit undetermined: tendons.helix.tendon_string.helix_pitch = " in err
    assert read_dataset(output).attrs["undetermined"] == PITCH
