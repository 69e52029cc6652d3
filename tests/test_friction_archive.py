"""What the archives record of tendon friction (issue 34): the stick/slip state of every
routing point (``slip_state``, int8 with CF ``flag_values`` / ``flag_meanings``) and the
chord tensions (``tension_profile``), per step of a track and per output time of
``simulate``, with the history each assumed (``friction_history``).

Reference: the rigid helix of tests/test_tendon_stiction.py (turns θ_e from its closed
form). Pulled to T_max (every point sliding in, −1) and released monotonically to T, point
e slides out (+1) iff its stored tension T_max e^{−μΘ_e} exceeds its upper bound
T e^{μΘ_e}, i.e. iff T < T_max e^{−2μΘ_e}, and is stuck (0) otherwise; pulled again from
T_min after every point slid out, it slides in iff T > T_min e^{2μΘ_e} (else stuck). The
last point's edge is the backlash dead zone's (docs/tendon.md, "Friction").
"""

from __future__ import annotations

import math

import numpy as np
from test_tendon_friction import LENGTH, catheter
from test_tendon_stiction import TENSION, helix_scene, helix_turns

import rodsim
from rodsim.core.program import Table
from rodsim.core.scene import Scene

MU, NODES, T_MAX, T_MIN = 0.2, 11, 1e-3, 0.4e-3


def expected_states(values: list[float], wrap: np.ndarray) -> np.ndarray:
    """The closed form's state of every point after each value of a loop that goes up to
    T_MAX, down to T_MIN (below every point's edge) and up again (module docstring)."""
    out, top, bottom, falling = [], values[0], None, False
    for k, value in enumerate(values):
        falling = k > 0 and value < values[k - 1] or (falling and value == values[k - 1])
        if bottom is None and not falling and (k == 0 or value > values[k - 1]):
            out.append(np.full(len(wrap), -1))
            top = value
        elif falling:
            out.append(np.where(value < top * np.exp(-2 * MU * wrap), 1, 0))
            bottom = value
        else:
            out.append(np.where(value > bottom * np.exp(2 * MU * wrap), -1, 0))
    return np.array(out)


def test_a_track_archive_holds_the_slip_states_of_the_hysteresis_loop(tmp_path, cli,
                                                                     capsys):
    """A pull–release–pull loop on the rigid helix (μ = 0.2, kinetic): every point's
    archived state flips where the closed form puts its edge — the last point, the backlash
    dead zone's, tested 0.2 % either side of T_max e^{−2μΘ}; the steps whose last point
    is stuck after a move are the track's dead zone; the archive reads back with its flags;
    ``rodsim rerun`` reproduces it bit for bit (positions, tensions and states)."""
    from rodsim.app.inverse.track_rerun import rerun_track
    from rodsim.io.archive import read_dataset, write_dataset

    wrap = np.cumsum(helix_turns(NODES))
    edge = T_MAX * math.exp(-2 * MU * wrap[-1])
    assert T_MIN < edge
    values = [0.5e-3, 0.75e-3, T_MAX, 0.8e-3, 0.7e-3, 0.55e-3, edge * 1.002, edge * 0.998,
              T_MIN, 0.5e-3, 0.7e-3, 0.9e-3]
    # No value within 1e-3 of another point's edge (the rod bends by 1e-8 relative).
    for k in range(3, 9):
        assert np.all(np.abs(values[k] / (T_MAX * np.exp(-2 * MU * wrap[:-1])) - 1) > 1e-3)
    for k in range(9, 12):
        assert np.all(np.abs(values[k] / (T_MIN * np.exp(2 * MU * wrap)) - 1) > 1e-3)
    scene = Scene.from_dict(helix_scene(NODES, values[0], friction=MU))
    track = rodsim.track(scene, {TENSION: values}, estimates=False)
    assert track.success, track.message
    states = np.array(track.slip)
    expected = expected_states(values, wrap)
    np.testing.assert_array_equal(states, expected)
    assert states[6, -1] == 0 and states[7, -1] == 1  # either side of the dead zone's edge
    assert set(np.unique(states[3:9])) == {0, 1} and set(np.unique(states[9:])) == {-1, 0}
    stuck_last = [k for k in range(1, len(values)) if states[k, -1] == 0]
    assert track.dead_zone_steps == stuck_last
    path = write_dataset(track.to_xarray(), tmp_path / "loop.nc")
    stored = read_dataset(path)
    slip = stored["slip_state"]
    assert slip.dims == ("step", "chord") and slip.dtype == np.int8
    np.testing.assert_array_equal(slip.values, expected)
    assert list(slip.attrs["flag_values"]) == [-1, 0, 1]
    assert slip.attrs["flag_meanings"] == "sliding_in stuck sliding_out"
    np.testing.assert_array_equal(stored["chord_point_s"].values,
                                  np.linspace(0.0, 0.1, NODES)[:-1])
    again, difference = rerun_track(stored)
    assert difference == 0.0
    np.testing.assert_array_equal(np.array(again.slip), slip.values)
    np.testing.assert_array_equal(np.array(again.tension), stored["tension_profile"].values)
    assert cli(["rerun", str(path), "--tolerance", "0"]) == 0
    out = capsys.readouterr().out
    assert "largest difference from the stored centerlines: 0 m" in out
    assert f"stick/slip states: 0 of {expected.size} differ" in out
    tampered = stored.load().copy(deep=True)
    tampered["slip_state"].values[7, -1] = 0
    write_dataset(tampered, tmp_path / "tampered.nc")
    assert cli(["rerun", str(tmp_path / "tampered.nc")]) == 0
    assert f"stick/slip states: 1 of {expected.size} differ" in capsys.readouterr().out


def test_a_run_archive_holds_its_cold_states(tmp_path):
    """A cold run assumes the tendon pulled in from slack: every point sliding in, said in
    the archive's ``friction_history``; a frictionless run has no states."""
    from rodsim.io.archive import read_dataset, write_content
    from rodsim.io.run_dataset import run_content

    result = rodsim.solve(Scene.from_dict(helix_scene(NODES, T_MAX, friction=MU)))
    write_content(run_content(result), tmp_path / "run.nc")
    stored = read_dataset(tmp_path / "run.nc")
    np.testing.assert_array_equal(stored["slip_state"].values, np.full(NODES - 1, -1))
    assert "pulled in from slack" in stored.attrs["friction_history"]
    plain = rodsim.solve(Scene.from_dict(helix_scene(NODES, T_MAX)))
    assert "slip_state" not in run_content(plain).data_vars


def test_a_trajectory_archive_holds_the_tensions_and_states_from_its_start():
    """``simulate`` from the equilibrium at 3 N (the self-bent catheter, μ = 0.2) with the
    tension held: the run stays in that equilibrium (its friction history is the cold
    solve's), and its archive holds at every output time the cold solve's chord tensions
    and every point sliding in. Released to 2.7 N, the points near the actuator slide out and
    the rest stick (the quasi-static slip front, (T_max − T) EI/(2 μ T T_max ρ) = 0.094 m,
    lies mid-way). Before the start's history was taken at the model's offsets, it was
    computed with the free positions doubled and the held run moved (measured: 0.43 mm at
    the tip in 0.01 s)."""
    raw = catheter(NODES, 0.2, 3.0)
    raw["rods"]["backbone"]["damping"] = {"retardation_time": 6e-3}
    scene = Scene.from_dict(raw)
    cold = rodsim.solve(scene)
    held = rodsim.simulate(scene, 0.01, output_dt=0.005, step=2.5e-3,
                           initial={TENSION: 3.0})
    assert held.success, held.message
    assert np.max(np.abs(held.positions[-1] - cold.positions())) < 1e-9 * LENGTH
    ds = held.to_xarray()
    assert ds["tension_profile"].dims == ("time", "chord")
    np.testing.assert_allclose(ds["tension_profile"].values,
                               np.tile(cold.tension_profiles["a"][1], (3, 1)), rtol=1e-9)
    np.testing.assert_array_equal(ds["slip_state"].values, np.full((3, NODES - 1), -1))
    assert "t = 0" in ds.attrs["friction_history"]
    released = rodsim.simulate(scene, 0.02, output_dt=0.01, step=2.5e-3,
                               initial={TENSION: 3.0},
                               program={TENSION: Table((0.0, 0.02), (3.0, 2.7))})
    assert released.success, released.message
    last = released.to_xarray()["slip_state"].values[-1]
    front = int(np.argmin(last == 1))
    assert 0 < front < NODES - 1 and np.all(last[:front] == 1) and np.all(last[front:] == 0)
