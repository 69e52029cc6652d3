"""Damped modes (rodsim.modes with ``[rods.<rod>.damping]``; rodsim/core/damped_vibration.py;
docs/dynamics.md, "Damped modes") against independent references: the damping ratios of a
clamped steel rod in closed form, ζ_n = τ ω_n / 2 for Kelvin–Voigt and ζ_n = c/(2 ρA ω_n)
for a drag (ω_n the Euler–Bernoulli frequencies), the damped frequency ω_n √(1 − ζ²), the
Kelvin–Voigt overdamped roots' limit −1/τ, a dense generalised eigensolve of the whole
(λ² M + λ D + K) pencil written here, and the decay that rodsim.simulate measures."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as la
from test_simulate import STEEL, decay_ratio, first_frequency, modal, peaks, wire

import rodsim
from rodsim.app.cli.main import main
from rodsim.core.damping import Damping
from rodsim.core.inertia import mass_factor
from rodsim.core.model import Model
from rodsim.io.archive import read_dataset

#: Euler–Bernoulli clamped–free roots β_n L.
BETA = (1.87510407, 4.69409113, 7.85475744)
RHO_A = STEEL["density"] * math.pi * STEEL["radius"] ** 2


def projected_damping(model: Model, x: np.ndarray) -> np.ndarray:
    """D̂: the damping matrix at the free state ``x`` without each quaternion's norm
    direction (dense), as the pencils of these tests use it."""
    physical = x + model.reference[model.free]
    damping = Damping(model).matrix(physical).toarray()
    free_of = np.full(model.full_size, -1)
    free_of[model.free] = np.arange(model.n)
    projector = np.eye(model.n)
    for block in free_of[model.rods["wire"].layout.quaternion_index]:
        q = physical[block] / np.linalg.norm(physical[block])
        projector[np.ix_(block, block)] -= np.outer(q, q)
    return projector @ damping @ projector


def bending(n: int) -> float:
    """ω_n of the clamped–free steel rod, Euler–Bernoulli [rad/s]."""
    return first_frequency(STEEL) * (BETA[n] / BETA[0]) ** 2


def test_kelvin_voigt_damping_ratios_are_tau_omega_over_two():
    """τ with ζ₁ = 0.01: the first three bending pairs (y and z) within 1 % of τ ω_n/2 for
    the Euler–Bernoulli ω_n (measured −2.9e-4, −1.0e-3, −1.7e-3: the N = 41
    discretisation of ω_n) and within 1e-5 of τ |λ|/2 (exact for a damping proportional to
    the stiffness: measured ≤ 1.7e-6); each rings at ω_n √(1 − ζ²)."""
    tau = 2.0 * 0.01 / bending(0)
    modes = rodsim.modes(wire(41, damping={"retardation_time": tau}), count=6)
    assert modes.success and modes.message == "ok", modes.message
    for k in range(6):
        omega = bending(k // 2)
        assert abs(modes.damping_ratios[k] / (tau * omega / 2.0) - 1.0) < 0.01
        magnitude = abs(modes.damped_eigenvalues[k])
        assert abs(modes.damping_ratios[k] / (tau * magnitude / 2.0) - 1.0) < 1e-5
        undamped = 2.0 * math.pi * modes.frequencies[k]
        ringing = undamped * math.sqrt(1.0 - modes.damping_ratios[k] ** 2)
        assert 2.0 * math.pi * modes.damped_frequencies[k] == pytest.approx(ringing, rel=1e-5)
    assert modes.damping_ratios[4] > 0.17  # ζ₃ = 17.5 ζ₁: the damping grows with ω


def test_drag_damping_ratios_are_c_over_two_rho_a_omega():
    """A drag c with ζ₁ = 0.01: ζ_n = c/(2 ρA ω_n) within 1 % for the first three pairs
    (measured +2.8e-4, +9.6e-4, +1.5e-3: the N = 41 discretisation of ω_n, and the rotary
    inertia the drag does not act on)."""
    drag = 2.0 * 0.01 * RHO_A * bending(0)
    modes = rodsim.modes(wire(41, damping={"drag": drag}), count=6)
    assert modes.success, modes.message
    for k in range(6):
        expected = drag / (2.0 * RHO_A * bending(k // 2))
        assert abs(modes.damping_ratios[k] / expected - 1.0) < 0.01


def test_without_rotary_inertia_the_damped_rotations_still_damp_bending():
    """Without ρI the rotations are massless but damped (Kelvin–Voigt acts on the
    curvature): the first pair keeps ζ₁ = τ ω₁/2 within 1 % (measured −1.1e-3, N = 21)."""
    tau = 2.0 * 0.01 / bending(0)
    modes = rodsim.modes(wire(21, damping={"retardation_time": tau}), count=2,
                         rotary_inertia=False)
    assert np.all(np.abs(modes.damping_ratios / (tau * bending(0) / 2.0) - 1.0) < 0.01)


def test_overdamped_kelvin_voigt_roots_gather_at_minus_one_over_tau():
    """ζ₁ = 0.05: ζ₃ = 0.87 still rings, but the slow roots of every overdamped mode lie
    just beyond −1/τ (λ = −(τω²/2)(1 − √(1 − 4/(τω)²)) → −1/τ), before the third pair: the
    real roots found are within 1 % of −1/τ (measured −1.00000015/τ), and the message says
    they do not ring."""
    tau = 2.0 * 0.05 / bending(0)
    modes = rodsim.modes(wire(41, damping={"retardation_time": tau}), count=6)
    roots = modes.damped_eigenvalues
    real = roots[roots.imag == 0.0]
    assert len(real) >= 1 and "do not oscillate" in modes.message
    assert np.all((real.real * tau < -1.0) & (real.real * tau > -1.01))
    assert np.all(modes.damping_ratios[roots.imag == 0.0] == 1.0)
    assert np.all(modes.damped_frequencies[roots.imag == 0.0] == 0.0)


def test_against_a_dense_generalised_eigensolve_of_the_pencil():
    """A bent rod (0.2 N at the tip, N = 11) with Kelvin–Voigt and drag: the roots equal
    those of the pencil [[0, I], [−K, −D̂]] z = λ [[I, 0], [0, M]] z (D̂: D without each
    quaternion's norm direction) solved densely here, to 1e-6 (measured 2e-7: the QZ of a
    pencil that the centerline penalty makes ill-scaled)."""
    scene = wire(11, damping={"retardation_time": 5e-4, "drag": 0.3},
                 tip_load={"force": [0.0, -0.2, 0.3], "mass": 0.0})
    modes = rodsim.modes(scene, count=5)
    assert modes.success, modes.message
    result = modes.result
    model = Model(result.scene)
    x = result.state
    stiffness = -model.jacobian(x).toarray()
    factor = mass_factor(model, x).toarray()
    damping = projected_damping(model, x)
    n = model.n
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-stiffness, -damping]])
    b = np.block([[np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), factor @ factor.T]])
    values = la.eigvals(a, b)
    values = values[np.isfinite(values) & (values.imag >= 0.0)]
    values = values[np.argsort(np.abs(values))][:5]
    np.testing.assert_allclose(modes.damped_eigenvalues, values, rtol=1e-6)


@pytest.mark.slow  # ~5 s of CPU each, as test_simulate.py's decrement tests (also slow)
@pytest.mark.parametrize("kind", ["kelvin-voigt", "drag"])
def test_the_decay_rodsim_simulate_measures(kind):
    """The steel rod (N = 21) released from a 0.02 N tip force with ζ₁ = 0.01: the
    logarithmic decrement over five periods gives the damping ratio of the first damped
    root within 1 % (Kelvin–Voigt: measured +0.24 %, and +1.5 % from 0.1 N, +7.5 % from
    0.5 N, where each element's clipped geometric stiffness adds damping in proportion to
    the amplitude; drag: −0.09 %), and its period is the damped one lengthened by the
    midpoint rule's (ωh)²/12 (measured to −2.7e-6 and −3.5e-5 of the period)."""
    damping = ({"retardation_time": 2.0 * 0.01 / bending(0)} if kind == "kelvin-voigt"
               else {"drag": 2.0 * 0.01 * RHO_A * bending(0)})
    scene = wire(21, damping=damping)
    modes = rodsim.modes(scene, count=1)
    period = 2.0 * math.pi / bending(0)
    h = period / 100
    run = rodsim.simulate(scene, 5.0 * period, step=h, output_dt=h,
                          initial={"tip_load.force": [0.0, -0.02, 0.0]})
    assert run.success, run.message
    times, values = peaks(run.times, modal(run))
    measured = decay_ratio(values)
    assert abs(measured / modes.damping_ratios[0] - 1.0) < 0.01
    ringing = np.mean(np.diff(times))
    omega_h = 2.0 * math.pi * modes.frequencies[0] * h
    assert abs(ringing * modes.damped_frequencies[0] - 1.0 - omega_h**2 / 12.0) < 1e-4


def test_an_undamped_scene_has_zero_damping_ratios():
    modes = rodsim.modes(wire(11), count=3)
    np.testing.assert_array_equal(modes.damped_frequencies, modes.frequencies)
    np.testing.assert_array_equal(modes.damping_ratios, np.zeros(3))


SCENE = """
name = "damped-wire"
[rods.wire]
length = 0.4
radius = 1.2e-3
youngs_modulus = 207e9
density = 8000.0
poisson_ratio = 0.3
nodes = 21
terms = ["stretch", "bend_twist", "centerline"]
[rods.wire.damping]
retardation_time = 3e-4
drag = 0.05
"""


def test_cli_prints_and_archives_the_damped_modes(tmp_path, monkeypatch, capsys):
    """``rodsim modes`` prints, in each mode's row, the damped frequency and ratio of the
    root matched to it, and archives the roots as the Python result has them, bit for
    bit."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "damped.toml").write_text(SCENE, encoding="utf-8")
    assert main(["modes", "damped.toml", "--count", "4", "-o", "modes.nc"]) == 0
    out = capsys.readouterr().out
    assert "damped [Hz]" in out and "damping ratio" in out
    ds = read_dataset(tmp_path / "modes.nc")
    python = rodsim.modes(tmp_path / "damped.toml", count=4)
    rows = [line.split() for line in out.splitlines() if line.split()[:1] in (["1"], ["2"],
                                                                            ["3"], ["4"])]
    assert [row[-1] for row in rows] == [f"{z:.4g}" for z in python.matched_damping_ratios]
    assert [row[-2] for row in rows] == [
        f"{lam.imag / (2 * math.pi):.6g}" for lam in python.matched_eigenvalues]
    np.testing.assert_array_equal(ds["damped_frequency"].values, python.damped_frequencies)
    np.testing.assert_array_equal(ds["damping_ratio"].values, python.damping_ratios)
    np.testing.assert_array_equal(ds["damped_eigenvalue_real"].values
                                  + 1j * ds["damped_eigenvalue_imag"].values,
                                  python.damped_eigenvalues)
    # both dampings add: ζ₁ = τ ω₁/2 + c/(2 ρA ω₁)
    omega = 2.0 * math.pi * python.frequencies[0]
    expected = 3e-4 * omega / 2.0 + 0.05 / (2.0 * RHO_A * omega)
    assert python.damping_ratios[0] == pytest.approx(expected, rel=1e-3)


def user_rod(rng: np.random.Generator, kind: str) -> dict:
    """A steel or nitinol wire, or a soft polymer catheter, as a user writes one."""
    if kind == "polymer":
        return {"length": rng.uniform(0.05, 0.3), "radius": rng.uniform(0.8e-3, 3e-3),
                "youngs_modulus": rng.uniform(5e6, 60e6), "density": rng.uniform(1000, 1250),
                "poisson_ratio": 0.45}
    return {"length": rng.uniform(0.1, 0.5), "radius": rng.uniform(0.2e-3, 1e-3),
            "youngs_modulus": 200e9 if kind == "steel" else rng.uniform(40e9, 75e9),
            "density": 7900.0 if kind == "steel" else 6450.0, "poisson_ratio": 0.3}


@pytest.mark.parametrize("seed", range(6))
def test_family_of_user_robots(seed):
    """Seeded robots (steel and nitinol wires, soft polymer catheters) with both dampings
    at random: the first pair's ζ is τ ω₁/2 + c/(2 ρA ω₁) (a Rayleigh damping, one
    stiffness- and one mass-proportional part, decouples the modes) within 1e-3, ω₁ the
    robot's own undamped frequency (measured ≤ 1.0e-4, on the thick polymer catheters:
    their rotary inertia, which the drag does not act on)."""
    rng = np.random.default_rng(300 + seed)
    kind = ["steel", "nitinol", "polymer"][seed % 3]
    rod = user_rod(rng, kind)
    omega = first_frequency(rod)
    rho_a = rod["density"] * math.pi * rod["radius"] ** 2
    tau = 2.0 * rng.uniform(0.002, 0.05) / omega
    drag = 2.0 * rng.uniform(0.002, 0.05) * rho_a * omega
    modes = rodsim.modes(wire(int(rng.choice([21, 31])), rod,
                              damping={"retardation_time": tau, "drag": drag}), count=2)
    assert modes.success, modes.message
    own = 2.0 * math.pi * modes.frequencies
    expected = tau * own / 2.0 + drag / (2.0 * rho_a * own)
    assert np.all(np.abs(modes.damping_ratios / expected - 1.0) < 1e-3)
