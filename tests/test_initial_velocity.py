"""Initial velocities in physical time (rodsim.simulate(initial_velocity=...);
rodsim/app/initial_velocity.py; docs/dynamics.md, "Initial state and programs") against
independent references: a cantilever started with its first mode's velocity field moves
in that mode alone — its tip's peak is the velocity over ω and its period the mode's
(rodsim.modes; the implicit midpoint rule's phase error (ωh)²/12 on top) — and a free rod
given a uniform velocity translates rigidly, x(t) = x₀ + v t."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_simulate import STEEL, crossings, first_frequency, peaks, wire

import rodsim
from rodsim.app.initial_velocity import initial_rates
from rodsim.core.model import Model
from rodsim.core.schema import SceneError
from rodsim.solvers.physical.coordinates import PhysicalCoordinates, physical_state


def first_mode(nodes: int, tip_amplitude: float):
    """(scene, ω [rad/s], the velocity field ω A φ₁ (free-coordinate rates) whose motion
    A sin(ωt) φ₁ moves the tip by ``tip_amplitude`` × L at its peak, the tip's unit
    direction, the tip's free indices)."""
    scene = wire(nodes)
    modes = rodsim.modes(scene, count=1)
    omega = 2.0 * math.pi * float(modes.frequencies[0])
    phi = modes.vectors[0]
    model = Model(rodsim.load_scene(scene))
    free_of = np.full(model.full_size, -1)
    free_of[model.free] = np.arange(model.n)
    tip = free_of[model.rods["wire"].layout.position_index[-1]]
    amplitude = tip_amplitude * STEEL["length"] / np.linalg.norm(phi[tip])
    direction = phi[tip] / np.linalg.norm(phi[tip])
    return scene, omega, amplitude * omega * phi, direction


def tip_motion(run: rodsim.app.simulate.Simulation, direction: np.ndarray) -> np.ndarray:
    return (run.positions[:, -1] - run.positions[0, -1]) @ direction


def test_first_mode_velocity_field_midpoint():
    """Tip amplitude 1e-3 L (N = 11), h = T/100: the peak is the amplitude to 1e-6 (measured
    −2.4e-7), the half period the mode's lengthened by (ωh)²/12 = 3.29e-4 to 1e-6."""
    scene, omega, velocity, direction = first_mode(11, 1e-3)
    period = 2.0 * math.pi / omega
    h = period / 100.0
    run = rodsim.simulate(scene, 0.75 * period, step=h, output_dt=h,
                          initial_velocity=velocity)
    assert run.success, run.message
    d = tip_motion(run, direction)
    _, peak = peaks(run.times, d)
    assert abs(peak[0] / (1e-3 * STEEL["length"]) - 1.0) < 1e-6
    half = crossings(run.times[1:], d[1:])[0]
    assert abs(2.0 * half / period - 1.0 - (omega * h) ** 2 / 12.0) < 1e-6
    assert "initial velocity field" in run.initial


def test_first_mode_velocity_field_cvode_against_modes_and_euler_bernoulli():
    """CVODE at rtol = atol = 1e-9, tip amplitude 3e-3 L (N = 11): the peak within 1e-5 of
    the amplitude (measured −2.6e-6, the output sampling at T/200 and the geometry), the
    half period within 1e-4 of rodsim.modes' (measured +3.4e-5; 5.7e-6 at 1e-10) and within
    the N = 11 discretisation of Euler–Bernoulli's."""
    scene, omega, velocity, direction = first_mode(11, 3e-3)
    period = 2.0 * math.pi / omega
    run = rodsim.simulate(scene, 0.75 * period, output_dt=period / 200, integrator="cvode",
                          rtol=1e-9, atol=1e-9, initial_velocity=velocity)
    assert run.success, run.message
    d = tip_motion(run, direction)
    _, peak = peaks(run.times, d)
    assert abs(peak[0] / (3e-3 * STEEL["length"]) - 1.0) < 1e-5
    half = crossings(run.times[1:], d[1:])[0]
    assert abs(2.0 * half / period - 1.0) < 1e-4
    euler_bernoulli = 2.0 * math.pi / first_frequency(STEEL)
    discrete = omega / first_frequency(STEEL) - 1.0  # the N = 11 discretisation
    assert abs(2.0 * half / euler_bernoulli - 1.0) < abs(discrete) + 1e-4


#: A rod held by the softest elastic base the scene allows (1e-9 N/m, no moment): free.
FREE = {"length": 0.2, "radius": 1e-3, "youngs_modulus": 1e9, "density": 1000.0,
        "nodes": 6, "clamp": "elastic",
        "terms": ["stretch", "bend_twist", "centerline"],
        "base": {"translational_stiffness": 1e-9, "rotational_stiffness": 0.0}}


@pytest.mark.parametrize("velocity", [[0.3, -0.2, 0.1], [0.0, 0.0, -1.0]])
def test_free_rod_translates_rigidly(velocity):
    """No force but the softest base spring: a rod given a uniform velocity moves as
    x₀ + v t to 1e-9 m (the spring's pull, 1e-9 N/m over 5 cm, bends it by 1.4e-10 m), its
    kinetic energy ½ m |v|² to 1e-8 (the spring stores ½ k x² ≈ 1e-12 J)."""
    scene = {"name": "free", "rods": {"rod": FREE}}
    run = rodsim.simulate(scene, 0.05, step=0.005, output_dt=0.01, initial_velocity=velocity)
    assert run.success, run.message
    expected = run.positions[0][None] + run.times[:, None, None] * np.array(velocity)
    assert np.max(np.abs(run.positions - expected)) < 1e-9
    mass = FREE["density"] * math.pi * FREE["radius"] ** 2 * FREE["length"]
    assert run.kinetic_energy == pytest.approx(0.5 * mass * np.dot(velocity, velocity),
                                               rel=1e-8)
    assert "uniform initial velocity" in run.initial


def test_the_physical_velocities_and_the_rates_agree():
    """The same motion given as the n free-coordinate rates and as (v, ω): the same run."""
    scene, omega, velocity, _ = first_mode(5, 1e-3)
    model = Model(rodsim.load_scene(scene))
    x = physical_state(model, model.x0)
    coordinates = PhysicalCoordinates.of(model, x)
    v, w = initial_rates(model, coordinates, x, velocity)
    physical = np.concatenate([v, w.ravel()])
    assert len(physical) == coordinates.size < model.n
    period = 2.0 * math.pi / omega
    a = rodsim.simulate(scene, 0.1 * period, step=period / 50, initial_velocity=velocity)
    b = rodsim.simulate(scene, 0.1 * period, step=period / 50, initial_velocity=physical)
    assert np.array_equal(a.positions, b.positions)


@pytest.mark.parametrize("velocity, match", [
    ([1.0, 2.0], "2 numbers; allowed 3"),
    ([1.0, math.nan, 0.0], "finite"),
    ([[1.0, 2.0, 3.0]], "flat vector"),
    ("fast", "expected a 3-vector"),
])
def test_bad_velocity_is_one_line(velocity, match):
    with pytest.raises(SceneError, match=match) as caught:
        rodsim.simulate(wire(5), 0.01, step=1e-3, initial_velocity=velocity)
    assert "\n" not in str(caught.value)
