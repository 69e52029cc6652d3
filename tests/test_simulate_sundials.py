"""Physical time with SUNDIALS IDA (rodsim.simulate(integrator="ida"); docs/dynamics.md,
"IDA") against independent references: rodsim.modes' discrete period and the
Euler–Bernoulli clamped–free frequency, the implicit midpoint rule at a fine step (a second
integrator), the energy balance, the Kelvin–Voigt damping ratio of a modal analysis, and
IDA's own convergence as its tolerance tightens. Scenes are written as a user writes them
from docs/."""

from __future__ import annotations

import functools
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
from user_robots import KINDS, user_rod

import rodsim
import rodsim.solvers.physical.ida_run as ida_run
from rodsim.core.schema import SceneError

PERIOD = 2.0 * math.pi / first_frequency(STEEL)
LENGTH = STEEL["length"]


def ida(scene: dict, t_end: float, tolerance: float, **options: object
        ) -> rodsim.app.simulate.Simulation:
    """IDA at rtol = atol = ``tolerance``, BDF order ≤ 2 (an undamped rod)."""
    run = rodsim.simulate(scene, t_end, integrator="ida", rtol=tolerance, atol=tolerance,
                          max_order=2, **options)
    assert run.success, run.message
    return run


@functools.cache
def released_reference() -> rodsim.app.simulate.Simulation:
    """IDA at rtol = atol = 1e-8 on the steel rod (N = 11), one period after the release,
    output every PERIOD/20: the reference of the convergence tests below (one run per
    process, shared)."""
    return ida(wire(11), PERIOD, 1e-8, output_dt=PERIOD / 20, initial=RELEASE)


def test_period_against_modes_and_euler_bernoulli():
    """The steel rod released from a 0.1 N tip force (N = 31, three periods, rtol 1e-5):
    the first mode's period within 1e-4 of rodsim.modes' discrete period (measured 2.2e-5;
    1.7e-6 at 1e-6) and within 1e-3 of Euler–Bernoulli's (measured 5.4e-4, of which 5.1e-4
    is the N = 31 discretisation); unit quaternions (outputs projected on |q| = 1)."""
    run = ida(wire(31), 3.0 * PERIOD, 1e-5, output_dt=PERIOD / 100, initial=RELEASE)
    zeros = crossings(run.times, modal(run))
    measured = 2.0 * (zeros[-1] - zeros[0]) / (len(zeros) - 1)
    modes = rodsim.modes(wire(31), count=1)
    assert abs(measured * modes.frequencies[0] - 1.0) < 1e-4
    assert abs(measured / PERIOD - 1.0) < 1e-3
    assert np.max(np.abs(np.linalg.norm(run.quaternions, axis=2) - 1.0)) < 1e-14


@pytest.mark.slow
def test_converges_with_rtol_and_agrees_with_the_midpoint_rule():
    """N = 11, one period after the release, the tip at every output time. IDA at
    rtol = atol = 1e-4, 1e-5, 1e-6 against IDA at 1e-8 (whose own error, against 1e-9, is
    2.5e-7 L: 4 % of the smallest error below).

    The error falls with the tolerance at the rate IDA's error control gives: it bounds
    each step's local error, which at BDF order q makes the global error proportional to
    tol^(q/(q+1)) — tol^(1/2) at order 1, tol^(2/3) at order 2 (the cap here), 4.6 a
    decade. Measured 4.1e-4, 2.4e-5, 6.3e-6 L: an exponent of 0.91 over the two decades
    (asserted ≥ 1/2, order 1's), 1.24 and 0.57 in each (asserted ≥ 0.3: an adaptive step
    sequence is not smooth in the tolerance — the decade 3e-6 → 1e-6 measured 0.22 — so no
    single decade is held to 1/2); at 1e-6 the error is 6.3 tol (asserted < 10 tol). An
    earlier run (at 9075df9, outside this history) measured 1.6e-3, 1.9e-5, 3.1e-6 L; a test
    asking a factor 10 then 5 a decade, more than order 2 gives, failed at 4.1e-4, 2.4e-5,
    6.3e-6.

    The energy balance's error falls with it (BDF's numerical damping: measured 3.1e-2,
    7.5e-4, 6.9e-5 of the vibration's energy). IDA at 1e-6 and the midpoint rule at 1600
    steps a period (whose error falls slowly: a sudden release excites modes its step does
    not resolve) agree within 1.5e-5 L (measured 7.6e-6 L; 1.0e-5 L in the earlier
    run)."""
    options = {"output_dt": PERIOD / 20, "initial": RELEASE}
    reference = released_reference()
    errors, balance = [], []
    for tolerance in (1e-4, 1e-5, 1e-6):
        run = ida(wire(11), PERIOD, tolerance, **options)
        assert np.array_equal(run.times, reference.times)
        errors.append(float(np.max(np.abs(run.positions[:, -1] - reference.positions[:, -1])))
                      / LENGTH)
        assert np.all(run.dissipated_energy == 0.0) and np.all(run.work == 0.0)
        balance.append(float(np.max(np.abs(run.energy_error))) / vibration_energy(run))
    exponents = np.log10(np.array(errors[:-1]) / np.array(errors[1:]))  # per decade
    assert np.log10(errors[0] / errors[2]) / 2.0 >= 0.5, errors  # at least order 1's
    assert np.all(exponents >= 0.3), (exponents, errors)
    assert errors[1] < 5e-5 and errors[2] < 1e-5, errors
    assert balance[0] > 10.0 * balance[1] > 50.0 * balance[2], balance
    assert balance[1] < 1e-3, balance
    midpoint = rodsim.simulate(wire(11), PERIOD, step=PERIOD / 1600, **options)
    difference = np.max(np.abs(run.positions[:, -1] - midpoint.positions[:, -1])) / LENGTH
    assert difference < 1.5e-5, difference


def test_kelvin_voigt_damping_ratio():
    """ζ = 0.01 from Kelvin–Voigt (τ = 2ζ/ω₁), measured from the decay of the first
    mode's peaks over five periods, within 2 %; the dissipated energy closes the balance
    to IDA's error."""
    omega = first_frequency(STEEL)
    zeta = 0.01
    scene = wire(21, damping={"retardation_time": 2.0 * zeta / omega})
    run = rodsim.simulate(scene, 5.0 * PERIOD, integrator="ida", rtol=1e-6, atol=1e-6,
                          output_dt=PERIOD / 100, initial=RELEASE)
    assert run.success, run.message
    _, values = peaks(run.times, modal(run))
    measured = decay_ratio(values)
    assert abs(measured / zeta - 1.0) < 0.02
    energy = vibration_energy(run)
    assert run.dissipated_energy[-1] > 0.4 * energy
    # the dissipation is a quadrature on IDA's interpolant: measured 2.8e-3 of the energy
    # at rtol 1e-6, 5.5e-4 at 1e-7
    assert np.max(np.abs(run.energy_error)) < 5e-3 * energy


@pytest.mark.slow
def test_program_with_a_step_and_a_ramp():
    """A tip force stepped at t = 0.2 T and ramped back over 0.3 T (a jump and two
    kinks, where IDA stops and restarts): the programs' work enters the balance, and the
    tip agrees with the midpoint rule at 800 steps a period (measured 1.2e-5 L; the
    balance's error 8.3e-5 of the largest kinetic energy). Slow: after the jump IDA takes
    ~4 700 steps at 1e-6 (7.7 s of CPU, the midpoint rule 1.9 s)."""
    program = {"tip_load.force[1]": ([0.0, 0.2 * PERIOD, 0.2 * PERIOD, 0.5 * PERIOD],
                                     [0.0, 0.0, -0.1, 0.0])}
    options = {"output_dt": PERIOD / 20, "program": program}
    run = ida(wire(11), 0.6 * PERIOD, 1e-6, **options)  # past the ramp's end
    reference = rodsim.simulate(wire(11), 0.6 * PERIOD, step=PERIOD / 800, **options)
    assert run.work[-1] != 0.0
    scale = np.max(np.abs(run.kinetic_energy))
    assert np.max(np.abs(run.energy_error)) < 1e-3 * scale
    difference = np.max(np.abs(run.positions[:, -1] - reference.positions[:, -1]))
    assert difference < 2e-5 * LENGTH


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(len(KINDS)))
def test_family_of_user_robots_agree_with_the_midpoint_rule(seed):
    """Seeded robots as a user writes them (one of each kind: a steel and a nitinol wire, a
    soft polymer catheter; N = 7 or 11; seed 3, a steel wire again, ran the same code),
    released from 0.08–0.15 E I/L²: IDA at rtol 1e-6 and the
    midpoint rule at 400 steps a period agree within 5e-3 of the release's deflection over
    one period (measured 1.3e-3 to 3.1e-3: the midpoint rule's own error at that step, which
    a sudden release's unresolved modes make first order — on the steel rod above 5.4e-5 L,
    3.4e-3 of the deflection, against IDA at 1e-8). Slow: ~5–6 s of CPU a robot, most of it
    IDA's 4 000–11 000 steps after the sudden release (test_string_tendon_tension_step
    below keeps IDA against the midpoint rule in the README's command)."""
    rng = np.random.default_rng(200 + seed)
    kind = KINDS[seed % 3]
    rod = user_rod(rng, kind)
    stiffness = rod["youngs_modulus"] * math.pi * rod["radius"] ** 4 / 4.0
    force = float(rng.uniform(0.08, 0.15)) * stiffness / rod["length"] ** 2
    period = 2.0 * math.pi / first_frequency(rod)
    scene = wire(int(rng.choice([7, 11])), rod)
    options = {"output_dt": period / 10, "initial": {"tip_load.force": [0.0, -force, 0.0]}}
    run = ida(scene, period, 1e-6, **options)
    reference = rodsim.simulate(scene, period, step=period / 400, **options)
    deflection = abs(reference.positions[0, -1, 1])
    difference = np.max(np.abs(run.positions[:, -1] - reference.positions[:, -1]))
    assert difference < 5e-3 * deflection, (kind, difference / deflection)
    assert np.max(np.abs(np.linalg.norm(run.quaternions, axis=2) - 1.0)) < 1e-14


def test_string_tendon_tension_step():
    """tdcr-two-segment (string tendons, N = 21): from its equilibrium at 3 N, tendon
    s1a's tension steps to 3.5 N, ramped over a tenth of the first mode's period (a sudden
    step makes IDA resolve the segments' rotation against the shear penalty, docs); IDA
    and the midpoint rule at 400 steps a period agree on the tip over 0.3 periods within
    2e-3 of the tip's travel (measured 4.4e-4), and IDA's balance holds to 1e-6 of the
    tension's work (measured 4.8e-8)."""
    overrides = ["nodes=21"]
    modes = rodsim.modes(rodsim.load_scene("tdcr-two-segment", overrides), count=1)
    period = 1.0 / modes.frequencies[0]
    key = "s1a.tendon_string.tension"
    options = {"output_dt": period / 20, "overrides": overrides, "initial": {key: 3.0},
               "program": {key: ([0.0, 0.1 * period], [3.0, 3.5])}}
    run = rodsim.simulate("tdcr-two-segment", 0.3 * period, integrator="ida", **options)
    assert run.success, run.message
    reference = rodsim.simulate("tdcr-two-segment", 0.3 * period, step=period / 400,
                                **options)
    travel = np.max(np.linalg.norm(reference.positions[:, -1] - reference.positions[0, -1],
                                   axis=1))
    assert travel > 0.01
    difference = np.max(np.abs(run.positions[:, -1] - reference.positions[:, -1]))
    assert difference < 2e-3 * travel, difference / travel
    assert run.work[-1] > 0.0
    assert np.max(np.abs(run.energy_error)) < 1e-6 * run.work[-1]


@pytest.mark.slow
def test_cvode_agrees_with_ida():
    """CVODE on the explicit form (quaternions projected, dense Jacobian), N = 11, one
    period after the release: at rtol = atol = 1e-5 and 1e-6 the tip within 1e-4 and 2e-5 L
    of IDA at 1e-8 (measured 3.8e-5, 6.8e-6 L; IDA at the same tolerances 1.9e-5,
    3.1e-6 L), the balance's error falling with rtol (1.6e-3, 1.4e-4 of the vibration's
    energy), the outputs' quaternions unit."""
    options = {"output_dt": PERIOD / 20, "initial": RELEASE}
    reference = released_reference()
    errors, balance = [], []
    for tolerance in (1e-5, 1e-6):
        run = rodsim.simulate(wire(11), PERIOD, integrator="cvode", rtol=tolerance,
                              atol=tolerance, **options)
        assert run.success, run.message
        errors.append(float(np.max(np.abs(run.positions[:, -1] - reference.positions[:, -1])))
                      / LENGTH)
        balance.append(float(np.max(np.abs(run.energy_error))) / vibration_energy(run))
        assert np.max(np.abs(np.linalg.norm(run.quaternions, axis=2) - 1.0)) < 1e-14
    assert errors[0] < 1e-4 and errors[1] < 2e-5 and errors[1] < errors[0] / 3.0, errors
    assert balance[0] < 5e-3 and balance[1] < balance[0] / 5.0, balance


def test_same_answer_on_every_run():
    """Two runs give the same arrays bit for bit (no clock-dependent choice)."""
    runs = [ida(wire(7), 0.5 * PERIOD, 1e-5, output_dt=PERIOD / 10, initial=RELEASE)
            for _ in range(2)]
    for name in ("times", "positions", "quaternions", "kinetic_energy", "potential_energy"):
        assert np.array_equal(getattr(runs[0], name), getattr(runs[1], name)), name
    assert runs[0].steps == runs[1].steps


def test_a_run_that_fails_part_way_keeps_what_it_computed(monkeypatch):
    """A run stopped by IDA's step budget returns its outputs up to the failure, marked
    incomplete, with the failure's time and advice."""
    monkeypatch.setattr(ida_run, "MAX_STEPS", 100)
    run = rodsim.simulate(wire(11), PERIOD, integrator="ida", output_dt=PERIOD / 100,
                          initial=RELEASE)
    assert not run.success
    assert "failed at t = " in run.message and "try" in run.message
    assert 1 < len(run.times) < 101
    assert len(run.positions) == len(run.times) == len(run.kinetic_energy)
    assert np.all(np.isfinite(run.positions))


@pytest.mark.parametrize("arguments, match", [
    ({"integrator": "rk4"}, "integrator"),
    ({"integrator": "cvode", "max_order": 0}, "max_order"),
    ({"integrator": "ida", "rtol": 0.0}, "rtol"),
    ({"integrator": "ida", "rtol": 0.5}, "rtol"),
    ({"integrator": "ida", "atol": -1e-6}, "atol"),
    ({"integrator": "ida", "atol": "1e-6"}, "atol"),
    ({"integrator": "ida", "max_order": 6}, "max_order"),
    ({"integrator": "ida", "max_order": 2.0}, "max_order"),
    ({"max_order": 2}, "only for integrators 'ida' and 'cvode'"),
    ({"atol": 1e-6}, "give rtol too"),
])
def test_bad_input_is_one_line(arguments, match):
    """Bad input raises SceneError with one line, before any work (the midpoint rule takes
    rtol: its error control, tests/test_midpoint_error_control.py)."""
    with pytest.raises(SceneError, match=match) as error:
        rodsim.simulate(wire(11), 0.1, **arguments)
    assert "\n" not in str(error.value)
