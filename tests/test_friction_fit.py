"""Estimating a tendon's friction coefficient μ from a measured pull–release series
(rodsim/app/inverse/series_fit.py; docs/tendon.md, "Friction"). The measurements are
synthesised by the model at μ = 0.2 with Gaussian noise on the tip's in-plane coordinates;
the fit starts at μ = 0.1. And reach telling a target in the backlash dead zone."""

from __future__ import annotations

import numpy as np
import pytest
from test_tendon_friction import LENGTH, TENSION, catheter

import rodsim
from rodsim.app.inverse.series_fit import fit_series
from rodsim.app.inverse.track import Track
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError

FRICTION = "tendons.a.tendon_string.friction"
CYCLE = np.r_[np.linspace(0.5, 3.0, 6), np.linspace(2.5, 0.5, 5)]  # N, up and back down


def measured(mu: float, noise: float, seed: int) -> np.ndarray:
    truth = rodsim.track(Scene.from_dict(catheter(21, mu, CYCLE[0])), {TENSION: CYCLE},
                         estimates=False)
    assert truth.success
    rng = np.random.default_rng(seed)
    return truth.tips() + noise * rng.standard_normal((len(CYCLE), 3)) * [1.0, 1.0, 0.0]


def test_noise_free_series_gives_mu_back():
    fitted = fit_series(Scene.from_dict(catheter(21, 0.1, CYCLE[0])), {TENSION: CYCLE},
                        measured(0.2, 0.0, 0), [FRICTION])
    assert fitted.values[FRICTION] == pytest.approx(0.2, abs=1e-6)
    assert fitted.rms < 1e-9 * LENGTH


@pytest.mark.parametrize("seed", range(3))
def test_noisy_series_gives_mu_within_its_standard_error(seed):
    """Noise of 0.1 mm (5e-4 L) per coordinate: μ̂ within 3 standard errors of 0.2, the
    standard error a few percent of μ, and the residual RMS the noise's (two noisy
    coordinates of three: σ √(2/3))."""
    noise = 1e-4
    fitted = fit_series(Scene.from_dict(catheter(21, 0.1, CYCLE[0])), {TENSION: CYCLE},
                        measured(0.2, noise, seed), [FRICTION])
    mu, error = fitted.values[FRICTION], fitted.standard_errors[FRICTION]
    assert abs(mu - 0.2) < 3 * error, (mu, error)
    assert 1e-3 < error < 0.03
    assert fitted.rms == pytest.approx(noise * np.sqrt(2 / 3), rel=0.5)
    assert fitted.track.success and len(fitted.track.states) == len(CYCLE)


def test_a_series_of_the_wrong_length_is_one_line():
    with pytest.raises(SceneError, match="one per ramp value") as info:
        fit_series(Scene.from_dict(catheter(11, 0.1, 0.5)), {TENSION: CYCLE},
                   np.zeros((3, 3)), [FRICTION])
    assert "\n" not in str(info.value)


def test_reach_says_when_its_target_lies_in_the_dead_zone():
    """From the cold equilibrium at 3 N (μ = 0.2; the dead zone reaches down to 2.43 N,
    docs/tendon.md), a target released to 2.75 N is reached by lowering the tension while
    the termination's tension holds: reach flags the dead zone and says so; a target pulled
    further (3.2 N) moves the termination and is not flagged, nor is a frictionless reach."""
    scene = Scene.from_dict(catheter(21, 0.2, 3.0))
    released = rodsim.track(scene, {TENSION: [3.0, 2.75]}, estimates=False).tips()[-1]
    inside = rodsim.reach(scene, released, [TENSION])
    assert inside.dead_zone and "backlash dead zone" in inside.message
    assert 2.43 < inside.values[0] < 3.0
    ends = inside.result.tension_profiles["a"][1][-1]
    assert ends == rodsim.solve(scene).tension_profiles["a"][1][-1]
    pulled = rodsim.track(scene, {TENSION: [3.0, 3.2]}, estimates=False).tips()[-1]
    beyond = rodsim.reach(scene, pulled, [TENSION])
    assert beyond.success and not beyond.dead_zone
    assert beyond.values[0] == pytest.approx(3.2, rel=1e-6)
    plain = rodsim.reach(Scene.from_dict(catheter(21, 0.0, 3.0)), pulled, [TENSION])
    assert not plain.dead_zone


def _replayed(scene: Scene, keys: list[str], path: np.ndarray) -> Track:
    """A track through the continuation's values (its friction history)."""
    track = rodsim.track(scene, {key: list(path[:, k]) for k, key in enumerate(keys)},
                         estimates=False)
    assert track.success, track.message
    return track


@pytest.mark.parametrize("kind", ["fit", "reach"])
def test_fit_and_reach_archives_hold_the_friction_state_of_their_path(kind, tmp_path, cli,
                                                                      capsys):
    """A fit of the tension to the shape released from 3 N to 2.75 N (μ = 0.2), and a reach
    of its tip, both from 3 N: the archive holds ``tension_profile`` and ``slip_state`` of
    the final state (read back), equal to a separate track's through the archived path of
    values (``*_path``: the states bit for bit, the tensions to 1e-9); a cold solve at the
    values found holds other states (every point sliding in), so the history matters and
    ``friction_history`` names the path; ``rerun`` replays it (measured: 0 m from the
    stored shape, where a cold solve is 0.29 mm and 2.9 mm away from the fit's and the
    reach's)."""
    from rodsim.app.api import rerun
    from rodsim.app.inverse.fit import Points
    from rodsim.app.inverse.path_record import path_solver
    from rodsim.io.archive import read_dataset, write_dataset

    scene = Scene.from_dict(catheter(11, 0.2, 3.0))
    truth = rodsim.track(scene, {TENSION: [3.0, 2.75]}, estimates=False)
    if kind == "fit":
        found = rodsim.fit(scene, Points(truth.positions[-1]), [TENSION])
    else:
        found = rodsim.reach(scene, truth.tips()[-1], [TENSION])
    stored = read_dataset(write_dataset(found.to_xarray(), tmp_path / f"{kind}.nc"))
    path = stored["tendons_a_tendon_string_tension_path"]
    assert path.dims == ("evaluation",) and path.attrs["scene_key"] == TENSION
    assert path.values[0] == 3.0 and path.values[-1] == found.values[0]
    assert len(path) == found.evaluations + 1
    assert "continuation" in stored.attrs["friction_history"]
    again = _replayed(scene, [TENSION], path.values[:, None])
    np.testing.assert_array_equal(stored["slip_state"].values, again.slip[-1])
    np.testing.assert_allclose(stored["tension_profile"].values, again.tension[-1],
                               rtol=1e-9)
    assert set(np.unique(stored["slip_state"].values)) != {-1}
    cold = rodsim.solve(Scene.from_dict(catheter(11, 0.2, float(found.values[0]))))
    assert np.all(cold.point_states["a"][1] == -1)
    apart = np.max(np.linalg.norm(cold.positions() - stored["position"].values, axis=1))
    assert apart > 1e-5 * LENGTH
    # rerun replays the stored path (a cold solve would be ``apart`` away).
    result, difference = rerun(stored, path_solver(stored))
    assert difference < 1e-12 * LENGTH, (difference, apart)
    np.testing.assert_array_equal(result.point_states["a"][1], stored["slip_state"].values)
    assert cli(["rerun", str(tmp_path / f"{kind}.nc"), "--tolerance", "1e-12"]) == 0
    assert "largest difference from the stored positions: 0 m" in capsys.readouterr().out
    tampered = stored.load().copy(deep=True)
    tampered["tendons_a_tendon_string_tension_path"].values[0] = -1.0
    write_dataset(tampered, tmp_path / "tampered.nc")
    assert cli(["rerun", str(tmp_path / "tampered.nc")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "out of range" in err, repr(err)


def test_a_frictionless_reach_archive_has_no_path():
    scene = Scene.from_dict(catheter(11, 0.0, 3.0))
    target = rodsim.track(scene, {TENSION: [3.0, 2.75]}, estimates=False).tips()[-1]
    ds = rodsim.reach(scene, target, [TENSION]).to_xarray()
    assert "slip_state" not in ds and "evaluation" not in ds.dims
    assert "friction_history" not in ds.attrs
