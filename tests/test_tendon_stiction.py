"""Per-point friction coefficients and stiction on a string tendon
(``tendon_string.friction_points``, ``tendon_string.static_friction``; issue 34) against the
closed forms derived in docs/tendon.md, "Friction per routing point" and "Stiction".

- A rigid helix (a stiff straight rod, a tendon at radius a, pitch p, routing points at
  the N nodes): the polygon's interior turns all equal θ with
  cos θ = (4a² sin²(Δφ/2) cos Δφ + h²)/(4a² sin²(Δφ/2) + h²), Δφ = 2π h/p, and the entry
  turns by α = atan(a 2π/p) from the axis to the helix's tangent and on to the first chord;
  the tension past point k is T_0 e^{−Σ_{j≤k} μ_j θ_j} (capstan, one μ per point).
- The same helix released in one step from T_max (pulled in from slack: every point
  sliding in) to T_1: every point must break loose, so chord e keeps T_max e^{−μ_k Θ_e}
  unless T_1 e^{μ_s Θ_e} is smaller; the termination holds iff T_1 ≥ T_max e^{−(μ_k+μ_s)Θ}.
  Released on in a second step to T_2 after the first freed every point but the last: the
  freed points slide at μ_k, the last holds iff T_2 ≥ T_max e^{−2μ_kΘ − (μ_s−μ_k)θ_last}.
- A catheter bent by its own tendon (planar, offset ρ): 1/T(s) is linear in s with slope
  ±μ ρ/EI wherever the tendon slides (dΘ/ds = T ρ/EI, dT/dΘ = ∓μ T). Released in one step
  from T_max to T_0 with μ_s: 1/T = 1/T_0 − μ_s ρ s/EI up to the slip front
  s_f = (T_max − T_0) EI/((μ_s + μ_k) T_0 T_max ρ), the pulled 1/T_max + μ_k ρ s/EI beyond.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import rodsim
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.core.terms.tendon_string import TendonString

TENSION = "tendons.a.tendon_string.tension"
#: The helix: radius, pitch [m] on a stiff steel rod (E 200 GPa, r = 2 mm, 0.1 m).
HELIX_RADIUS, HELIX_PITCH, ROD_LENGTH = 1.5e-3, 0.05, 0.1


def helix_scene(nodes: int, tension: float, **string) -> dict:
    area = math.pi * 4e-6
    return {"name": "stiction-helix", "rods": {"backbone": {
        "length": ROD_LENGTH, "radius": 2e-3, "youngs_modulus": 200e9,
        "stretch_modulus": 200e9, "poisson_ratio": 0.3, "density": 7900.0, "nodes": nodes,
        "clamp": "frame", "terms": ["stretch", "bend_twist", "centerline"],
        "centerline": {"K_P": 200e9 / 2.6 * area}}},
        "tendons": {"a": {"catheter": "backbone", "coupling": "string", "offset": 0.01,
                          "direction": [1.0, 0.0], "tendon_string": {
                              "tension": tension, "routing": "helix",
                              "helix_radius": HELIX_RADIUS, "helix_pitch": HELIX_PITCH,
                              **string}}},
        "solver": {"integrator": "static"}}


def string_term(model: Model) -> TendonString:
    return next(t for t in model.terms if isinstance(t, TendonString))


def helix_turns(nodes: int) -> np.ndarray:
    """θ_0 … θ_{N−2} of the helix polygon through the N nodes of the straight rod, from
    its geometry alone (module docstring): the entry's α + ∠(t_in, t⁺) + ∠(t⁺, u_0) (the
    entry turn leaves the plane of t_in and u_0: split through t⁺ = (3u_0 − u_1)/2,
    rodsim/core/tendon_friction.py) and the equal interior turns."""
    a, rate = HELIX_RADIUS, 2 * math.pi / HELIX_PITCH
    h = ROD_LENGTH / (nodes - 1)
    step = rate * h
    chord2 = 4 * a**2 * math.sin(step / 2) ** 2
    interior = math.acos((chord2 * math.cos(step) + h**2) / (chord2 + h**2))

    def point(s: float) -> np.ndarray:
        return np.array([a * math.cos(rate * s), a * math.sin(rate * s), s])

    def unit(v: np.ndarray) -> np.ndarray:
        return v / np.linalg.norm(v)

    def angle(u: np.ndarray, v: np.ndarray) -> float:
        return math.atan2(float(np.linalg.norm(np.cross(u, v))), float(u @ v))

    u0, u1 = unit(point(h) - point(0.0)), unit(point(2 * h) - point(h))
    tangent = unit(np.array([0.0, a * rate, 1.0]))
    ahead = unit(1.5 * u0 - 0.5 * u1)
    entry = math.atan(a * rate) + angle(tangent, ahead) + angle(ahead, u0)
    return np.concatenate([[entry], np.full(nodes - 2, interior)])


# --- friction_points -------------------------------------------------------------------


def test_friction_points_meet_the_capstan_closed_form_on_a_rigid_helix():
    """One μ per routing point (seeded, 0.05–0.6) on the rigid helix: the chord tensions
    T_0 e^{−Σ μ_j θ_j} with the turns of the helix's closed form, at the rest shape (the
    polygon exactly; round-off) and solved at 1 mN (the rod then twists and bends a little:
    measured 6.8e-12 N = 6.8e-9 T_0 from the same closed form); the termination's."""
    nodes, t0 = 21, 1e-3
    mu = np.random.default_rng(34).uniform(0.05, 0.6, nodes)
    scene = Scene.from_dict(helix_scene(nodes, t0, friction_points=list(mu)))
    model = Model(scene)
    term = string_term(model)
    assert len(term.points.s) == nodes
    closed = t0 * np.exp(-np.cumsum(mu[:-1] * helix_turns(nodes)))
    rod = term.tendon.catheter
    rest = np.zeros(model.full_size)
    rest[rod.layout.position_index] = rod.rest_positions()
    rest[rod.layout.quaternion_index] = rod.rest_quaternions()
    assert np.max(np.abs(term.chord_tensions(rest) - closed)) < 1e-15 * t0 * 10
    result = rodsim.solve(scene)
    assert result.success, result.message
    s, tension = result.tension_profiles["a"]
    assert np.max(np.abs(tension - closed)) < 2e-8 * t0
    # The last chord's tension is the point force the termination takes: T_tip.
    assert tension[-1] == pytest.approx(t0 * math.exp(-float(mu[:-1] @ helix_turns(nodes))),
                                        rel=2e-8)


def test_equal_friction_points_are_the_scalar_friction_to_round_off():
    """friction_points all equal to μ give friction = μ's equilibrium (the wrap summed as
    Σ μ θ_j instead of μ Σ θ_j: round-off), on a catheter the tendon bends."""
    nodes = 15
    data = helix_scene(nodes, 5.0, friction=0.3)
    data["rods"]["backbone"] |= {"youngs_modulus": 54e9, "radius": 0.7e-3,
                                 "centerline": {"K_P": 54e9 / 2.6 * math.pi * 0.49e-6}}
    data["tendons"]["a"]["tendon_string"] |= {"routing": "constant", "spacers": True}
    scalar = rodsim.solve(Scene.from_dict(data))
    data["tendons"]["a"]["tendon_string"]["friction_points"] = [0.3] * nodes
    points = rodsim.solve(Scene.from_dict(data))
    assert scalar.success and points.success
    bend = np.max(np.abs(scalar.positions() - scalar.positions()[:1]))
    assert bend > 1e-3
    assert np.max(np.abs(points.positions() - scalar.positions())) < 1e-9 * bend


def test_friction_points_follow_a_coarser_discretisation():
    """The discretisation estimate re-solves at fewer nodes: each coarse routing point takes
    the μ of the fine point nearest to it, so the coarse scene has its own count."""
    from rodsim.app.discretisation import coarser_scene

    nodes = 21
    mu = [0.1 if k < 10 else 0.4 for k in range(nodes)]
    scene = Scene.from_dict(helix_scene(nodes, 1e-3, friction_points=mu))
    data, counts, _ = coarser_scene(scene, 2.0)
    assert counts == {"backbone": 11}
    coarse = data["tendons"]["a"]["tendon_string"]["friction_points"]
    assert coarse == [0.1] * 5 + [0.4] * 6
    assert string_term(Model(Scene.from_dict(data))).kinetic.shape == (10,)


@pytest.mark.parametrize("values, message", [
    ({"friction_points": [0.1, 0.2]}, "friction_points has 2 values, expected 11"),
    ({"friction_points": [0.1] * 10 + [-0.1]}, "component out of range"),
    ({"friction_points": [0.1] * 10 + [float("nan")]}, "not finite"),
    ({"friction": 0.3, "static_friction": 0.2}, "smaller than the kinetic coefficient"),
    ({"friction_points": [0.1] * 10 + [0.5], "static_friction": 0.4},
     "largest friction_points value"),
    ({"static_friction": -0.2}, "out of range"),
    ({"control": "displacement", "stiffness": 6e3, "friction_points": [0.1] * 11},
     "tension-controlled string only"),
    ({"control": "displacement", "stiffness": 6e3, "static_friction": 0.2},
     "tension-controlled string only"),
])
def test_bad_coefficients_are_one_line(values, message):
    data = helix_scene(11, 1e-3)
    data["tendons"]["a"]["tendon_string"] |= values
    if values.get("control") == "displacement":
        del data["tendons"]["a"]["tendon_string"]["tension"]
    with pytest.raises(SceneError, match=message) as info:
        Model(Scene.from_dict(data))
    assert "\n" not in str(info.value)


def test_bad_coefficients_exit_2_on_the_command_line(tmp_path, capsys):
    from rodsim.app.cli import main

    data = helix_scene(11, 1e-3)
    rod, string = data["rods"]["backbone"], data["tendons"]["a"]["tendon_string"]
    lines = ['name = "stiction-cli"', "[rods.backbone]"]
    lines += [f"{k} = {v!r}" for k, v in rod.items() if k not in ("centerline", "terms",
                                                                  "clamp")]
    lines += ['clamp = "frame"', 'terms = ["stretch", "bend_twist", "centerline"]',
              "[rods.backbone.centerline]", f"K_P = {rod['centerline']['K_P']!r}",
              "[tendons.a]", 'catheter = "backbone"', 'coupling = "string"', "offset = 0.01",
              "[tendons.a.tendon_string]"]
    lines += [f"{k} = {v!r}".replace("'", '"') for k, v in string.items()]
    lines += ["[solver]", 'integrator = "static"', ""]
    scene = tmp_path / "helix.toml"
    scene.write_text("\n".join(lines))
    for override in ("tendons.a.tendon_string.friction_points=[0.1,0.2]",
                     "tendons.a.tendon_string.friction_points=[0.1,-0.2]",
                     "tendons.a.tendon_string.static_friction=0.1"):
        code = main(["run", str(scene), "--set", "tendons.a.tendon_string.friction=0.2",
                     "--set", override, "-o", str(tmp_path / "bad.nc")])
        err = capsys.readouterr().err.strip()
        assert code == 2 and "\n" not in err and "tendons.a.tendon_string" in err, err
