"""Per-strain Kelvin–Voigt damping (``[rods.<rod>.damping] retardation_time_stretch``,
``_shear``, ``_bending``, ``_twist``; rodsim/core/damping.py) and the damped modes' complex
shapes matched to the undamped modes (``rodsim.modes``: ``matched_eigenvalues``,
``damped_shapes``; docs/dynamics.md, "Damped modes"), against independent references: the
closed-form frequencies of a clamped steel rod (Euler–Bernoulli bending, the rod's first
axial mode (π/2)√(E/ρ)/L and torsion mode (π/2)√(G/ρ)/L), ζ = τ_k ω/2 for the strain kind
k each mode is made of, the decay that ``rodsim.simulate`` measures, and the residual of
(λ² M + λ D + K) φ = 0 with M, D and K assembled here."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_damped_modes import bending, projected_damping
from test_simulate import STEEL, decay_ratio, modal, peaks, wire

import rodsim
from rodsim.app.cli.main import main
from rodsim.core.damping import Damping, rod_damping
from rodsim.core.inertia import mass_factor
from rodsim.core.model import Model
from rodsim.core.schema import SceneError

LENGTH = STEEL["length"]
#: The first axial and torsion modes of the clamped–free rod [rad/s].
AXIAL = 0.5 * math.pi * math.sqrt(STEEL["youngs_modulus"] / STEEL["density"]) / LENGTH
TORSION = 0.5 * math.pi * math.sqrt(
    STEEL["youngs_modulus"] / (2.0 * (1.0 + STEEL["poisson_ratio"])) / STEEL["density"]
) / LENGTH
#: ζ₁ = 0.01 of bending; τ of stretch and twist that give ζ = 0.02 and 0.03 to their modes.
TAU_BENDING = 2.0 * 0.01 / bending(0)
TAU_STRETCH = 2.0 * 0.02 / AXIAL
TAU_TWIST = 2.0 * 0.03 / TORSION


def test_per_strain_keys_are_set_resolved_and_checked(capsys):
    """``--set`` reaches the per-strain keys on a scene without a damping table; an omitted
    one follows ``retardation_time`` (set before or after it; shear: 0) and stays out of
    the resolved table; a negative one is a one-line error (CLI: exit 2)."""
    scene = rodsim.load_scene("table1-50g", ["nodes=11", "retardation_time_twist=2e-3",
                                             "damping.retardation_time=1e-3"])
    table = scene.data["rods"]["catheter"]["damping"]
    assert table == {"retardation_time": 1e-3, "drag": 0.0, "retardation_time_twist": 2e-3}
    options = rod_damping(Model(scene), "catheter")
    assert [options.retardation(kind) for kind in ("stretch", "shear", "bending", "twist")
            ] == [1e-3, 0.0, 1e-3, 2e-3]
    with pytest.raises(SceneError, match="out of range") as caught:
        rodsim.load_scene("table1-50g", ["damping.retardation_time_bending=-1"])
    assert "rods.catheter.damping.retardation_time_bending" in str(caught.value)
    assert "\n" not in str(caught.value)
    with pytest.raises(SceneError, match="unknown key"):
        rodsim.load_scene(wire(5, damping={"retardation_time_bend": 1e-3}))
    assert main(["simulate", "table1-50g", "--set", "nodes=5", "--set",
                 "damping.retardation_time_stretch=-2e-3", "--t-end", "0.01"]) == 2
    err = capsys.readouterr().err.strip()
    assert "retardation_time_stretch" in err and len(err.splitlines()) == 1


def test_shear_damping_is_off_unless_given_and_then_dissipates():
    """Without ``retardation_time_shear`` the centerline penalty adds nothing to D (the
    matrix equals the one of stretch and bend–twist alone, bit for bit); with it, D gains
    the positive semi-definite K_P l Jᵀ J (its eigenvalues ≥ 0, its trace larger)."""
    plain = Model(rodsim.load_scene(wire(7, damping={"retardation_time": 1e-4})))
    sheared = Model(rodsim.load_scene(wire(7, damping={"retardation_time": 1e-4,
                                                       "retardation_time_shear": 1e-4})))
    x = plain.x0 + plain.reference[plain.free]
    x = x + 1e-3 * np.random.default_rng(1).standard_normal(x.size)
    base = Damping(plain)
    assert [term.name for term, _, _ in base.elastic] == ["stretch", "bend_twist"]
    both = Damping(sheared).matrix(x).toarray()
    extra = both - base.matrix(x).toarray()
    assert np.trace(extra) > 0.0
    assert np.linalg.eigvalsh(extra).min() > -1e-9 * np.abs(extra).max()


def _kinds(modes: rodsim.app.modes.Modes) -> tuple[int, int]:
    """The first axial mode (its motion along x) and the first torsion mode (its kinetic
    energy in the rotation) among ``modes``."""
    along = np.linalg.norm(modes.shapes[:, :, 0], axis=1) / np.linalg.norm(
        modes.shapes.reshape(len(modes.shapes), -1), axis=1)
    axial = int(np.flatnonzero(along > 0.99)[0])
    torsion = int(np.flatnonzero(modes.rotational_share > 0.99)[0])
    return axial, torsion


def test_each_strain_kind_damps_its_own_modes():
    """τ_bending, τ_stretch and τ_twist chosen for ζ = 0.01, 0.02 and 0.03 (N = 11, 22
    modes: the bending pairs, 8 of them overdamped, then torsion at 1 970 Hz and the axial
    mode at 3 182 Hz): each matched damped root has ζ = τ_k ω/2 within 2 % for the
    closed-form ω (measured: bending −0.46 %, the N = 11 discretisation of ω₁; axial
    −0.02 %; torsion −0.10 %), and within 1e-4 of τ_k |λ|/2 (the modes stay apart: the
    damping of each is its own kind's alone, measured ≤ 3e-6); each damped shape is the
    undamped one (MAC > 0.999)."""
    damping = {"retardation_time_bending": TAU_BENDING,
               "retardation_time_stretch": TAU_STRETCH, "retardation_time_twist": TAU_TWIST}
    modes = rodsim.modes(wire(11, damping=damping), count=22)
    assert modes.success, modes.message
    axial, torsion = _kinds(modes)
    for k, tau, omega in ((0, TAU_BENDING, bending(0)), (1, TAU_BENDING, bending(0)),
                          (axial, TAU_STRETCH, AXIAL), (torsion, TAU_TWIST, TORSION)):
        zeta = modes.matched_damping_ratios[k]
        assert abs(zeta / (tau * omega / 2.0) - 1.0) < 0.02, (k, zeta)
        magnitude = abs(modes.matched_eigenvalues[k])
        assert abs(zeta / (tau * magnitude / 2.0) - 1.0) < 1e-4, (k, zeta)
        assert modes.shape_mac[k] > 0.999
    # one τ for all (bending's) would give the axial and torsion modes a far larger ζ
    assert modes.matched_damping_ratios[axial] < 0.1 * TAU_BENDING * AXIAL / 2.0


def test_the_bending_decay_rodsim_simulate_measures_follows_the_bending_tau():
    """The steel rod (N = 11) released from a 0.02 N tip force with τ_bending for ζ₁ = 0.01
    and a stretch τ ten times larger: the logarithmic decrement over four periods (60 steps
    each) gives τ_bending ω₁/2 within 2 % for the Euler–Bernoulli ω₁ (measured −0.70 %,
    the same as with one τ for both: the N = 11 ω₁ and the midpoint rule; with the
    stretch τ it would be 0.1)."""
    scene = wire(11, damping={"retardation_time_bending": TAU_BENDING,
                              "retardation_time_stretch": 10.0 * TAU_BENDING})
    period = 2.0 * math.pi / bending(0)
    h = period / 60
    run = rodsim.simulate(scene, 4.0 * period, step=h, output_dt=h,
                          initial={"tip_load.force": [0.0, -0.02, 0.0]})
    assert run.success, run.message
    _, values = peaks(run.times, modal(run))
    measured = decay_ratio(values)
    assert abs(measured / (TAU_BENDING * bending(0) / 2.0) - 1.0) < 0.02, measured


def test_the_axial_decay_rodsim_simulate_measures_follows_the_stretch_tau():
    """The same rod with the three τ released from a 50 N axial tip force: its motion
    along x projected on the first axial mode (trapezoid weights) decays over four
    periods (60 steps each) with τ_stretch ω_axial/2 within 2 % for the closed-form
    ω_axial (measured −0.08 %; with τ_bending it would be 150 times larger)."""
    damping = {"retardation_time_bending": TAU_BENDING,
               "retardation_time_stretch": TAU_STRETCH, "retardation_time_twist": TAU_TWIST}
    scene = wire(11, damping=damping)
    modes = rodsim.modes(scene, count=22)
    axial, _ = _kinds(modes)
    period = 1.0 / modes.frequencies[axial]
    h = period / 60
    run = rodsim.simulate(scene, 4.0 * period, step=h, output_dt=h,
                          initial={"tip_load.force": [50.0, 0.0, 0.0]})
    assert run.success, run.message
    weights = np.ones(11)
    weights[[0, -1]] = 0.5
    stretch = run.positions[:, :, 0] - np.linspace(0.0, LENGTH, 11)
    _, values = peaks(run.times, stretch @ (weights * modes.shapes[axial, :, 0]))
    measured = decay_ratio(np.abs(values))
    assert abs(measured / (TAU_STRETCH * AXIAL / 2.0) - 1.0) < 0.02, measured


def test_proportional_damping_keeps_the_undamped_shapes():
    """One Kelvin–Voigt τ (D = τ K_mat, at the straight rest state τ K: proportional):
    every damped shape is its undamped mode (MAC > 0.999; the shapes themselves to 1e-5 of
    their size, measured 2.2e-6: a bending pair's two roots split by 1e-7 in the dense
    eigensolve, within ``DEGENERATE``) and ζ_n = τ ω_n/2 for each mode's own ω_n to 1e-5,
    overdamped modes (ζ > 1) excepted. Without damping the damped shapes are the
    undamped ones."""
    tau = 2.0 * 0.01 / bending(0)
    modes = rodsim.modes(wire(11, damping={"retardation_time": tau}), count=10)
    assert modes.success, modes.message
    assert np.all(modes.shape_mac > 0.999)
    size = np.abs(modes.shapes).max()
    np.testing.assert_allclose(modes.damped_shapes, modes.shapes, rtol=0.0,
                               atol=1e-5 * size)
    omega = 2.0 * math.pi * modes.frequencies
    ringing = tau * omega / 2.0 < 1.0
    np.testing.assert_allclose(modes.matched_damping_ratios[ringing],
                               (tau * omega / 2.0)[ringing], rtol=1e-5)
    # the first four pairs are the roots by |λ| (a pair's two equal roots to 1e-7); then
    # the slow real root of an overdamped mode (near −1/τ) comes before the fifth pair by
    # |λ|, which the matching still finds ringing with ζ = τ ω/2
    np.testing.assert_allclose(modes.matched_eigenvalues[:8], modes.damped_eigenvalues[:8],
                               rtol=1e-7)
    assert modes.damped_eigenvalues[8].imag == 0.0 < modes.matched_eigenvalues[8].imag
    undamped = rodsim.modes(wire(11), count=3)
    np.testing.assert_array_equal(undamped.damped_shapes, undamped.shapes)
    np.testing.assert_array_equal(undamped.shape_mac, np.ones(3))


def test_non_proportional_damped_shapes_solve_the_quadratic_eigenproblem():
    """A bent rod (0.2 N at the tip, N = 11) with Kelvin–Voigt on bending only and a drag,
    not proportional: each matched complex shape φ_d and root λ satisfy
    (λ² M + λ D̂ + K) φ_d = 0 with M, D̂ (D without each quaternion's norm direction) and K
    assembled here, to 1e-4 of ‖K φ_d‖ (measured ≤ 1.4e-5, where the eigenvectors of a
    dense QZ of the same pencil, ill-scaled by the centerline penalty, reach 3.3e-5 and
    2.9e-5 on the first pair); the shape has unit modal mass
    and φ_dᴴ M φ real and positive; the archive holds the shapes bit for bit."""
    scene = wire(11, damping={"retardation_time_bending": 5e-4, "drag": 2.0},
                 tip_load={"force": [0.0, -0.2, 0.3], "mass": 0.0})
    modes = rodsim.modes(scene, count=6)
    assert modes.success, modes.message
    model = Model(modes.result.scene)
    x = modes.result.state
    stiffness = -model.jacobian(x).toarray()
    factor = mass_factor(model, x).toarray()
    mass = factor @ factor.T
    damping = projected_damping(model, x)
    whole = 1.0 / math.sqrt(rodsim.core.inertia.total_mass(model))
    imaginary = 0.0
    for k in range(6):
        full = np.zeros(model.full_size, dtype=complex)
        rod = model.rods["wire"].layout
        full[rod.position_index] = modes.damped_shapes[k] * whole
        full[rod.quaternion_index] = modes.damped_rotations[k] * whole
        phi = full[model.free]
        lam = modes.matched_eigenvalues[k]
        residual = (lam**2 * mass + lam * damping + stiffness) @ phi
        assert np.linalg.norm(residual) < 1e-4 * np.linalg.norm(stiffness @ phi), k
        assert np.real(phi.conj() @ mass @ phi) == pytest.approx(1.0, rel=1e-9)
        overlap = phi.conj() @ mass @ modes.vectors[k]
        assert overlap.real > 0.0 and abs(overlap.imag) < 1e-9 * abs(overlap)
        imaginary = max(imaginary, float(np.abs(modes.damped_shapes[k].imag).max()))
    assert imaginary > 0.0  # non-proportional: the shapes are complex
    ds = modes.to_xarray()
    np.testing.assert_array_equal(ds["damped_mode_position_real"].values
                                  + 1j * ds["damped_mode_position_imag"].values,
                                  modes.damped_shapes)
    np.testing.assert_array_equal(ds["matched_eigenvalue_real"].values
                                  + 1j * ds["matched_eigenvalue_imag"].values,
                                  modes.matched_eigenvalues)
    np.testing.assert_array_equal(ds["shape_mac"].values, modes.shape_mac)
