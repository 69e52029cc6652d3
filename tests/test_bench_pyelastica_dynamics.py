"""The ``pyelastica-dynamics`` benchmark (benchmarks/rodsim_bench/pyelastica_dynamics.py)
without PyElastica: it says how to install it and writes nothing; its two rods are the
physics it claims (PyElastica's shear stiffness is rodsim's K_P, the example's step, the
first mode's velocity field); the CPU ratio picks the cheapest rodsim run as accurate.
Timings are never asserted."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rodsim
from rodsim_bench import pyelastica_dynamics as bench


def test_skips_without_pyelastica(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("RODSIM_PYELASTICA_PATH", str(tmp_path))
    if bench.have_pyelastica():
        pytest.skip("PyElastica is installed here")
    messages = []
    assert bench.run("small", tmp_path, lambda f, s: messages.append(s)) == []
    assert messages == [bench.INSTALL_HINT]
    assert "pip install pyelastica==1.0.0" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_matched_physics_and_steps():
    example, steel = bench.EXAMPLE, bench.STEEL
    # PyElastica's default G = E/3 (Poisson 0.5) and its shear stiffness alpha_c G A.
    assert math.isclose(example.shear_modulus, 1e5 / 3.0)
    assert math.isclose(example.penalty, 27.0 / 28.0 * 1e5 / 3.0 * math.pi * 0.02**2)
    assert bench.scene(example, 11)["rods"]["rod"]["centerline"]["K_P"] == example.penalty
    # The example's own step, dt = 0.05 dl, and a Courant number round trip.
    assert math.isclose(bench.pyelastica_dt(example, 100, None), 5e-4)
    assert 0.36 < bench.EXAMPLE_COURANT < 0.37
    assert math.isclose(bench.courant(steel, 40, bench.pyelastica_dt(steel, 40, 0.9)), 0.9)
    # On the thin steel rod the element's rotation against shear sets the step.
    assert steel.fastest(40) > 4.0 * 2.0 * steel.wave_speed / (steel.length / 40)
    # Euler-Bernoulli: T = 2 pi / (1.8751^2 sqrt(EI / (rho A L^4))).
    assert math.isclose(example.period, 25.27, rel_tol=1e-3)
    assert math.isclose(steel.period, 0.09368, rel_tol=1e-3)


def test_mode_shape_is_the_clamped_free_first_mode():
    length = 0.7
    s = np.linspace(0.0, length, 2001)
    phi = bench.mode_shape(s, length)
    h = s[1] - s[0]
    assert phi[0] == pytest.approx(0.0, abs=1e-12) and phi[-1] == pytest.approx(1.0)
    assert abs(phi[1] - phi[0]) / h < 1e-2  # clamped: no slope at the base
    curvature = np.diff(phi, 2) / h**2
    assert abs(curvature[-1]) < 2e-3 * abs(curvature[0])  # free: no moment at the tip


def test_rodsim_velocity_is_the_mode_field():
    nodes = 11
    velocity = bench.rodsim_velocity(bench.EXAMPLE, nodes)
    free = 3 * (nodes - 1)
    assert len(velocity) == free + 3 * (nodes - 1)
    v = velocity[:free].reshape(nodes - 1, 3)
    assert np.all(v[:, :2] == 0.0) and np.all(velocity[free:] == 0.0)
    assert v[-1, 2] == pytest.approx(bench.EXAMPLE.end_velocity)
    x = np.linspace(0.0, 1.0, nodes)[1:]
    assert np.allclose(v[:, 2], 0.005 * bench.mode_shape(x, 1.0))


def test_example_rod_frequency_against_euler_bernoulli():
    """rodsim's rod of the example (shearable, rotary inertia) at N = 41: its first
    frequency is Euler-Bernoulli's lowered by shear and rotary inertia, (r/L)^2 small."""
    modes = rodsim.modes(bench.scene(bench.EXAMPLE, 41), count=1)
    ratio = 2.0 * math.pi * modes.frequencies[0] / bench.EXAMPLE.omega
    assert -3e-3 < ratio - 1.0 < 0.0


def test_cpu_ratio_takes_the_cheapest_as_accurate():
    ref = {"tip": [[1.0, 0.0, 0.0], [1.0, 0.0, 0.1]]}
    rodsim_rows = [
        {"integrator": "midpoint", "nodes": 11, "setting": "a", "cpu_s": 1.0,
         "tip_error_over_L": 1e-3},
        {"integrator": "midpoint", "nodes": 21, "setting": "b", "cpu_s": 3.0,
         "tip_error_over_L": 1e-5},
        {"integrator": "cvode", "nodes": 11, "setting": "c", "cpu_s": 0.5,
         "tip_error_over_L": 1e-2}]
    jobs = [{"n_elem": 10, "courant": 0.9, "dt": 1e-6, "documented": True},
            {"n_elem": 20, "courant": 0.9, "dt": 1e-6, "documented": False},
            {"n_elem": 40, "courant": 1.0, "dt": 1e-6, "documented": False}]
    off = 1e-4  # tip error / L of the first PyElastica run
    results = [{"tips": [[1.0, 0.0, 0.0], [1.0, off, 0.1]], "finite": True, "cpu_s": 30.0,
                "all_cpu_s": [30.0], "steps": 9},
               {"tips": [[1.0, 0.0, 0.0], [1.0, 0.05, 0.1]], "finite": True, "cpu_s": 5.0,
                "all_cpu_s": [5.0], "steps": 9},
               {"tips": [[1.0, 0.0, 0.0]], "finite": False, "cpu_s": 1.0,
                "all_cpu_s": [1.0], "steps": 3}]
    rows = bench.pyelastica_rows(bench.EXAMPLE, results, jobs, ref, rodsim_rows)
    assert rows[0]["tip_error_over_L"] == pytest.approx(off)
    assert rows[0]["cpu_ratio"] == pytest.approx(10.0)  # only N = 21 is as accurate
    assert rows[1]["cpu_ratio"] == pytest.approx(10.0)  # the cheapest, cvode at 0.5 s
    assert "cpu_ratio" not in rows[2] and math.isnan(rows[2]["tip_error_over_L"])
    verdict = bench.verdict(rows)
    assert verdict["documented"]["smallest_ratio"] == pytest.approx(10.0)
    assert not verdict["all"]["holds"]
