"""Events in physical time (rodsim.simulate(events=...); rodsim/solvers/physical/events.py;
docs/dynamics.md, "Events") found by SUNDIALS' root finding, against closed forms: a rod
that falls freely under gravity, translating rigidly, touches a plane at t = √(2h/g) (and,
thrown upward with v₀, at (v₀ + √(v₀² + 2gh))/g); a tendon whose tension is programmed to
reach zero goes slack at that time."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rodsim
from rodsim.core.schema import SceneError
from rodsim.solvers.physical.events import ContactOnset, TendonSlack

GAP, G, RADIUS = 0.01, 9.81, 1e-3


def falling_rod(gravity: float = G) -> dict:
    """A rod along +x held by the softest elastic base the scene allows (1e-9 N/m and
    N·m/rad: free), its node spheres GAP above a frictionless plane, under gravity −y."""
    rod = {"length": 0.2, "radius": RADIUS, "youngs_modulus": 1e9, "density": 1000.0,
           "nodes": 6, "clamp": "elastic",
           "terms": ["stretch", "bend_twist", "centerline", "gravity"],
           "gravity": {"gravity": gravity},
           "base": {"translational_stiffness": 1e-9, "rotational_stiffness": 1e-9}}
    floor = {"type": "plane", "point": [0.0, -GAP - RADIUS, 0.0], "normal": [0.0, 1.0, 0.0],
             "rods": ["rod"]}
    return {"name": "fall", "rods": {"rod": rod}, "obstacles": {"floor": floor}}


#: ``falling_rod()`` as a scene file, for the command line.
FALL_TOML = """name = "fall"
[rods.rod]
length = 0.2
radius = 1e-3
youngs_modulus = 1e9
density = 1000.0
nodes = 6
clamp = "elastic"
terms = ["stretch", "bend_twist", "centerline", "gravity"]
[rods.rod.base]
translational_stiffness = 1e-9
rotational_stiffness = 1e-9
[obstacles.floor]
type = "plane"
point = [0.0, -0.011, 0.0]
normal = [0.0, 1.0, 0.0]
rods = ["rod"]
"""


@pytest.mark.parametrize("integrator", ["ida", "cvode"])
def test_free_fall_onto_a_plane_stops_at_the_contact(integrator):
    """Terminal contact onset at rtol = atol = 1e-8: the event at √(2h/g) to 1e-6 relative
    (measured −4.6e-7 IDA, −1.7e-7 CVODE: 2e-9 m of fall, the position tolerance
    1e-8 L); the run ends there, its last output the event's state, the lowest sphere on
    the plane; the archive holds the event."""
    run = rodsim.simulate(falling_rod(), 0.1, output_dt=0.005, integrator=integrator,
                          rtol=1e-8, atol=1e-8, events=[ContactOnset(terminal=True)])
    assert run.success, run.message
    exact = math.sqrt(2.0 * GAP / G)
    assert len(run.events) == 1
    time, name = run.events[0]
    assert name == "contact onset: rod on floor"
    assert abs(time / exact - 1.0) < 1e-6
    assert run.times[-1] == time and "stopped by the event" in run.message
    assert abs(run.positions[-1, :, 1].min() + GAP) < 1e-8
    ds = run.to_xarray()
    assert ds["events"].values.tolist() == [time]
    assert ds["event_name"].values.tolist() == [name]


def test_thrown_upward_and_watched_past_the_contact():
    """Thrown upward with v₀ = 0.2 m/s (an initial velocity), a non-terminal event: onset at
    (v₀ + √(v₀² + 2gh))/g to 1e-6, recorded once, and the run goes on to t_end."""
    v0 = 0.2
    exact = (v0 + math.sqrt(v0**2 + 2.0 * G * GAP)) / G
    run = rodsim.simulate(falling_rod(), exact + 0.002, output_dt=0.005, integrator="cvode",
                          rtol=1e-8, atol=1e-8, events=["contact"],
                          initial_velocity=[0.0, v0, 0.0])
    assert run.success, run.message
    assert [name for _, name in run.events] == ["contact onset: rod on floor"]
    assert abs(run.events[0][0] / exact - 1.0) < 1e-6
    assert run.times[-1] == pytest.approx(exact + 0.002)


def test_a_tendon_goes_slack_when_its_tension_reaches_zero():
    """tdcr-two-segment (N = 5) from rest, tendon s1a's tension ramped 0 → 0.05 N → 0 over
    [0, 5 ms, 10 ms] and held at 0: slack at 10 ms to 1e-9 s (measured −1e-10 s: a tension
    below SLACK = 1e-9 N counts as slack), once; the run goes on to t_end (a tension held
    at zero is no function vanishing on an interval to SUNDIALS)."""
    key = "s1a.tendon_string.tension"
    run = rodsim.simulate("tdcr-two-segment", 0.0125, output_dt=0.0025, integrator="ida",
                          rtol=1e-3, atol=1e-3, overrides=["nodes=5"],
                          program={key: ([0.0, 0.005, 0.01], [0.0, 0.05, 0.0])},
                          events=[TendonSlack(tendon="s1a")])
    assert run.success, run.message
    assert len(run.events) == 1
    assert run.events[0][1] == "tendon slack: s1a"
    assert abs(run.events[0][0] - 0.01) < 1e-9
    assert run.times[-1] == pytest.approx(0.0125)


@pytest.mark.parametrize("options, match", [
    ({"integrator": "midpoint", "step": 1e-3, "events": ["slack"]}, "has no string tendon"),
    ({"integrator": "ida", "events": ["impact"]}, "event 'impact'"),
    ({"integrator": "ida", "events": ["slack"]}, "has no string tendon"),
    ({"integrator": "ida", "events": [ContactOnset(obstacle="wall")]}, "named 'wall'"),
])
def test_bad_events_are_one_line(options, match):
    with pytest.raises(SceneError, match=match) as caught:
        rodsim.simulate(falling_rod(), 0.01, **options)
    assert "\n" not in str(caught.value)


def test_no_event_no_archive_entries():
    run = rodsim.simulate(falling_rod(0.0), 0.005, output_dt=0.005, integrator="ida")
    assert run.events == ()
    assert run.to_xarray()["events"].size == 0
    assert np.all(np.isfinite(run.positions))


def test_the_command_line_stops_at_the_event_and_archives_it(tmp_path, capsys):
    """`rodsim simulate FALL --integrator cvode --event contact:stop`: the event printed,
    the archive validated, holding the event the Python run finds."""
    from rodsim.app.cli.main import main
    from rodsim.io.archive import read_dataset

    scene = tmp_path / "fall.toml"
    scene.write_text(FALL_TOML)
    out = tmp_path / "fall.nc"
    assert main(["simulate", str(scene), "--t-end", "0.1", "--integrator", "cvode",
                 "--rtol", "1e-8", "--atol", "1e-8", "--event", "contact:stop",
                 "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "event       contact onset: rod on floor at t = 0.0451523" in printed
    ds = read_dataset(out)
    assert abs(float(ds["events"].values[0]) / math.sqrt(2.0 * GAP / G) - 1.0) < 1e-6
    assert ds["event_name"].values.astype(str).tolist() == ["contact onset: rod on floor"]
    from rodsim.io.archive_schema import ArchiveSchemaError, check_archive

    with pytest.raises(ArchiveSchemaError, match="'events'"):
        check_archive(ds.assign(events=("event", [math.nan])))


def test_a_displacement_controlled_tendon_goes_slack_when_released():
    """tdcr-two-segment (N = 5), tendon s1a pulled in 4 mm (displacement control, E A =
    6 kN, 4.45 N at equilibrium) and let out to 0 over 10 ms: a terminal slack event (IDA,
    1e-4), where the tendon's unclipped tension (E A/ℓ*)(ℓ(x) − ℓ*(t)) at the stored state
    is zero to 1e-6 of the starting tension (measured 4.7e-8 N at 0.483 ms; 3.4e-12 N at
    1e-6). At 1e-4 this run once failed just after the root (an exact zero of the event
    function: SUNDIALS' "root found at and very near t"), now given as −5e-324."""
    from test_tendon_displacement import pulled, tension_and_lengths

    from rodsim.solvers.physical.coordinates import model_state

    scene = pulled(nodes=5)
    start = rodsim.solve(scene, "static")
    tension = tension_and_lengths(scene, start.state)[0]
    ramp = 0.01
    run = rodsim.simulate(scene, 2.0 * ramp, output_dt=ramp / 4, integrator="ida",
                          initial=start, rtol=1e-4, atol=1e-4,
                          program={"s1a.tendon_string.displacement": ([0.0, ramp],
                                                                      [0.004, 0.0])},
                          events=[TendonSlack(terminal=True)])
    assert run.success, run.message
    assert [name for _, name in run.events] == ["tendon slack: s1a"]
    when = run.events[0][0]
    assert run.times[-1] == when < ramp
    model = rodsim.build_model(scene)
    term = next(t for t in model.terms if t.name == "tendon_string_displacement")
    full = model.full(model_state(model, run.states[-1]))
    free_length = term.rest_length - 0.004 * (1.0 - when / ramp)
    assert abs(term.spring * (term.path_length(full) - free_length)) < 1e-6 * tension
