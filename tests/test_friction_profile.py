"""A friction coefficient given along the arc length (``tendon_string.friction_profile`` at
``friction_profile_s``, piecewise linear; issue 34), independent of the discretisation,
against closed forms of the capstan law with μ(s) (docs/tendon.md, "Friction along the
arc length").

- Rigid helix (radius a, rate φ′ = 2π/p per unit arc length s of the straight rod): the
  tendon's tangent turns by α = atan(a φ′) at the entry, then at |dt/ds| = a φ′²/c per
  unit s (c = √(1 + a²φ′²)), so T(s) = T_0 exp(−μ(0) α − (a φ′²/c) ∫_0^s μ ds′); chord e
  carries T at its midpoint (O(h²)).
- A catheter bent by its own tendon (planar, offset ρ): dΘ/ds = T ρ/EI and
  dT/dΘ = −μ(s) T, so d(1/T)/ds = μ(s) ρ/EI: 1/T(s) = 1/T_0 + (ρ/EI) ∫_0^s μ ds′ and
  Θ(s) = (ρ/EI) ∫_0^s T ds′; the tip the quadrature of (1 − T/EA)(cos Θ, sin Θ).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from test_tendon_friction import EI, LENGTH, OFFSET, _tip, catheter, model_tip
from test_tendon_stiction import HELIX_PITCH, HELIX_RADIUS, ROD_LENGTH, helix_scene, string_term

import rodsim
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.core.tendon_friction import profile_coefficients


def _integral(knots: np.ndarray, values: np.ndarray, s: float) -> float:
    """∫_0^s μ of the piecewise-linear profile (knots from 0)."""
    mu = lambda u: float(np.interp(u, knots, values))  # noqa: E731
    inside = [k for k in knots if 0.0 < k < s]
    return quad(mu, 0.0, s, points=inside or None, limit=200, epsabs=1e-15,
                epsrel=1e-13)[0]


def _orders(errors: list[float]) -> list[float]:
    return [math.log2(a / b) for a, b in zip(errors, errors[1:], strict=False)]


def _rest(model: Model) -> np.ndarray:
    term = string_term(model)
    rod = term.tendon.catheter
    full = np.zeros(model.full_size)
    full[rod.layout.position_index] = rod.rest_positions()
    full[rod.layout.quaternion_index] = rod.rest_quaternions()
    return full


def test_the_mean_over_each_point_s_cell_integrates_a_profile_exactly():
    """A routing point's μ is the mean of μ(s) between its chords' midpoints (the entry's
    is μ at the entry): exact for a linear μ, and the cells' means times their lengths sum
    to ∫ μ ds across kinks."""
    s = np.linspace(0.0, 1.0, 11)
    linear = profile_coefficients(np.array([0.0, 1.0]), np.array([0.1, 0.3]), s)
    np.testing.assert_allclose(linear, np.concatenate([[0.1], 0.1 + 0.2 * s[1:-1]]),
                               rtol=1e-14)
    knots, values = np.array([0.05, 0.33, 0.6]), np.array([0.2, 0.5, 0.1])
    mu = profile_coefficients(knots, values, s)
    middles = 0.5 * (s[1:] + s[:-1])
    total = _integral(np.concatenate([[0.0], knots]), np.concatenate([[0.2], values]),
                      middles[-1]) - _integral(np.concatenate([[0.0], knots]),
                                               np.concatenate([[0.2], values]), middles[0])
    assert float(mu[1:] @ np.diff(middles)) == pytest.approx(total, rel=1e-13)


@pytest.mark.parametrize("knots, values", [
    ([0.0, 0.03, 0.07, 0.1], [0.1, 0.5, 0.2, 0.3]),          # kinks
    ([0.0, 0.0437, 0.0437 + 1e-7, 0.1], [0.1, 0.1, 0.5, 0.5]),  # a jump between two nodes
])
def test_the_helix_tensions_converge_at_second_order_whatever_the_profile(knots, values):
    """Chord tensions on the rigid helix against T_0 exp(−μ(0) α − (a φ′²/c) ∫_0^s μ) at
    the chords' midpoints, at the rest shape (the polygon exactly), N = 21, 41, 81:
    measured 1.01e-2, 2.54e-3, 6.36e-4 T_0 with the kinks (orders 1.99, 2.00) and 9.85e-3,
    2.48e-3, 6.21e-4 with the jump (1.99, 2.00) — the helix polygon's own error, as with one
    μ. A μ per routing point sampled from the same profile at the nodes
    (``friction_points``) meets the jump in one point's turn: 7.2e-3, 2.7e-3, 4.6e-3
    (first order at best). Solved at 1 mN the tensions are the rest shape's to 1e-8 T_0."""
    knots, values = np.array(knots), np.array(values)
    t0 = 1e-3
    a, rate = HELIX_RADIUS, 2 * math.pi / HELIX_PITCH
    c = math.sqrt(1 + (a * rate) ** 2)

    def closed(s: float) -> float:
        return t0 * math.exp(-values[0] * math.atan(a * rate)
                             - a * rate**2 / c * _integral(knots, values, s))

    errors, sampled = [], []
    for n in (21, 41, 81):
        data = helix_scene(n, t0, friction_profile=list(values),
                           friction_profile_s=list(knots))
        model = Model(Scene.from_dict(data))
        term = string_term(model)
        s = term.points.s
        reference = np.array([closed(m) for m in 0.5 * (s[1:] + s[:-1])])
        tension = term.chord_tensions(_rest(model))
        errors.append(float(np.max(np.abs(tension - reference))) / t0)
        nodes = np.linspace(0.0, ROD_LENGTH, n)
        points = Model(Scene.from_dict(helix_scene(
            n, t0, friction_points=list(np.interp(nodes, knots, values)))))
        sampled.append(float(np.max(np.abs(
            string_term(points).chord_tensions(_rest(points)) - reference))) / t0)
        if n == 41:
            result = rodsim.solve(Scene.from_dict(data))
            assert result.success, result.message
            assert np.max(np.abs(result.tension_profiles["a"][1] - tension)) < 1e-8 * t0
    assert errors[-1] < 7e-4 and min(_orders(errors)) > 1.95, errors
    if knots[2] - knots[1] < 1e-6:  # the jump: sampling it at the nodes is not convergent
        assert sampled[-1] > 5 * errors[-1], (sampled, errors)


def test_the_self_bent_catheter_converges_to_the_closed_form_with_a_profile():
    """The catheter bent by its own tendon (3 N) with μ from 0.1 to 0.4 and back to 0.3
    along it: tip and chord tensions against 1/T = 1/T_0 + (ρ/EI) ∫ μ ds. Measured tip
    error / L 5.96e-5, 1.51e-5, 3.79e-6 (N = 21, 41, 81; 9.5e-7 at 161), orders 1.98, 1.99;
    tensions 2.21e-4, 5.54e-5, 1.39e-5 T_0 (2.00, 2.00)."""
    knots, values, t0 = np.array([0.0, 0.05, 0.12, 0.2]), np.array([0.1, 0.4, 0.15, 0.3]), 3.0

    def tension(s: float) -> float:
        return 1.0 / (1.0 / t0 + OFFSET / EI * _integral(knots, values, s))

    def theta(s: float) -> float:
        inside = [k for k in knots if 0.0 < k < s]
        return quad(lambda u: tension(u) * OFFSET / EI, 0.0, s, points=inside or None,
                    epsabs=1e-15, epsrel=1e-13)[0]

    reference = _tip(theta, tension, list(zip(knots[:-1], knots[1:], strict=True)))
    tips, tensions = [], []
    for n in (21, 41, 81):
        result = rodsim.solve(Scene.from_dict(catheter(
            n, 0.0, t0, friction_profile=list(values), friction_profile_s=list(knots))))
        assert result.success, result.message
        tips.append(float(np.linalg.norm(model_tip(result.positions()) - reference)) / LENGTH)
        s, chord = result.tension_profiles["a"]
        tensions.append(float(np.max(np.abs(chord - [tension(v) for v in s]))) / t0)
    assert tips[-1] < 5e-6 and min(_orders(tips)) > 1.9, tips
    assert tensions[-1] < 2e-5 and min(_orders(tensions)) > 1.9, tensions


def test_a_constant_profile_is_the_scalar_friction():
    """friction_profile = [μ] gives friction = μ's equilibrium (the wrap summed as
    Σ μ θ_j instead of μ Σ θ_j: the solver's tolerance)."""
    scalar = rodsim.solve(Scene.from_dict(catheter(15, 0.25, 3.0)))
    profile = rodsim.solve(Scene.from_dict(catheter(
        15, 0.0, 3.0, friction_profile=[0.25], friction_profile_s=[0.1])))
    assert scalar.success and profile.success
    assert np.max(np.abs(profile.positions() - scalar.positions())) < 1e-9 * LENGTH


@pytest.mark.parametrize("values, message", [
    ({"friction_profile": [0.1, -0.2], "friction_profile_s": [0.0, 0.1]},
     "friction_profile = .*component out of range"),
    ({"friction_profile": [0.1, 0.2], "friction_profile_s": [0.05, 0.02]}, "not increasing"),
    ({"friction_profile": [0.1, 0.2], "friction_profile_s": [0.05, 0.05]}, "not increasing"),
    ({"friction_profile": [0.1, 0.2], "friction_profile_s": [0.0, 0.3]},
     r"outside the tendon; allowed: arc lengths within its span \[0, 0.2\]"),
    ({"start": 0.05, "friction_profile": [0.1], "friction_profile_s": [0.01]},
     "outside the tendon"),
    ({"friction_profile": [0.1, 0.2], "friction_profile_s": [0.1]}, "as many of each"),
    ({"friction_profile_s": [0.1]}, "as many of each"),
    ({"friction_profile": [0.1], "friction_profile_s": [0.1], "friction_points": [0.1] * 11},
     "both set"),
    ({"friction_profile": [0.1, 0.4], "friction_profile_s": [0.0, 0.1],
      "static_friction": 0.3}, "largest friction_profile value"),
    ({"control": "displacement", "stiffness": 6e3, "friction_profile": [0.1],
      "friction_profile_s": [0.1]}, "tension-controlled string only"),
])
def test_bad_profiles_are_one_line(values, message):
    data = catheter(11, 0.0, 3.0, **values)
    if values.get("control") == "displacement":
        del data["tendons"]["a"]["tendon_string"]["tension"]
    with pytest.raises(SceneError, match=message) as info:
        Model(Scene.from_dict(data))
    assert "\n" not in str(info.value)


def test_bad_profiles_exit_2_on_the_command_line(tmp_path, capsys, cli):
    from test_tendon_friction import toml_scene

    scene = toml_scene(tmp_path, 3.0)
    key = "tendons.a.tendon_string.friction_profile"
    for override in ([f"{key}=[0.1,-0.2]", f"{key}_s=[0.0,0.1]"],
                     [f"{key}=[0.1,0.2]", f"{key}_s=[0.1,0.05]"],
                     [f"{key}=[0.1,0.2]", f"{key}_s=[0.1,0.5]"]):
        argv = ["run", str(scene), "-o", str(tmp_path / "bad.nc")]
        for item in override:
            argv += ["--set", item]
        code = cli(argv)
        err = capsys.readouterr().err.strip()
        assert code == 2 and "\n" not in err and key in err, err


def test_a_profile_takes_stiction_as_friction_points_do():
    """With ``static_friction`` the profile's per-point μ̄_j are the kinetic coefficients of
    the stick/slip law: released in one step from T_max on the rigid helix, the termination
    holds iff T_1 ≥ T_max e^{−2W − (μ_s − μ̄_last) θ_last}, W = Σ μ̄_j θ_j with the helix's
    closed-form turns (docs/tendon.md, "Stiction"), tested 0.2 % either side."""
    from test_tendon_stiction import TENSION, helix_turns

    nodes, t_max, static = 11, 1e-3, 0.6
    knots, values = [0.0, 0.04, 0.1], [0.1, 0.45, 0.25]
    data = helix_scene(nodes, t_max, friction_profile=values, friction_profile_s=knots,
                       static_friction=static)
    term = string_term(Model(Scene.from_dict(data)))
    mu = profile_coefficients(np.array(knots), np.array(values), term.points.s)
    np.testing.assert_array_equal(term.kinetic, mu)
    turns = helix_turns(nodes)
    edge = t_max * math.exp(-2 * float(mu @ turns) - (static - mu[-1]) * turns[-1])
    for factor, held in ((1.002, True), (0.998, False)):
        track = rodsim.track(Scene.from_dict(data), {TENSION: [t_max, edge * factor]},
                             estimates=False)
        assert track.success, track.message
        assert (track.tension[-1][-1] == track.tension[0][-1]) == held, factor
        assert track.slip[-1][-1] == (0.0 if held else 1.0)
