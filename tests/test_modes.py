"""Natural frequencies and mode shapes (rodsim.modes; docs/dynamics.md) against independent
references: the Euler–Bernoulli closed form, a clamped–free beam with a tip mass (its
characteristic equation), Timoshenko's beam with rotary inertia, shear and tension
(tests/beam_reference.py, a transfer-matrix solve of our own), the torsion and axial
closed forms, and a dense generalised eigensolve of the whole pencil (K, M)."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
import scipy.linalg as la
from beam_reference import clamped_free_frequencies, spans_frequencies
from scipy.optimize import brentq
from user_robots import KINDS, user_rod

import rodsim
from rodsim.core.inertia import (
    angular_velocity,
    mass_factor,
    quaternion_mass,
    segment_mass,
)
from rodsim.core.model import Model
from rodsim.core.rod.quaternion import directors, from_rotation_matrix
from rodsim.core.vibration import ModesError

#: Euler–Bernoulli clamped–free roots β_n L.
BETA_L = np.array([1.87510407, 4.69409113, 7.85475744])

STEEL = {"length": 0.4, "radius": 1.2e-3, "youngs_modulus": 207e9, "density": 8000.0,
         "poisson_ratio": 0.3}


def wire(nodes: int, **values: object) -> dict:
    """A straight clamped rod along +x, as a user writes it from docs/scenes.md."""
    rod = {**STEEL, "nodes": nodes, **values}
    return {"name": "wire", "rods": {"wire": rod}}


def section(rod: dict) -> tuple[float, float, float, float]:
    """(L, E I, ρ A, ρ I) of a uniform solid rod table."""
    r = rod["radius"]
    area, second = math.pi * r**2, math.pi * r**4 / 4.0
    return rod["length"], rod["youngs_modulus"] * second, rod["density"] * area, \
        rod["density"] * second


def bending(modes: rodsim.app.modes.Modes, count: int = 3) -> np.ndarray:
    """The first ``count`` bending frequencies of a straight rod along x: the modes that move
    the nodes across the axis, one of each degenerate pair (y and z)."""
    across = np.sum(modes.shapes[:, :, 1:] ** 2, axis=(1, 2))
    along = np.sum(modes.shapes[:, :, 0] ** 2, axis=1)
    chosen = modes.frequencies[(across > 100.0 * along) & (modes.rotational_share < 0.5)]
    return chosen[::2][:count]  # each bending frequency twice (y and z)


def order(errors: list[np.ndarray]) -> np.ndarray:
    """Observed order of each mode's error at N − 1 = 20, 40, 80 (least-squares slope)."""
    h = np.log([20.0, 40.0, 80.0])
    return -np.polyfit(h, np.log(np.abs(np.array(errors))), 1)[0]


# ----------------------------------------------------------------------- the mass model


def test_angular_velocity_of_a_known_rotation():
    """ω from q̇ (Eq. 13 inverted) is the body-frame rate of R(t) = R₀ exp(t [w]×)."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        start = la.qr(rng.standard_normal((3, 3)))[0]
        start *= np.sign(np.linalg.det(start))
        rate = rng.standard_normal(3)

        def q_at(t: float, start: np.ndarray = start, rate: np.ndarray = rate) -> np.ndarray:
            return from_rotation_matrix(start @ la.expm(t * np.cross(np.eye(3), rate)))

        h = 1e-6
        q0, plus, minus = q_at(0.0), q_at(h), q_at(-h)
        plus, minus = plus * np.sign(plus @ q0), minus * np.sign(minus @ q0)
        assert np.allclose(directors(q0).T, start)
        np.testing.assert_allclose(angular_velocity(q0, (plus - minus) / (2 * h)), rate,
                                   rtol=1e-8, atol=1e-8)


def test_rotary_mass_block_is_rank_three_with_the_norm_massless():
    rng = np.random.default_rng(4)
    q = rng.standard_normal((6, 4))
    inertia = rng.uniform(0.5, 2.0, (6, 3))
    blocks = quaternion_mass(q, inertia)
    for block, quaternion, moments in zip(blocks, q, inertia, strict=True):
        values = np.linalg.eigvalsh(block)
        norm2 = quaternion @ quaternion
        assert abs(values[0]) < 1e-12 * values[-1]
        np.testing.assert_allclose(block @ quaternion, 0.0, atol=1e-12)
        # the nonzero eigenvalues are 4 I_k / |q|², one per body axis
        np.testing.assert_allclose(values[1:], np.sort(4.0 * moments / norm2), rtol=1e-12)


def test_translational_mass_is_the_consistent_mass_of_the_sections():
    """Each segment's (1/3, 1/6, 1/3) share; with sections, summing a row gives the lumped
    node mass (the consistent share ∫ ρA N_i ds of rodsim/core/rod/sections.py) and the
    whole matrix the rod's mass ∫ ρA ds."""
    scene = rodsim.load_scene("catheter-pull-ring")
    model = Model(scene)
    for rod in model.rods.values():
        blocks = segment_mass(rod)
        rows = np.zeros(rod.nodes)
        rows[:-1] += blocks[:, 0] + blocks[:, 1]
        rows[1:] += blocks[:, 1] + blocks[:, 2]
        np.testing.assert_allclose(rows, rod.node_masses(), rtol=1e-12)
        profile = rod.profile
        assert profile is not None and not profile.uniform
        total = float(np.sum(profile.density * profile.area * (profile.end - profile.start)))
        assert blocks.sum() + blocks[:, 1].sum() == pytest.approx(total, rel=1e-12)


def test_mass_matrix_of_a_rigid_motion():
    """½ ẋᵀ M ẋ of a rigid translation at velocity v is ½ m v², and of a spin about the
    straight rod's axis at rate Ω it is ½ ρ J L Ω² (the rod free at its base: clamp free
    would leave nothing to hold it, so the factor is built on the full coordinates)."""
    scene = rodsim.load_scene(wire(21))
    model = Model(scene)
    x = model.x0
    factor = mass_factor(model, x)
    m = factor @ factor.T
    rod = model.rods["wire"]
    velocity = np.zeros(model.full_size)
    velocity[rod.layout.position_index] = [0.0, 2.0, -1.0]
    free = velocity[model.free]
    mass = rod.density * rod.area * rod.length
    held = 2.0 * rod.density * rod.area * rod.geometry.segment_length / 3.0  # node 0 fixed
    assert free @ (m @ free) == pytest.approx((mass - held) * 5.0, rel=1e-12)
    # spin about x: q(t) = rotation about d3 = x at rate Ω; q̇ = ½ q ⊗ (0, Ω e3) in the body
    omega = 3.0
    spin = np.zeros(model.full_size)
    q = model.full(x)[rod.layout.quaternion_index]
    for j, quaternion in enumerate(q):
        after = from_rotation_matrix(directors(quaternion).T @ la.expm(
            1e-7 * omega * np.cross(np.eye(3), [0.0, 0.0, 1.0])))
        after *= np.sign(after @ quaternion)
        spin[rod.layout.quaternion_index[j]] = (after - quaternion) / 1e-7
    free = spin[model.free]
    expected = rod.density * rod.polar_moment * rod.length * omega**2
    assert free @ (m @ free) == pytest.approx(expected, rel=1e-6)


# --------------------------------------------------------------- clamped–free references


def test_steel_rod_against_euler_bernoulli():
    """Rotary inertia off: the first three bending frequencies within 1e-3 of
    β_n² √(EI/(ρ A L⁴)) at N = 81, converging at order ≥ 1.8 over N = 21, 41, 81."""
    length, stiffness, line_mass, _ = section(wire(3)["rods"]["wire"])
    exact = BETA_L**2 * math.sqrt(stiffness / (line_mass * length**4)) / (2 * math.pi)
    errors = []
    for nodes in (21, 41, 81):
        modes = rodsim.modes(wire(nodes), count=6, rotary_inertia=False)
        assert modes.success, modes.message
        errors.append(bending(modes) / exact - 1.0)
    assert np.all(np.abs(errors[-1]) < 1e-3), errors[-1]
    assert np.all(order(errors) >= 1.8), order(errors)


def test_steel_rod_with_rotary_inertia_against_rayleigh():
    """Rotary inertia on: against the Rayleigh beam (EB with ρI), our transfer-matrix
    reference; the same bounds."""
    rod = wire(3)["rods"]["wire"]
    length, stiffness, line_mass, rotary = section(rod)
    exact = clamped_free_frequencies(3, length=length, EI=stiffness, rhoA=line_mass,
                                     rhoI=rotary, shear=100.0 * rod["youngs_modulus"]
                                     * math.pi * rod["radius"] ** 2)
    errors = [bending(rodsim.modes(wire(nodes), count=6)) / exact - 1.0
              for nodes in (21, 41, 81)]
    assert np.all(np.abs(errors[-1]) < 1e-3), errors[-1]
    assert np.all(order(errors) >= 1.8), order(errors)


def test_tip_mass_against_its_characteristic_equation():
    """A point mass at the tip (tip_load's mass with gravity 0: inertia, no weight) against
    1 + cos βL cosh βL + μ βL (cos βL sinh βL − sin βL cosh βL) = 0, μ = m_t/(ρ A L)."""
    tip_mass = 0.01
    scene = wire(81, terms=["stretch", "bend_twist", "centerline", "tip_load"],
                 tip_load={"mass": tip_mass, "gravity": 0.0})
    length, stiffness, line_mass, _ = section(scene["rods"]["wire"])
    ratio = tip_mass / (line_mass * length)

    def equation(b: float) -> float:
        return (1.0 + math.cos(b) * math.cosh(b)
                + ratio * b * (math.cos(b) * math.sinh(b) - math.sin(b) * math.cosh(b)))

    grid = np.linspace(0.1, 12.0, 4000)
    roots = [brentq(equation, a, b, xtol=1e-14) for a, b in zip(grid[:-1], grid[1:],
                                                                 strict=True)
             if equation(a) * equation(b) < 0.0][:3]
    exact = np.array(roots) ** 2 * math.sqrt(stiffness / (line_mass * length**4)) / (2 * math.pi)
    found = bending(rodsim.modes(scene, count=6, rotary_inertia=False))
    np.testing.assert_allclose(found, exact, rtol=1e-3)
    assert found[0] < 0.8 * BETA_L[0] ** 2 * math.sqrt(
        stiffness / (line_mass * length**4)) / (2 * math.pi)  # the mass lowers it


def test_torsion_and_axial_modes():
    """ω = (2n − 1) π/(2L) √(G J/(ρ J)) for twist and √(E_s/ρ) for stretch (n = 1)."""
    modes = rodsim.modes(wire(81), count=24)
    rod = STEEL
    shear = rod["youngs_modulus"] / (2.0 * (1.0 + rod["poisson_ratio"]))
    twist = math.sqrt(shear / rod["density"]) / (4.0 * rod["length"])
    axial = math.sqrt(rod["youngs_modulus"] / rod["density"]) / (4.0 * rod["length"])
    torsion = modes.frequencies[modes.rotational_share > 0.99]
    along = np.sum(modes.shapes[:, :, 0] ** 2, axis=1)
    across = np.sum(modes.shapes[:, :, 1:] ** 2, axis=(1, 2))
    stretch = modes.frequencies[along > 1e6 * across]
    assert len(torsion) == 1 and len(stretch) == 1
    assert torsion[0] == pytest.approx(twist, rel=1e-4)
    assert stretch[0] == pytest.approx(axial, rel=1e-4)


def test_table1_catheter_against_timoshenko():
    """table1-50g's catheter (hanging mass removed, N = 81): a thick soft rod, where rotary
    inertia and the shear of the centerline penalty (K_P = 1e4 N, Timoshenko's κGA) move
    the third frequency by 2.5 % from Euler–Bernoulli. Against the Timoshenko reference
    within 1e-3, with and without rotary inertia; Euler–Bernoulli alone would miss."""
    scene = rodsim.load_scene("table1-50g", ["mass=0", "nodes=81"])
    rod = scene.rods["catheter"]
    r = rod.radius
    line_mass = rod.density * math.pi * r**2
    rotary = rod.density * math.pi * r**4 / 4.0
    stiffness = rod.youngs_modulus * math.pi * r**4 / 4.0
    penalty = float(scene.data["rods"]["catheter"]["centerline"]["K_P"])
    euler = clamped_free_frequencies(3, length=rod.length, EI=stiffness, rhoA=line_mass)
    for inertia in (False, True):
        exact = clamped_free_frequencies(3, length=rod.length, EI=stiffness, rhoA=line_mass,
                                         rhoI=rotary if inertia else 0.0, shear=penalty)
        found = bending(rodsim.modes(scene, count=8, rotary_inertia=inertia))
        np.testing.assert_allclose(found, exact, rtol=1e-3)
        if inertia:
            assert abs(found[2] / euler[2] - 1.0) > 0.02


def test_tension_stiffens_against_the_reference():
    """A tip force T along the axis (a dead load): E I w'''' − T w'' = ρ A ω² w, free end
    V = 0, solved by our transfer-matrix reference (with the rotary inertia and the default
    penalty's shear). T = 20 N doubles the first frequency; within 1e-3 at N = 81, order
    ≥ 1.8."""
    tension = 20.0
    rod = STEEL
    length, stiffness, line_mass, rotary = section(wire(3)["rods"]["wire"])
    area = math.pi * rod["radius"] ** 2
    exact = clamped_free_frequencies(3, length=length, EI=stiffness, rhoA=line_mass,
                                     rhoI=rotary, shear=100.0 * rod["youngs_modulus"] * area,
                                     tension=tension)
    slack = clamped_free_frequencies(1, length=length, EI=stiffness, rhoA=line_mass,
                                     rhoI=rotary)
    assert exact[0] > 1.9 * slack[0]
    errors = []
    for nodes in (21, 41, 81):
        scene = wire(nodes, terms=["stretch", "bend_twist", "centerline", "tip_load"],
                     tip_load={"force": [tension, 0.0, 0.0]})
        errors.append(bending(rodsim.modes(scene, count=6)) / exact - 1.0)
    assert np.all(np.abs(errors[-1]) < 1e-3), errors[-1]
    assert np.all(order(errors) >= 1.8), order(errors)


def test_sections_against_the_piecewise_reference():
    """catheter-pull-ring's two sections (a tube, E 200 MPa shaft and 20 MPa distal 4 cm:
    a 10× jump in E I), its wires slack: against the product of the spans' exact transfer
    matrices. Within 1e-3 at N = 81 and at N = 83 (the jump inside a segment), order ≥ 1.8
    over N = 21, 41, 81."""
    scene = rodsim.load_scene("catheter-pull-ring", [
        "tendons.wire_up.tendon_string.tension=0", "tendons.wire_down.tendon_string.tension=0"])
    rod = scene.rods["catheter"]
    inner = 0.00075
    area = math.pi * (rod.radius**2 - inner**2)
    second = math.pi * (rod.radius**4 - inner**4) / 4.0
    penalty = float(scene.data["rods"]["catheter"]["centerline"]["K_P"])
    spans = [{"length": length, "EI": modulus * second, "rhoA": rod.density * area,
              "rhoI": rod.density * second, "shear": penalty}
             for length, modulus in ((0.06, 2.0e8), (0.04, 2.0e7))]
    first = (1.875 / rod.length) ** 2 * math.sqrt(2.0e7 * second / (rod.density * area))
    exact = spans_frequencies(3, spans, first=first)
    errors = [bending(rodsim.modes(scene.with_overrides([f"nodes={nodes}"]), count=8))
              / exact - 1.0 for nodes in (21, 41, 81, 83)]
    assert np.all(np.abs(errors[2]) < 1e-3) and np.all(np.abs(errors[3]) < 1e-3), errors
    assert np.all(order(errors[:3]) >= 1.8), order(errors[:3])


def test_compression_softens_and_past_buckling_is_unstable():
    """A tip force against the axis: below Euler's load π² E I/(4 L²) (5.2 N here) the
    first frequency drops as the reference says; past it, the straight equilibrium that
    static finds is unstable: ω² < 0, frequency NaN, and the message says so."""
    rod = STEEL
    length, stiffness, line_mass, rotary = section(wire(3)["rods"]["wire"])
    area = math.pi * rod["radius"] ** 2
    euler = math.pi**2 * stiffness / (4.0 * length**2)
    for push in (0.5 * euler, 2.0 * euler):
        scene = wire(81, terms=["stretch", "bend_twist", "centerline", "tip_load"],
                     tip_load={"force": [-push, 0.0, 0.0]})
        modes = rodsim.modes(scene, count=4)
        assert modes.success
        if push < euler:
            exact = clamped_free_frequencies(1, length=length, EI=stiffness, rhoA=line_mass,
                                             rhoI=rotary, shear=100.0 * rod["youngs_modulus"]
                                             * area, tension=-push)
            assert bending(modes, 1) == pytest.approx(exact, rel=1e-3)
            assert modes.message == "ok"
        else:
            assert modes.eigenvalues[0] < 0.0 and np.isnan(modes.frequencies[0])
            assert "unstable" in modes.message


USER_ROBOTS = 6


@pytest.mark.parametrize("seed", range(USER_ROBOTS))
def test_family_of_user_robots(seed):
    """Seeded robots as a user writes them: steel and nitinol wires, soft polymer catheters,
    N from 31 to 81, some with a tension or a tip mass. Each bending frequency within twice
    the leading discretisation error c_n (β_n h)² measured on the steel rod at N = 81
    (c = 0.13, 0.072, 0.043: the error is scale-free) of the Timoshenko reference."""
    rng = np.random.default_rng(seed)
    kind = KINDS[seed % 3]
    rod = user_rod(rng, kind)
    nodes = int(rng.choice([31, 41, 61, 81]))
    length, stiffness, line_mass, rotary = section(rod)
    tension = tip_mass = 0.0
    terms = ["stretch", "bend_twist", "centerline"]
    table: dict = {}
    if seed % 2:
        tension = float(rng.uniform(0.5, 5.0)) * stiffness / length**2
        terms.append("tip_load")
        table = {"tip_load": {"force": [tension, 0.0, 0.0]}}
    elif seed % 3:
        tip_mass = float(rng.uniform(0.1, 1.0)) * line_mass * length
        terms.append("tip_load")
        table = {"tip_load": {"mass": tip_mass, "gravity": 0.0}}
    scene = {"name": f"robot-{seed}", "rods": {"r": {**rod, "nodes": nodes, "terms": terms,
                                                       **table}}}
    area = math.pi * rod["radius"] ** 2
    exact = clamped_free_frequencies(3, length=length, EI=stiffness, rhoA=line_mass,
                                     rhoI=rotary, shear=100.0 * rod["youngs_modulus"] * area,
                                     tension=tension, tip_mass=tip_mass)
    modes = rodsim.modes(scene, count=12)
    assert modes.success and modes.symmetric, modes.message
    found = bending(modes)
    bound = 2.0 * np.array([0.13, 0.072, 0.043]) * (BETA_L / (nodes - 1)) ** 2 + 2e-5
    assert np.all(np.abs(found / exact - 1.0) < bound), (found / exact - 1.0, bound)


# --------------------------------------------------------- a bent, tendon-loaded robot


@pytest.fixture(scope="module")
def tdcr():
    result = rodsim.solve("tdcr-two-segment", "static")
    assert result.success
    return result, rodsim.modes(result, count=8)


def test_tdcr_bent_equilibrium_modes_are_consistent(tdcr):
    """About tdcr-two-segment's bent equilibrium (string tendons: conservative): ω² real
    and positive, K φ = ω² M φ to round-off, unit modal mass, and the same ω² as a dense
    generalised eigensolve of the whole (singular) pencil (K, M) (the Rayleigh quotients of
    its eigenvectors)."""
    result, modes = tdcr
    assert modes.success and modes.symmetric and modes.message == "ok"
    assert np.all(modes.eigenvalues > 0.0) and np.all(modes.growth == 0.0)
    model = Model(result.scene)
    x = result.state
    stiffness = -model.jacobian(x).toarray()
    factor = mass_factor(model, x).toarray()
    mass = factor @ factor.T
    for value, vector in zip(modes.eigenvalues, modes.vectors, strict=True):
        residual = stiffness @ vector - value * (mass @ vector)
        assert np.linalg.norm(residual) < 1e-6 * np.linalg.norm(stiffness @ vector)
        assert vector @ mass @ vector == pytest.approx(1.0, rel=1e-7)
    # shapes: the vectors' positions scaled to the whole mass's modal mass
    total = sum(rod.node_masses().sum() for rod in model.rods.values())
    full = np.zeros((len(modes.vectors), model.full_size))
    full[:, model.free] = modes.vectors * math.sqrt(total)
    np.testing.assert_array_equal(
        modes.shapes, full[:, model.rods["backbone"].layout.position_index])
    # The dense QZ's eigenvalues carry its round-off (~eps |K| / |M| with the centerline
    # penalty in K: up to 1.6e-7 relative, on mode 2 of a near-degenerate pair); the
    # Rayleigh quotients of its eigenvectors are accurate to second order (within 1.1e-8
    # of ours on every mode), so the comparison is on them.
    values, vectors = la.eig(stiffness, mass)
    finite = np.flatnonzero(np.isfinite(values))
    lowest = finite[np.argsort(values[finite].real)[:8]]
    quotients = [(v @ stiffness @ v) / (v @ mass @ v)
                 for v in (vectors[:, i].real for i in lowest)]
    np.testing.assert_allclose(values[lowest].real, quotients, rtol=1e-6)
    np.testing.assert_allclose(modes.eigenvalues, quotients, rtol=1e-7)
    # the tendons' load matters: the straight unloaded robot vibrates differently
    unloaded = rodsim.modes("tdcr-two-segment", count=2, overrides=[
        "tendons.s1a.tendon_string.tension=0", "tendons.s1b.tendon_string.tension=0",
        "tendons.s1c.tendon_string.tension=0", "tendons.s2a.tendon_string.tension=0",
        "tendons.s2b.tendon_string.tension=0", "tendons.s2c.tendon_string.tension=0",
        "force=[0,0,0]"])
    assert abs(unloaded.frequencies[0] / modes.frequencies[0] - 1.0) > 1e-3


def test_modes_are_reproducible(tdcr):
    result, modes = tdcr
    again = rodsim.modes(result, count=8)
    assert np.array_equal(again.eigenvalues, modes.eigenvalues)
    assert np.array_equal(again.shapes, modes.shapes)


def test_non_conservative_coupling_uses_the_general_solver():
    """The paper's lumen coupling (table3-catheter1) makes K non-symmetric: eigs, and each
    mode still satisfies K φ = ω² M φ."""
    result = rodsim.solve("table3-catheter1", "static")
    modes = rodsim.modes(result, count=4)
    assert modes.success and not modes.symmetric
    model = Model(result.scene)
    registered = model.reregistered(result.state, exact=True)
    model = model if registered is None else registered
    stiffness = -model.jacobian(result.state)
    factor = mass_factor(model, result.state)
    for value, vector in zip(modes.eigenvalues, modes.vectors, strict=True):
        residual = stiffness @ vector - value * (factor @ (factor.T @ vector))
        assert np.linalg.norm(residual) < 1e-6 * np.linalg.norm(stiffness @ vector)


def test_bad_count_is_refused():
    with pytest.raises(ModesError, match="count"):
        rodsim.modes(wire(5), count=0)
    with pytest.raises(ModesError, match="allowed 1 to"):
        rodsim.modes(wire(5), count=10_000)
    with pytest.raises(ModesError, match="overrides"):
        rodsim.modes(rodsim.solve(wire(5), "static"), overrides=["nodes=9"])


# ----------------------------------------------------------------------------- the CLI


def cli(*args: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rodsim.app.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_cli_prints_the_table_and_writes_the_archive(tmp_path):
    from rodsim.io.archive import read_dataset

    out = tmp_path / "m.nc"
    done = cli("modes", "tdcr-two-segment", "--count", "4", "-o", str(out), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "frequency [Hz]" in done.stdout
    ds = read_dataset(out)
    assert ds.attrs["kind"] == "modes" and ds.sizes["mode"] == 4
    modes = rodsim.modes("tdcr-two-segment", count=4)
    np.testing.assert_array_equal(ds["frequency"].values, modes.frequencies)
    assert ds["mode_position"].shape == (4, 61, 3)
    assert (tmp_path / "m.png").exists()


@pytest.mark.parametrize("args, words", [
    (("--count", "0"), "at least 1"),
    (("--set", "density=0"), "density"),
    (("--count", "100000"), "allowed 1 to"),
])
def test_cli_bad_input(tmp_path, args, words):
    done = cli("modes", "tdcr-two-segment", *args, "-o", str(tmp_path / "m.nc"),
               cwd=tmp_path)
    assert done.returncode == 2
    assert words in done.stderr and len(done.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "m.nc").exists()
