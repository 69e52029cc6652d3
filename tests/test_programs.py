"""Programs: values that vary in time (issue 33 item 2; docs/dynamics.md, "Initial state and
programs"). A sinusoidal tip force on a damped steel rod against the closed form of the
driven damped oscillator of its first Euler–Bernoulli mode (below resonance: the
quasi-static response's amplitude and phase; at resonance: the whole response from rest),
the scene file's ``[program]`` table against the same program given in Python, the
``--program KEY=sin:...`` syntax, and the refusals (one line, before any work)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from test_simulate import BETA_1, STEEL, first_frequency, modal, wire
from user_robots import KINDS, user_rod

import rodsim
from rodsim.app.cli.main import main
from rodsim.core.program import Sinusoid, Table, program_entry
from rodsim.core.schema import SceneError
from rodsim.io.archive import read_dataset

#: The steel rod's mass per length [kg/m].
RHO_A = STEEL["density"] * math.pi * STEEL["radius"] ** 2


def tip_of_shape() -> float:
    """φ₁(L) of the clamped–free mode shape cosh − cos − σ (sinh − sin), ∫₀ᴸ φ₁² ds = L."""
    b = BETA_1
    sigma = (math.cosh(b) + math.cos(b)) / (math.sinh(b) + math.sin(b))
    return math.cosh(b) - math.cos(b) - sigma * (math.sinh(b) - math.sin(b))


def driven(t: np.ndarray, omega: float, zeta: float, drive: float, load: float
           ) -> tuple[np.ndarray, float, float]:
    """x'' + 2ζω x' + ω² x = load · sin(drive t) from rest, x(0) = x'(0) = 0: the whole
    solution, the steady amplitude X and its phase lag φ (x → X sin(drive t − φ))."""
    amplitude = load / math.hypot(omega**2 - drive**2, 2.0 * zeta * omega * drive)
    lag = math.atan2(2.0 * zeta * omega * drive, omega**2 - drive**2)
    damped = omega * math.sqrt(1.0 - zeta**2)
    a = amplitude * math.sin(lag)
    b = (zeta * omega * a - amplitude * drive * math.cos(lag)) / damped
    steady = amplitude * np.sin(drive * t - lag)
    return steady + np.exp(-zeta * omega * t) * (a * np.cos(damped * t)
                                                 + b * np.sin(damped * t)), amplitude, lag


def sine_fit(t: np.ndarray, x: np.ndarray, drive: float) -> tuple[float, float]:
    """Amplitude and phase lag of the best X sin(drive t − φ) + c through (t, x)."""
    basis = np.column_stack([np.sin(drive * t), np.cos(drive * t), np.ones_like(t)])
    a, b, _ = np.linalg.lstsq(basis, x, rcond=None)[0]
    return math.hypot(a, b), math.atan2(-b, a)


def test_table_and_sinusoid_values():
    table = Table((0.0, 1.0, 1.0, 2.0), (0.0, 2.0, 5.0, 3.0))
    assert [table.value(t) for t in (-1.0, 0.25, 1.0, 1.5, 3.0)] == [0.0, 0.5, 5.0, 4.0, 3.0]
    assert table.extremes() == (0.0, 5.0)
    wave = Sinusoid(0.5, 2.0, math.pi / 6).about(1.0)
    assert wave.value(0.0) == pytest.approx(1.25, abs=1e-15)
    assert wave.value(1.0 / 12.0) == pytest.approx(1.5, abs=1e-15)  # 4π/12 + π/6 = π/2
    assert wave.extremes() == (0.5, 1.5)
    assert Sinusoid(0.5, 2.0, offset=3.0).about(1.0).offset == 3.0  # its own offset kept
    assert program_entry("k", {"amplitude": 1, "frequency": 3}) == Sinusoid(1.0, 3.0)
    assert program_entry("k", ([0, 1], [2, 3])) == Table((0.0, 1.0), (2.0, 3.0))


@pytest.mark.slow  # ~8 s of CPU
def test_below_resonance_the_response_is_the_quasi_static_one():
    """A tip force F sin(Ωt), Ω = ω₁/5, on the steel rod with Kelvin–Voigt damping
    ζ₁ = 0.2: over the second drive period the first mode's coordinate is the driven
    oscillator's steady response, amplitude (2F/ρA ω₁²) H and phase lag φ with
    H = 1/√((1 − r²)² + (2ζr)²) = 1.038, tan φ = 2ζr/(1 − r²) (φ = 0.0831 rad): measured
    +0.42 % and +0.0011 rad at N = 21, 25 steps a period of the first mode (the static answer,
    H = 1 and φ = 0, is 3.8 % and 0.083 rad away)."""
    omega = first_frequency(STEEL)
    zeta, ratio, force = 0.2, 0.2, 0.05
    drive = ratio * omega
    period = 2.0 * math.pi / omega
    h = period / 25
    run = rodsim.simulate(wire(21, damping={"retardation_time": 2.0 * zeta / omega}),
                          10.0 * period, step=h, output_dt=h,
                          program={"tip_load.force[1]": rodsim.Sinusoid(
                              force, drive / (2.0 * math.pi))})
    assert run.success, run.message
    _, amplitude, lag = driven(run.times, omega, zeta, drive, force * tip_of_shape() / RHO_A)
    # the static response of the mode: the projection of F s²(3L − s)/(6EI) on φ₁
    static = 2.0 * force / (RHO_A * omega**2)
    assert amplitude / static == pytest.approx(1.0 / math.hypot(1 - ratio**2,
                                                                2 * zeta * ratio))
    last = run.times >= run.times[-1] - 5.0 * period * (1.0 - 1e-9)  # one drive period
    measured, measured_lag = sine_fit(run.times[last], modal(run)[last], drive)
    assert abs(measured / amplitude - 1.0) < 0.01
    assert abs(measured_lag - lag) < 0.003
    assert abs(measured / static - 1.0) > 0.03 and measured_lag > 0.07  # not static


@pytest.mark.slow  # ~8 s of CPU
def test_at_resonance_the_amplitude_follows_the_single_mode_oscillator():
    """Driven at the Euler–Bernoulli ω₁ from rest with a drag of ζ₁ = 0.05: over the sixth
    period the first mode's amplitude against the single-mode oscillator's whole response
    from rest (transient included, 82 % of the steady 1/(2ζ) = 10 times the static
    response by then): ratio 1.0010 at N = 21 (1.0003 below at N = 41)."""
    omega = first_frequency(STEEL)
    zeta, force = 0.05, 0.05
    period = 2.0 * math.pi / omega
    h = period / 100
    run = rodsim.simulate(wire(21, damping={"drag": 2.0 * zeta * RHO_A * omega}),
                          6.0 * period, step=h, output_dt=h,
                          program={"tip_load.force[1]": rodsim.Sinusoid(
                              force, omega / (2.0 * math.pi))})
    assert run.success, run.message
    reference, amplitude, _ = driven(run.times, omega, zeta, omega,
                                     force * tip_of_shape() / RHO_A)
    assert amplitude == pytest.approx(force / (zeta * RHO_A * omega**2))  # 1/(2ζ) · static
    last = run.times >= run.times[-1] - period * (1.0 - 1e-9)
    peak, expected = np.max(np.abs(modal(run)[last])), np.max(np.abs(reference[last]))
    assert abs(peak / expected - 1.0) < 0.01
    assert expected > 0.75 * amplitude  # resonant build-up, not a quasi-static response


SCENE_FILE = """
name = "wire"
[rods.wire]
length = 0.4
radius = 1.2e-3
youngs_modulus = 207e9
density = 8000.0
poisson_ratio = 0.3
nodes = 11
terms = ["stretch", "bend_twist", "centerline", "tip_load"]
[rods.wire.tip_load]
mass = 0.01
[rods.wire.damping]
drag = 0.5
[program."tip_load.force[1]"]
amplitude = 0.05
frequency = 20.0
phase = 0.5
[program."wire.tip_load.mass"]
times = [0.0, 0.01, 0.02]
values = [0.01, 0.02, 0.015]
"""


def test_the_scene_files_program_is_the_python_one(tmp_path):
    """A scene file's [program] table runs exactly as the same programs given in Python;
    a program given in Python replaces the file's entry for the same value (named another
    way); ``--set`` short forms do not see the program's entries."""
    path = tmp_path / "wire.toml"
    path.write_text(SCENE_FILE, encoding="utf-8")
    scene = rodsim.load_scene(path)
    assert scene.data["program"]["tip_load.force[1]"] == {"amplitude": 0.05,
                                                         "frequency": 20.0, "phase": 0.5}
    from_file = rodsim.simulate(path, 0.02, step=1e-3, output_dt=5e-3)
    plain = {key: value for key, value in scene.data.items() if key != "program"}
    given = rodsim.simulate(plain, 0.02, step=1e-3, output_dt=5e-3, program={
        "tip_load.force[1]": rodsim.Sinusoid(0.05, 20.0, 0.5),
        "tip_load.mass": ([0.0, 0.01, 0.02], [0.01, 0.02, 0.015])})
    assert from_file.success and given.success
    np.testing.assert_array_equal(from_file.positions, given.positions)
    assert from_file.program == given.program
    assert from_file.program["rods.wire.tip_load.force[1]"].offset == 0.0  # the scene's
    replaced = rodsim.simulate(path, 0.02, step=1e-3, output_dt=5e-3,
                               program={"rods.wire.tip_load.mass": ([0.0], [0.03])})
    assert replaced.program["rods.wire.tip_load.mass"] == Table((0.0,), (0.03,))
    assert not np.array_equal(replaced.positions, from_file.positions)
    assert rodsim.load_scene(path, ["mass=0.02"]).get("mass") == 0.02
    with pytest.raises(SceneError, match="unknown key"):
        rodsim.load_scene(path, ["amplitude=1"])


@pytest.mark.parametrize("program, match", [
    ({"tip_load.mass": {"amplitude": 0.02, "frequency": 1.0}}, "reaches -0.01"),  # 0.01 ∓ 0.02
    ({"tip_load.mass": Sinusoid(0.1, 1.0, offset=2e6)}, "out of range"),
    ({"tip_load.mass": {"amplitude": 0.001, "frequency": 0.0}}, "frequency"),
    ({"tip_load.mass": {"amplitude": -0.001, "frequency": 1.0}}, "amplitude"),
    ({"tip_load.mass": {"amplitude": 0.001}}, "needs frequency"),
    ({"tip_load.mass": {"amplitude": 0.001, "frequency": 1.0, "period": 1}}, "unknown key"),
    ({"tip_load.mass": {"times": [0, 1], "values": [0.01, 0.02], "phase": 0}}, "exactly"),
    ({"tip_load.mass": {"amplitude": math.nan, "frequency": 1.0}}, "finite"),
    ({"tip_load.mass": ([0.0], [0.1]), "mass": ([0.0], [0.2])}, "named twice"),
    ({"youngs_modulus": {"amplitude": 1e9, "frequency": 1.0}}, "cannot vary"),
    ({"tip_load.mass": "sin"}, "expected"),
])
def test_bad_programs_are_one_line_before_any_work(program, match):
    scene = wire(11, tip_load={"force": [0.0, 0.0, 0.0], "mass": 0.01})
    with pytest.raises(SceneError, match=match) as error:
        rodsim.simulate(scene, 1e3, step=1e-3, program=program)
    assert "\n" not in str(error.value)


def test_a_malformed_scene_program_is_refused_on_load(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(SCENE_FILE.replace("frequency = 20.0", "frequency = -1.0"),
                    encoding="utf-8")
    with pytest.raises(SceneError, match="frequency"):
        rodsim.load_scene(path)
    path.write_text(SCENE_FILE.replace('[program."wire.tip_load.mass"]',
                                       '[program."wire.tip_load.mass".inner]'),
                    encoding="utf-8")
    with pytest.raises(SceneError, match="program"):
        rodsim.load_scene(path)


def run_cli(*args: str) -> int:
    try:
        return main(list(args))
    except SystemExit as exc:  # an argparse usage error
        return int(exc.code or 0)


def test_cli_sinusoid_and_the_scene_files_program(tmp_path, monkeypatch, capsys):
    """``--program KEY=sin:A,F,PHASE,OFFSET`` is the Python Sinusoid; the archive keeps
    every program (the scene file's too) with its offset."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "wire.toml").write_text(SCENE_FILE, encoding="utf-8")
    out = tmp_path / "run.nc"
    assert run_cli("simulate", "wire.toml", "--t-end", "0.02", "--step", "1e-3",
                   "--output-dt", "5e-3", "--program", "tip_load.mass=sin:0.005,30,0,0.02",
                   "-o", str(out)) == 0
    ds = read_dataset(out)
    programs = json.loads(ds.attrs["program_json"])
    assert programs["rods.wire.tip_load.mass"] == {"amplitude": 0.005, "frequency": 30.0,
                                                  "phase": 0.0, "offset": 0.02}
    assert programs["rods.wire.tip_load.force[1]"]["offset"] == 0.0
    python = rodsim.simulate(tmp_path / "wire.toml", 0.02, step=1e-3, output_dt=5e-3,
                             program={"tip_load.mass": Sinusoid(0.005, 30.0, 0.0, 0.02)})
    np.testing.assert_array_equal(ds["position"].values, python.positions)
    capsys.readouterr()


@pytest.mark.parametrize("program, words", [
    ("tip_load.mass=sin:0.1", "sin:AMPLITUDE,FREQUENCY"),
    ("tip_load.mass=sin:0.1,1,2,3,4", "sin:AMPLITUDE,FREQUENCY"),
    ("tip_load.mass=sin:0.1,x", "sin:AMPLITUDE,FREQUENCY"),
    ("tip_load.mass=sin:0.1,0", "frequency"),
    ("tip_load.mass=sin:0.1,2", "out of range"),  # 0.05 − 0.1 < 0
    ("tip_load.mass=cos:0.1,2", "TIME:VALUE"),
])
def test_cli_bad_sinusoids_are_one_line_and_write_nothing(tmp_path, monkeypatch, capsys,
                                                          program, words):
    monkeypatch.chdir(tmp_path)
    assert run_cli("simulate", "table1-50g", "--set", "nodes=11", "--t-end", "0.05",
                   "--program", program) == 2
    captured = capsys.readouterr()
    assert words in captured.err and len(captured.err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_cli_refuses_a_scene_files_program_out_of_range(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "wire.toml").write_text(SCENE_FILE.replace("0.015]", "-0.015]"),
                                        encoding="utf-8")
    assert run_cli("simulate", "wire.toml", "--t-end", "0.05") == 2
    captured = capsys.readouterr()
    assert "tip_load.mass" in captured.err and len(captured.err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == [tmp_path / "wire.toml"]


@pytest.mark.parametrize("seed", range(6))
def test_family_of_user_robots(seed):
    """Seeded robots (steel and nitinol wires, soft polymer catheters) shaken at the tip by a
    sinusoid of random amplitude (0.05 to 0.15 E I/L², about the scene's zero), frequency
    (0.2 to 2 times the first) and phase, with a light drag: the energy balance with the
    program's work W and the dissipation holds to 1e-5 of the largest energy exchanged over
    two periods of the first mode at 100 steps a period (measured ≤ 2.7e-6, on the steel
    wires driven near resonance; ≤ 3.6e-8 at 200 steps)."""
    rng = np.random.default_rng(500 + seed)
    kind = KINDS[seed % 3]
    rod = user_rod(rng, kind)
    omega = first_frequency(rod)
    stiffness = rod["youngs_modulus"] * math.pi * rod["radius"] ** 4 / 4.0
    force = float(rng.uniform(0.05, 0.15)) * stiffness / rod["length"] ** 2
    wave = Sinusoid(force, float(rng.uniform(0.2, 2.0)) * omega / (2.0 * math.pi),
                    float(rng.uniform(-math.pi, math.pi)))
    rho_a = rod["density"] * math.pi * rod["radius"] ** 2
    period = 2.0 * math.pi / omega
    run = rodsim.simulate(wire(11, rod, damping={"drag": 0.02 * rho_a * omega}),
                          2.0 * period, step=period / 100, output_dt=period / 10,
                          program={"tip_load.force[2]": wave})
    assert run.success, run.message
    exchanged = max(np.max(np.abs(run.work)), np.max(run.kinetic_energy))
    assert exchanged > 0.0 and np.max(np.abs(run.energy_error)) < 1e-5 * exchanged
    assert np.max(np.abs(run.positions[:, -1, 2])) > 0.0  # it moves along z


def test_gravitys_direction_cannot_vary_in_time():
    """A direction is normalised, so a program on one component would turn it through a
    path no range check sees (it could pass through zero): refused, one line."""
    scene = wire(11)
    scene["rods"]["wire"]["terms"] = ["stretch", "bend_twist", "centerline", "tip_load",
                                      "gravity"]
    with pytest.raises(SceneError, match="cannot vary") as error:
        rodsim.simulate(scene, 1e3, step=1e-3,
                        program={"gravity.direction[2]": Sinusoid(1.0, 1.0)})
    assert "\n" not in str(error.value)
    run = rodsim.simulate(scene, 2e-3, step=1e-3,  # its strength can
                          program={"gravity.gravity": ([0.0, 1e-3], [9.81, 1.0])})
    assert run.success and run.work[-1] != 0.0


def test_programs_that_break_a_rule_together_stop_the_run_keeping_its_outputs():
    """Each program is in its key's range, but together a string tendon's start passes its
    end at some time (a rule across two values, checked as each model is built): the run
    stops there, keeps the outputs before it and says why."""
    run = rodsim.simulate("tdcr-two-segment", 0.05, step=5e-4, output_dt=5e-3, program={
        "s1a.tendon_string.start": Sinusoid(0.05, 20.0, offset=0.06),
        "s1a.tendon_string.end": Sinusoid(0.05, 20.0, math.pi, offset=0.14)})
    assert not run.success and "not before the termination" in run.message
    # start = end where sin(40πt) = 0.8: t = 0.00738 s, after the output at 0.005 s
    np.testing.assert_allclose(run.times, [0.0, 0.005], rtol=0, atol=1e-15)
    assert run.positions.shape[0] == 2 and np.all(np.isfinite(run.positions))


@pytest.mark.slow  # IDA at 1e-8
def test_a_sinusoids_work_is_counted_under_ida():
    """A program of sinusoids alone has no breakpoints; IDA still integrates its work (it
    counted none before, and the balance's error was the whole energy): a tip force
    0.01 sin(πt/T) on the steel rod over one period T of its first mode, IDA at
    rtol = atol = 1e-8, the balance within 1e-3 of the work (measured 2.1e-4, BDF's own
    loss; the central difference's half-width is 1e-3 of the sinusoid's period)."""
    period = 2.0 * math.pi / first_frequency(STEEL)
    run = rodsim.simulate(wire(11), period, output_dt=period / 10, integrator="ida",
                          rtol=1e-8, atol=1e-8,
                          program={"tip_load.force[1]": Sinusoid(0.01, 0.5 / period)})
    assert run.success, run.message
    assert run.work[-1] > 0.0
    assert np.max(np.abs(run.energy_error)) < 1e-3 * run.work[-1]
