"""The paper's semi-implicit Euler in physical time (``integrator="paper"``, Eqs. 14–17 with
the physical masses; docs/dynamics.md) against independent references: the implicit
midpoint rule at a small step (its order), rodsim.modes' first frequency with the backward
Euler method's closed-form phase and amplitude per step on a linear oscillator
(atan(ωh) and 1/√(1 + (ωh)²)), and the energy it loses. The steel cantilever of
tests/test_simulate.py at N = 11."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_simulate import (
    RELEASE,
    STEEL,
    crossings,
    decay_ratio,
    first_frequency,
    modal,
    peaks,
    vibration_energy,
    wire,
)

import rodsim
from rodsim.core.schema import SceneError

PERIOD = 2.0 * math.pi / first_frequency(STEEL)


def test_first_order_against_the_midpoint_rule():
    """The tip half a period into a smooth release (the 0.1 N tip force ramped to zero over
    a period, as tests/test_simulate.py's order test) at h = T/50, T/100, T/200 against the
    midpoint rule at T/400 (itself 1.8e-7 m from its T/200 run, 0.6 % of the Euler error
    at T/200): the error halves with h (measured orders 1.04, 1.05; errors 3.1e-4,
    1.5e-4, 7.2e-5 L)."""
    program = {"tip_load.force[1]": ([0.0, PERIOD], [-0.1, 0.0])}
    options = {"output_dt": 0.5 * PERIOD, "initial": RELEASE, "program": program}
    reference = rodsim.simulate(wire(11), 0.5 * PERIOD, step=PERIOD / 400, **options)
    assert reference.success, reference.message
    errors = []
    for steps in (50, 100, 200):
        run = rodsim.simulate(wire(11), 0.5 * PERIOD, step=PERIOD / steps,
                              integrator="paper", **options)
        assert run.success, run.message
        assert run.integrator == "paper" and run.steps == steps // 2
        errors.append(float(np.linalg.norm(run.positions[-1, -1]
                                           - reference.positions[-1, -1])))
    orders = [math.log2(errors[k] / errors[k + 1]) for k in range(2)]
    assert all(0.9 < order < 1.15 for order in orders), (orders, errors)
    assert errors[0] < 5e-4 * STEEL["length"]


@pytest.fixture(scope="module")
def releases() -> dict[int, rodsim.app.simulate.Simulation]:
    """The steel rod released from 0.1 N, undamped, three periods at 50 and 100 steps a
    period, every step stored."""
    runs = {}
    for steps in (50, 100):
        h = PERIOD / steps
        runs[steps] = rodsim.simulate(wire(11), 3.0 * PERIOD, step=h, output_dt=h,
                                      initial=RELEASE, integrator="paper")
        assert runs[steps].success, runs[steps].message
    return runs


@pytest.fixture(scope="module")
def omega() -> float:
    """The discrete rod's first angular frequency (rodsim.modes) [rad/s]."""
    return 2.0 * math.pi * float(rodsim.modes(wire(11), count=1).frequencies[0])


def test_first_frequency_against_modes(releases, omega):
    """The first mode's period from the zero crossings of its coordinate is rodsim.modes'
    lengthened by the backward Euler phase error, T_h = 2πh / atan(ωh) (about
    (ωh)²/3): measured 5.19e-3 and 1.30e-3 long at 50 and 100 steps a period, within 8e-6
    of the closed form; the test asks 3e-5 of it and 0.4 (ωh)² of the modes' period, a
    tolerance that shrinks with h."""
    for steps, run in releases.items():
        h = PERIOD / steps
        zeros = crossings(run.times, modal(run))
        measured = 2.0 * (zeros[-1] - zeros[0]) / (len(zeros) - 1)
        lengthened = 2.0 * math.pi * h / math.atan(omega * h) * omega / (2.0 * math.pi)
        longer = measured * omega / (2.0 * math.pi) - 1.0
        assert abs(longer - (lengthened - 1.0)) < 3e-5, (steps, longer, lengthened - 1.0)
        assert 0.0 < longer < 0.4 * (omega * h) ** 2, (steps, longer)


def test_energy_decays_as_backward_euler_damps(releases, omega):
    """Undamped, the energy never grows and decays at the backward Euler rate: the first
    mode's amplitude falls by 1/√(1 + (ωh)²) per step (measured to 1e-8; the test asks
    1e-5), so over three periods the vibration keeps 9.4 % (50 steps a period; 9.7 % for
    the first mode alone, the release's higher modes are damped faster) and 30 % (100
    steps; 31 %). The energy balance reports the loss: it is the scheme's, not an
    integration of any damping (none is dissipated)."""
    for steps, run in releases.items():
        h = PERIOD / steps
        rest = run.potential_energy[0] - vibration_energy(run)
        energy = run.kinetic_energy + run.potential_energy - rest
        assert np.all(np.diff(energy) <= 1e-12 * energy[0])
        assert np.all(run.dissipated_energy == 0.0)
        times, values = peaks(run.times, -modal(run))
        per_step = (values[-1] / values[0]) ** (h / (times[-1] - times[0]))
        assert abs(per_step - (1.0 + (omega * h) ** 2) ** -0.5) < 1e-5
        first_mode = (1.0 + (omega * h) ** 2) ** (-3 * steps)
        assert 0.9 * first_mode < energy[-1] / energy[0] < first_mode
        assert np.allclose(run.energy_error, energy - energy[0], atol=1e-9 * energy[0])


def test_large_step_fails_with_a_message_or_damps():
    """Backward Euler is L-stable: on a linear rod no step is too long, and a step too long
    for the motion shows as Newton failing. Released from 2 N (29 % of L below its rest),
    where the midpoint rule fails below 40 steps a period, the paper's Euler runs one
    period at 16 steps a period (Newton halves some steps) and loses energy. A step of ten
    periods, still too long after four halvings, ends the run at its start with a message
    naming the failure and advising a smaller step: no state that is not finite is kept,
    and no success claimed."""
    release = {"tip_load.force": [0.0, -2.0, 0.0]}
    run = rodsim.simulate(wire(11), PERIOD, step=PERIOD / 16, output_dt=PERIOD / 16,
                          initial=release, integrator="paper")
    assert run.success, run.message
    total = run.kinetic_energy + run.potential_energy
    assert total[-1] < total[0] and np.all(np.isfinite(run.positions))
    failed = rodsim.simulate(wire(11), 10.0 * PERIOD, step=10.0 * PERIOD, initial=release,
                             integrator="paper")
    assert not failed.success
    assert "failed" in failed.message and "smaller step" in failed.message
    assert "\n" not in failed.message
    assert np.array_equal(failed.times, [0.0]) and np.all(np.isfinite(failed.positions))


@pytest.mark.parametrize("arguments, match", [
    ({"rtol": 1e-6}, "only for integrators 'ida' and 'cvode'"),
    ({"events": ["contact"]}, "the paper's Euler does not locate them"),
    ({"step": 0.0}, "step"),
])
def test_bad_input_is_one_line(arguments, match):
    """Tolerances and events are refused (fixed steps, no root finding), as a bad step is:
    one line, before any work."""
    call = {"step": 1e-3, "integrator": "paper", **arguments}
    with pytest.raises(SceneError, match=match) as error:
        rodsim.simulate(wire(11), 0.01, **call)
    assert "\n" not in str(error.value)


def test_command_line_runs_the_paper_scheme(tmp_path, monkeypatch, capsys):
    """``rodsim simulate --integrator paper``: its archive names the integrator and holds
    ten fixed steps' outputs, the energy lost never regained; a tolerance given to it is
    one line and exit 2."""
    from rodsim.app.cli.main import main
    from rodsim.io.archive import read_dataset

    monkeypatch.chdir(tmp_path)
    args = ["simulate", "table1-50g", "--set", "nodes=11", "--t-end", "0.05", "--output-dt",
            "0.01", "--step", "0.005", "--initial", "tip_load.mass=0.1", "--integrator",
            "paper"]
    assert main(args) == 0
    assert "10 of at most 0.005 s" in capsys.readouterr().out
    ds = read_dataset(tmp_path / "runs" / "table1-50g-simulate.nc")
    assert ds.attrs["integrator"] == "paper" and ds.attrs["complete"] == 1
    assert ds.sizes["time"] == 6
    total = (ds["kinetic_energy"] + ds["potential_energy"]).values
    assert np.all(np.diff(total) <= 0.0) and total[-1] < total[0]
    assert main([*args, "--atol", "1e-6", "-o", "x.nc"]) == 2
    err = capsys.readouterr().err
    assert "--atol" in err and len(err.strip().splitlines()) == 1


def test_kelvin_voigt_damping_adds_to_the_numerical_damping(releases):
    """Kelvin–Voigt damping (τ = 2ζ/ω₁, ζ = 0.01) acts as under the midpoint rule: the
    damping ratio from the first mode's logarithmic decrement, less the scheme's own
    (the undamped run's, ≈ ωh/2 = 0.031 at 100 steps a period), is ζ within 2 % (measured
    −0.7 %); the energy the damping dissipates is counted, and the balance's error (the
    scheme's loss) stays below the undamped run's."""
    h = PERIOD / 100
    zeta = 0.01
    damped = rodsim.simulate(
        wire(11, damping={"retardation_time": 2.0 * zeta / first_frequency(STEEL)}),
        3.0 * PERIOD, step=h, output_dt=h, initial=RELEASE, integrator="paper")
    assert damped.success, damped.message
    ratios = [decay_ratio(peaks(run.times, -modal(run))[1]) for run in (releases[100], damped)]
    assert abs((ratios[1] - ratios[0]) / zeta - 1.0) < 0.02, ratios
    assert damped.dissipated_energy[-1] > 0.0
    assert abs(damped.energy_error[-1]) < abs(releases[100].energy_error[-1])


def test_newton_matrix_is_the_residuals_derivative(monkeypatch):
    """The step's Newton matrix against central differences of its residual, on a bent,
    moving, undamped rod (N = 5, random velocities and body rates, a point off the
    predictor): agreement to 1e-8 of its largest entry (measured 5e-11)."""
    from rodsim.core.damping import Damping
    from rodsim.core.model import Model
    from rodsim.solvers.physical import semi_implicit_euler
    from rodsim.solvers.physical.coordinates import PhysicalCoordinates, physical_state
    from rodsim.solvers.physical.fixed_step import Motion

    scene = rodsim.load_scene(wire(5, tip_load={"force": [0.0, -0.3, 0.2], "mass": 0.0}))
    model = Model(scene)
    x = physical_state(model, model.x0)
    coordinates = PhysicalCoordinates.of(model, x)
    p, s = len(coordinates.positions), len(coordinates.quaternions)
    rng = np.random.default_rng(5)
    checked = []

    def check(evaluate, r1, w, h, length, tolerance):
        r1 = r1 + 1e-5 * rng.standard_normal(p)
        w = w + 0.5 * rng.standard_normal((s, 3))
        matrix = evaluate(r1, w, True)[1].toarray()
        z = np.concatenate([r1, w.ravel()])
        differences = np.zeros_like(matrix)
        for j in range(len(z)):
            step = np.zeros(len(z))
            step[j] = 1e-7
            plus = evaluate((z + step)[:p], (z + step)[p:].reshape(-1, 3), False)[0]
            minus = evaluate((z - step)[:p], (z - step)[p:].reshape(-1, 3), False)[0]
            differences[:, j] = (plus - minus) / 2e-7
        checked.append(np.max(np.abs(matrix - differences)) / np.max(np.abs(matrix)))
        return r1, w, 1

    monkeypatch.setattr(semi_implicit_euler, "solve_step", check)
    stepper = semi_implicit_euler.SemiImplicitEulerStep(coordinates, Damping(model), 0.4)
    stepper.step(model, Motion(x, 0.01 * rng.standard_normal(p),
                               rng.standard_normal((s, 3))), 1e-3)
    assert checked and checked[0] < 1e-8, checked
