"""Events under the implicit midpoint rule and a user's event functions
(rodsim/solvers/physical/step_events.py, rodsim/solvers/physical/events.py;
docs/dynamics.md, "Events"), against closed forms: free fall onto a plane, with and without
a linear drag, a tension programmed to zero, a tip crossing a height."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from test_events import FALL_TOML, GAP, RADIUS, G, falling_rod

import rodsim
from rodsim import ContactOnset, Event, TendonSlack
from rodsim.core.schema import SceneError

#: A drag c [N·s/m²] on the falling rod: v̇ = −g − γ v, γ = c/(ρA) ≈ 9.5 /s.
DRAG = 0.03
FREE_FALL = math.sqrt(2.0 * GAP / G)


def dragged_rod() -> dict:
    scene = falling_rod()
    scene["rods"]["rod"]["damping"] = {"drag": DRAG}
    return scene


def dragged_onset() -> float:
    """The contact time of the rod falling from rest under gravity and the drag: the root
    of y(t) = −(g/γ) t + (g/γ²)(1 − e^(−γt)) = −GAP."""
    gamma = DRAG / (1000.0 * math.pi * RADIUS**2)

    def height(t: float) -> float:
        return -(G / gamma) * t + (G / gamma**2) * (1.0 - math.exp(-gamma * t)) + GAP
    return float(brentq(height, 0.01, 0.2, xtol=1e-15, rtol=1e-15))


def test_free_fall_onto_a_plane_is_found_exactly():
    """Free fall (constant acceleration): the midpoint rule's states are exact, so the
    contact onset is at √(2h/g) to 1e-9 relative even at five steps to the contact
    (measured −2.3e-10: the softest elastic base the scene allows, 1e-9 N/m), recorded
    once, the run going on past it."""
    run = rodsim.simulate(falling_rod(), 0.06, step=0.0125, output_dt=0.0125,
                          events=[ContactOnset()])
    assert run.success, run.message
    assert [name for _, name in run.events] == ["contact onset: rod on floor"]
    assert abs(run.events[0][0] / FREE_FALL - 1.0) < 1e-9
    assert run.times[-1] == pytest.approx(0.06)


def test_the_contact_time_converges_at_second_order():
    """With a drag the motion is no polynomial: the located onset's error against the closed
    form shrinks at the midpoint rule's order 2 (measured 8.89e-5, 2.22e-5, 5.56e-6 s at
    h = 12.5, 6.25, 3.125 ms: orders 2.000 and 1.999), about (γh)² t/8 (below /5)."""
    exact = dragged_onset()
    errors = []
    for count in (4, 8, 16):
        run = rodsim.simulate(dragged_rod(), 0.06, step=0.05 / count, output_dt=0.06,
                              events=[ContactOnset(terminal=True)])
        assert run.success and len(run.events) == 1, run.message
        errors.append(run.events[0][0] - exact)
    orders = [math.log2(errors[k] / errors[k + 1]) for k in range(2)]
    assert all(1.9 < order < 2.1 for order in orders), (errors, orders)
    assert abs(errors[0]) < (9.55 * 0.0125) ** 2 * exact / 5


@pytest.mark.parametrize("scene", [falling_rod, dragged_rod])
def test_a_terminal_event_leaves_the_state_at_its_time(scene):
    """A terminal contact: the last output is at the event's time (not the step's end), its
    lowest sphere on the plane to 1e-9 m; free fall: the kinetic energy there is
    ½ m (g t)² to 1e-8; the archive holds the event as the SUNDIALS runs' do."""
    run = rodsim.simulate(scene(), 0.06, step=0.0125, output_dt=0.02,
                          events=["contact:stop"])
    assert run.success, run.message
    when, name = run.events[0]
    assert run.times[-1] == when and "stopped by the event" in run.message
    assert run.times[-2] < when < run.times[-2] + 0.02
    assert abs(run.positions[-1, :, 1].min() + GAP) < 1e-9
    if scene is falling_rod:
        mass = 1000.0 * math.pi * RADIUS**2 * 0.2
        assert run.kinetic_energy[-1] == pytest.approx(0.5 * mass * (G * when) ** 2,
                                                       rel=1e-8)
    ds = run.to_xarray()
    assert ds["events"].values.tolist() == [when]
    assert ds["event_name"].values.tolist() == [name]


def test_a_tendon_goes_slack_at_the_programmed_time():
    """tdcr-two-segment (N = 5), tension of s1a ramped 0 → 0.05 N → 0 over [0, 2.5, 5] ms
    and held: slack at 5 ms (inside a step of 0.375 ms) to 1e-9 s (measured −5e-11 s: the
    slack threshold 1e-9 N at 20 N/s), once; the run goes on to t_end."""
    key = "s1a.tendon_string.tension"
    run = rodsim.simulate("tdcr-two-segment", 0.006, step=4e-4, output_dt=0.003,
                          overrides=["nodes=5"],
                          program={key: ([0.0, 0.0025, 0.005], [0.0, 0.05, 0.0])},
                          events=[TendonSlack(tendon="s1a")])
    assert run.success, run.message
    assert [name for _, name in run.events] == ["tendon slack: s1a"]
    assert abs(run.events[0][0] - 0.005) < 1e-9
    assert run.times[-1] == pytest.approx(0.006)


def test_a_terminal_event_with_friction():
    """The frictional catheter of tests/test_simulate_friction.py (μ = 0.2, N = 11), its
    tension ramped 0.5 → 3 N over 0.1 s: a user's event, the tip rising through the middle of
    its travel, ends the run there with the tip on that height to 1e-12 m (the last step
    taken again with friction's history, as any step), and the message names the event
    (it was replaced by the non-conservative scene's note). The state there is that of the
    same run without the event ended at the event's time (its last step the same, from
    45 ms): measured 2e-14 m and 1e-13 N apart; before round 17 the trial steps and the
    last one started from the history carried to the step's end (50 ms): 1.1e-4 m and
    0.02 N apart, the event 0.2 ms early."""
    from test_simulate_friction import NODES, TENSION, _scene

    level = 0.031

    def rise(t: float, positions: np.ndarray) -> float:
        return float(positions[NODES - 1, 1] - level)
    run = rodsim.simulate(_scene(0.2), 0.1, output_dt=0.01, step=5e-3,
                          initial={TENSION: 0.5}, program={TENSION: ([0.0, 0.1], [0.5, 3.0])},
                          events=[Event(rise, direction=1, terminal=True)])
    assert run.success, run.message
    assert run.message.startswith("stopped by the event (rise)")
    assert "non-conservative" in run.message
    # the run without the event passes 0.031 m between its outputs at 40 and 50 ms
    assert [name for _, name in run.events] == ["rise"] and 0.04 < run.events[0][0] < 0.05
    assert abs(run.positions[-1, NODES - 1, 1] - level) < 1e-12
    stop = run.events[0][0]
    again = rodsim.simulate(_scene(0.2), stop, output_dt=5e-3, step=5e-3,
                            initial={TENSION: 0.5},
                            program={TENSION: ([0.0, 0.1], [0.5, 3.0])})
    assert again.success and again.times[-2] == pytest.approx(0.045)
    assert np.max(np.abs(again.positions[-1] - run.positions[-1])) < 1e-11
    assert run.friction is not None and again.friction is not None
    assert np.max(np.abs(again.friction.tension[-1] - run.friction.tension[-1])) < 1e-10


def tip_height(t: float, positions: np.ndarray) -> float:
    """The tip's height above y = −5 mm [m]."""
    return float(positions[-1, 1] + 0.005)


@pytest.mark.parametrize("integrator, options", [
    ("midpoint", {"step": 0.004}), ("ida", {"rtol": 1e-8, "atol": 1e-8}),
])
def test_a_user_event_against_free_fall(integrator, options):
    """``Event(tip_height, terminal=True)``: the tip 5 mm down at √(2 · 5 mm/g) to 1e-8
    relative (measured −1.0e-10 midpoint, −2.6e-10 IDA at 1e-8), the run ending there with
    the tip at −5 mm."""
    run = rodsim.simulate(falling_rod(), 0.06, output_dt=0.01, integrator=integrator,
                          events=[Event(tip_height, name="tip 5 mm down", terminal=True)],
                          **options)
    assert run.success, run.message
    assert [name for _, name in run.events] == ["tip 5 mm down"]
    assert abs(run.events[0][0] / math.sqrt(2.0 * 0.005 / G) - 1.0) < 1e-8
    assert abs(run.positions[-1, -1, 1] + 0.005) < 1e-9


@pytest.mark.parametrize("integrator, options, tolerance", [
    ("midpoint", {"step": 0.005}, 1e-8), ("cvode", {"rtol": 1e-8, "atol": 1e-8}, 1e-6),
])
def test_a_user_event_s_direction(integrator, options, tolerance):
    """Thrown upward at 0.5 m/s, the tip passes +5 mm up at (v₀ − √(v₀² − 2gh))/g and down
    at (v₀ + √(v₀² − 2gh))/g: direction +1 records the first, −1 the second, 0 both — to
    1e-8 relative under the midpoint rule, exact on a parabola (measured 3.1e-9: the 1e-9
    N/m elastic base over 91 ms), to 1e-6 with CVODE at 1e-8 (measured 5.7e-7 on the rising
    one, at 11 ms); the default name is the function's."""
    v0, up = 0.5, 0.005

    def above(t: float, positions: np.ndarray) -> float:
        return float(positions[-1, 1] - up)
    root = math.sqrt(v0**2 - 2.0 * G * up)
    rising, falling = (v0 - root) / G, (v0 + root) / G
    run = rodsim.simulate(falling_rod(), falling + 0.005, output_dt=0.01,
                          integrator=integrator, initial_velocity=[0.0, v0, 0.0],
                          events=[Event(above, name="up", direction=1),
                                  Event(above, name="down"), Event(above, direction=0)],
                          **options)
    assert run.success, run.message
    got = sorted(run.events, key=lambda event: (event[1], event[0]))
    assert [name for _, name in got] == ["above", "above", "down", "up"]
    for (when, _), exact in zip(got, [rising, falling, falling, rising], strict=True):
        assert abs(when / exact - 1.0) < tolerance


@pytest.mark.parametrize("integrator, options", [
    ("midpoint", {"step": 0.01}), ("ida", {"rtol": 1e-8, "atol": 1e-8}),
])
def test_a_user_event_of_the_velocities(integrator, options):
    """``Event(..., velocities=True)``: thrown up at v₀ = 0.5 m/s, the tip's vertical
    velocity reaches zero at the apex, v₀/g, to 1e-8 relative (measured 2.6e-9 midpoint at
    10 ms steps, 2.5e-9 IDA at 1e-8: the elastic base), at the height v₀²/2g to 1e-9 m."""
    v0 = 0.5

    def rising(t: float, positions: np.ndarray, velocities: np.ndarray) -> float:
        return float(velocities[-1, 1])
    run = rodsim.simulate(falling_rod(), 0.08, output_dt=0.01, integrator=integrator,
                          initial_velocity=[0.0, v0, 0.0],
                          events=[Event(rising, name="apex", velocities=True, terminal=True)],
                          **options)
    assert run.success, run.message
    assert [name for _, name in run.events] == ["apex"]
    assert abs(run.events[0][0] / (v0 / G) - 1.0) < 1e-8
    assert abs(run.positions[-1, -1, 1] - v0**2 / (2.0 * G)) < 1e-9


@pytest.mark.parametrize("make, match", [
    (lambda: Event(42), "allowed a function"),
    (lambda: Event(tip_height, direction=2), "direction = 2"),
    (lambda: Event(tip_height, name=""), "non-empty string"),
    (lambda: Event(tip_height, terminal="yes"), "terminal = 'yes'"),
    (lambda: Event(tip_height, velocities=1), "velocities = 1"),
])
def test_bad_event_values_are_one_line(make, match):
    with pytest.raises(SceneError, match=match) as caught:
        make()
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("function, match", [
    (lambda t: 0.0, "TypeError"),
    (lambda t, p: "low", "ValueError"),
    (lambda t, p: math.nan, "returned nan"),
    (lambda t, p: 1.0 / 0.0, "ZeroDivisionError"),
])
def test_a_failing_user_function_is_one_line_before_the_run(function, match):
    with pytest.raises(SceneError, match=match) as caught:
        rodsim.simulate(falling_rod(), 0.01, step=0.005, output_dt=0.005,
                        events=[Event(function, name="bad")])
    assert "\n" not in str(caught.value) and "event 'bad'" in str(caught.value)


@pytest.mark.parametrize("integrator, options", [
    ("midpoint", {"step": 0.005}), ("ida", {}),
])
def test_a_user_function_failing_part_way_ends_the_run(integrator, options):
    """A function that returns NaN after 12 ms: the run stops there, ``success`` False, the
    message says so, the outputs before it kept."""
    def late(t: float, positions: np.ndarray) -> float:
        return math.nan if t > 0.012 else 1.0
    run = rodsim.simulate(falling_rod(), 0.03, output_dt=0.005, integrator=integrator,
                          events=[Event(late)], **options)
    assert not run.success
    assert "event 'late'" in run.message and "returned nan" in run.message
    assert 0.005 <= run.times[-1] <= 0.015


def test_the_command_line_midpoint_event(tmp_path, capsys):
    """``rodsim simulate FALL --step 0.0125 --output-dt 0.02 --event contact:stop``: the event
    at √(2h/g), printed and archived."""
    from rodsim.app.cli.main import main
    from rodsim.io.archive import read_dataset

    scene = tmp_path / "fall.toml"
    scene.write_text(FALL_TOML)
    out = tmp_path / "fall.nc"
    assert main(["simulate", str(scene), "--t-end", "0.06", "--step", "0.0125",
                 "--output-dt", "0.02", "--event", "contact:stop", "-o", str(out)]) == 0
    assert "event       contact onset: rod on floor at t = 0.045152364" in \
        capsys.readouterr().out
    ds = read_dataset(out)
    assert abs(float(ds["events"].values[0]) / FREE_FALL - 1.0) < 1e-9
