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
from test_tendon_friction import LENGTH, _tip, catheter, model_tip, released
from user_robots import user_rod

import rodsim
from rodsim.core.model import Model
from rodsim.core.program import Table
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


# --- static_friction: the stick/slip law ------------------------------------------------

MU_K, MU_S = 0.2, 0.5


def _helix_track(values: list[float], static: float, nodes: int = 11):
    scene = Scene.from_dict(helix_scene(nodes, values[0], friction=MU_K,
                                        static_friction=static))
    track = rodsim.track(scene, {TENSION: values}, estimates=False)
    assert track.success, track.message
    return track


def _last_states(track) -> np.ndarray:
    term = string_term(track.last_model)
    anchors = term.anchors_at(track.states[-1])
    return anchors[len(term.profile):]


def test_released_the_points_break_loose_one_by_one_and_slide_at_the_kinetic_ratio():
    """Rigid helix pulled in from slack to T_max (every point sliding in), released in one
    step to T_1: each point breaks loose when the tension over it exceeds e^{μ_s θ} with the
    points before it already sliding at μ_k (the step is solved again after each
    breakaway), so chord e falls to T_1 e^{μ_k Θ_e} up to the first point that holds, and
    the termination holds iff T_1 ≥ T_max e^{−2μ_kΘ − (μ_s−μ_k)θ_last} (e^{−2μ_kΘ}
    without stiction): turns from the helix's closed form, either side of the edge by
    0.2 %. The same release in five steps ends on the same tensions."""
    nodes, t_max = 11, 1e-3
    turns = helix_turns(nodes)
    wrap = np.cumsum(turns)
    edge = t_max * math.exp(-2 * MU_K * wrap[-1] - (MU_S - MU_K) * turns[-1])
    for factor, held in ((1.002, True), (0.998, False)):
        t_1 = edge * factor
        track = _helix_track([t_max, t_1], MU_S)
        closed = t_1 * np.exp(MU_K * wrap)
        if held:
            closed[-1] = t_max * math.exp(-MU_K * wrap[-1])
        assert np.max(np.abs(track.tension[-1] - closed)) < 1e-7 * t_max
        assert (track.tension[-1][-1] == track.tension[0][-1]) == held, factor
        states = _last_states(track)
        assert np.all(states[:-1] == 1.0) and states[-1] == (0.0 if held else 1.0)
        steps = _helix_track(list(np.linspace(t_max, t_1, 6)), MU_S)
        assert np.max(np.abs(steps.tension[-1] - track.tension[-1])) < 1e-9 * t_max
    kinetic_edge = t_max * math.exp(-2 * MU_K * wrap[-1])
    for factor, held in ((1.002, True), (0.998, False)):
        kinetic = _helix_track([t_max, kinetic_edge * factor], 0.0)
        assert (kinetic.tension[-1][-1] == kinetic.tension[0][-1]) == held


def test_a_point_that_stuck_holds_up_to_the_static_ratio():
    """Pulled to T_max, released to T_1 at which only the first points slide out, then
    pulled again to T_2: the first point has to break loose inward (μ_s: it slid the other
    way), so the profile holds while T_2 e^{−μ_s θ_0} ≤ τ_0 (its stored tension) and, past
    that, chord 0 slides in at the kinetic ratio, T_2 e^{−μ_k θ_0}; rigid helix."""
    nodes, t_max = 11, 1e-3
    turns = helix_turns(nodes)
    wrap = np.cumsum(turns)
    t_1 = 0.6 * t_max
    track = _helix_track([t_max, t_1], MU_S)
    stored = track.tension[-1]
    # The slip front: the first point e with T_1 ≥ T_max e^{−2μ_kΘ_e − (μ_s−μ_k)θ_e}.
    front = int(np.argmax(t_1 >= t_max * np.exp(-2 * MU_K * wrap - (MU_S - MU_K) * turns)))
    assert 0 < front < len(turns) - 1
    assert np.array_equal(_last_states(track), np.where(np.arange(len(turns)) < front,
                                                        1.0, 0.0))
    assert np.array_equal(stored < track.tension[0], np.arange(len(turns)) < front)
    assert stored[0] == pytest.approx(t_1 * math.exp(MU_K * turns[0]), rel=1e-9)
    edge = stored[0] * math.exp(MU_S * turns[0])
    for factor, moved in ((0.998, False), (1.002, True)):
        again = _helix_track([t_max, t_1, edge * factor], MU_S)
        if moved:
            assert again.tension[-1][0] == pytest.approx(
                edge * factor * math.exp(-MU_K * turns[0]), rel=1e-9)
        else:
            assert np.max(np.abs(again.tension[-1] - stored)) == 0.0


def test_equal_static_and_kinetic_friction_is_the_kinetic_model_bitwise():
    """static_friction = friction (or unset, or 0) takes the kinetic code path: a
    pull–release track's states equal to the last bit."""
    values = [0.5e-3, 1e-3, 0.7e-3, 0.4e-3]
    states = [_helix_track(values, static).states for static in (0.0, MU_K)]
    assert all(np.array_equal(a, b) for a, b in zip(*states, strict=True))
    sticky = _helix_track(values, MU_S).states
    # Pulling on, every point slides in at μ_k: the same equilibrium (to the solver's
    # tolerance: the wrap is summed as Σ μ θ_j on the stiction path).
    assert np.max(np.abs(sticky[1] - states[0][1])) < 1e-8
    assert not np.array_equal(sticky[-1], states[0][-1])


def test_on_a_lumen_stiction_tends_to_the_kinetic_release_at_second_order():
    """The catheter bent by its own tendon (a routing point at every node), pulled to 3 N
    and released in one step to 2.4 N with μ_k = 0.25, μ_s = 0.5: the static excess acts
    only on the turn of the point at the slip front, θ_f = O(h), so the released tip tends
    to the kinetic closed form (slip front s_f = (T_max − T_0) EI/(2 μ_k T_0 T_max ρ)).
    Measured tip error / L 4.7e-5, 1.1e-5, 2.6e-6 at N = 21, 41, 81 (kinetic alone 3.0e-5,
    7.5e-6, 1.9e-6); stiction's own part 2.8e-5, 6.2e-6, 1.3e-6 (order 2.2)."""
    mu_k, mu_s, t_max, t_0 = 0.25, 0.5, 3.0, 2.4
    theta, tension, front = released(mu_k, t_max, t_0)
    reference = _tip(theta, tension, [(0.0, front), (front, LENGTH)])
    errors, parts = [], []
    for n in (21, 41, 81):
        tips = {}
        for static in (0.0, mu_s):
            track = rodsim.track(Scene.from_dict(catheter(n, mu_k, t_max,
                                                          static_friction=static)),
                                 {TENSION: [t_max, t_0]}, estimates=False)
            assert track.success, track.message
            tips[static] = model_tip(track.positions[-1])
        errors.append(float(np.linalg.norm(tips[mu_s] - reference)) / LENGTH)
        parts.append(float(np.linalg.norm(tips[mu_s] - tips[0.0])) / LENGTH)
    assert errors[0] < 6e-5 and errors[1] < 1.5e-5 and errors[2] < 4e-6, errors
    assert parts[2] > 0.0
    assert min(math.log2(parts[0] / parts[1]), math.log2(parts[1] / parts[2])) > 1.8, parts


def stiction_robot(seed: int) -> tuple[dict, float]:
    """A user's robot drawn from ``seed``: a steel wire with a tendon on spacer disks
    (N loads) or a soft polymer catheter with a tendon in a lumen (mN loads), μ_k in
    [0.05, 0.3] and μ_s from 1.2 to 2.5 times it; returns (scene, its tension)."""
    # Seeds 0 … 5 draw steel wires at 1.5, 17.6 and 165 N and polymer catheters at 11 to
    # 106 mN.
    rng = np.random.default_rng(3400 + seed)
    kind = ("steel", "polymer")[seed % 2]
    rod = user_rod(rng, kind, polymer_length=(0.05, 0.15))
    radius, modulus = rod["radius"], rod["youngs_modulus"]
    offset = rng.uniform(3e-3, 8e-3) if kind == "steel" else rng.uniform(0.5, 0.8) * radius
    inertia = math.pi * radius**4 / 4
    scale = modulus * inertia / (offset * rod["length"])  # a tension for about 1 rad
    # Steel: a large bend (about 0.3 to 1 rad, N); polymer: a small one (mN).
    tension = float(scale * (rng.uniform(0.3, 1.0) if kind == "steel"
                             else rng.uniform(0.01, 0.1)))
    mu = float(rng.uniform(0.05, 0.3))
    rod |= {"stretch_modulus": modulus, "nodes": int(rng.integers(11, 26)), "clamp": "frame",
            "terms": ["stretch", "bend_twist", "centerline"],
            "centerline": {"K_P": modulus / 2.6 * math.pi * radius**2}}
    string = {"tension": tension, "spacers": kind == "steel", "friction": mu,
              "static_friction": float(mu * rng.uniform(1.2, 2.5))}
    return {"name": f"stiction-{kind}-{seed}", "rods": {"body": rod},
            "tendons": {"a": {"catheter": "body", "coupling": "string", "offset": offset,
                              "direction": [1.0, 0.0], "tendon_string": string}},
            "solver": {"integrator": "static"}}, tension


@pytest.mark.parametrize("seed", range(6))
def test_user_robots_with_stiction_widen_the_loop_and_pull_as_before(seed):
    """Each robot, a pull–release cycle (0.2 T → T → 0.2 T in 13 steps): the pull (every
    point sliding in) is the kinetic one to the solver's tolerance, the release is bent at
    least as far as with μ_s = μ_k at every tension (stiction holds more tension
    downstream), every point's state is −1, 0 or +1, and μ_s = μ_k is the kinetic model
    bitwise."""
    data, tension = stiction_robot(seed)
    values = list(np.concatenate([np.linspace(0.2, 1.0, 7), np.linspace(1.0, 0.2, 7)[1:]])
                  * tension)
    string = data["tendons"]["a"]["tendon_string"]
    tracks = {}
    for static in (string["static_friction"], string["friction"], 0.0):
        scene = Scene.from_dict(data | {"tendons": {"a": data["tendons"]["a"] | {
            "tendon_string": string | {"static_friction": static}}}})
        tracks[static] = rodsim.track(scene, {TENSION: values}, estimates=False)
        assert tracks[static].success, tracks[static].message
    sticky, kinetic = tracks[string["static_friction"]], tracks[0.0]
    assert all(np.array_equal(a, b) for a, b in zip(tracks[string["friction"]].states,
                                                    kinetic.states, strict=True))
    length = data["rods"]["body"]["length"]
    bend = np.linalg.norm(sticky.positions[:, -1, 1:], axis=1)
    plain = np.linalg.norm(kinetic.positions[:, -1, 1:], axis=1)
    assert np.max(np.abs(bend[:7] - plain[:7])) < 1e-7 * length
    assert np.all(bend[7:] >= plain[7:] - 1e-7 * length)
    states = _last_states(sticky)
    assert set(np.unique(states)) <= {-1.0, 0.0, 1.0}


def test_simulate_carries_the_stick_slip_state():
    """A run in physical time released from 3 N to 2.4 N in 0.03 s (the self-bent catheter,
    N = 11, damped): with μ_s = μ_k it is the kinetic run bitwise; with μ_s = 0.5 (points
    that stop while the catheter moves must break loose again) it ends 19 µm (9.6e-5 L) from
    the kinetic run at these 5 ms steps (37 µm before the breakaways were located inside the
    steps), where one track step from 3 to 2.4 N ends on the kinetic shape (7e-13 m: the
    same points break loose, the held ones keep their tensions either way)."""
    def run(static: float) -> np.ndarray:
        raw = catheter(11, 0.25, 3.0, static_friction=static)
        raw["rods"]["backbone"]["damping"] = {"retardation_time": 6e-3}
        release = Table((0.0, 0.03), (3.0, 2.4))
        out = rodsim.simulate(Scene.from_dict(raw), 0.03, output_dt=0.03, step=5e-3,
                              initial={TENSION: 3.0}, program={TENSION: release})
        assert out.success, out.message
        return out.positions[-1]

    kinetic = run(0.0)
    assert np.array_equal(run(0.25), kinetic)
    sticky = run(0.5)
    gap = float(np.linalg.norm(sticky[-1] - kinetic[-1]))
    assert 0.0 < gap < 1e-3 * LENGTH


def test_the_compiled_kernel_takes_the_points_coefficients_and_states(random_state, fd):
    """At a random 3-D state of the self-bent catheter (N = 9) with a μ per point and
    stiction, under a history that sticks on part of the path and slides either way on the
    rest: the compiled kernel's force and Jacobian equal the numpy reference's; on a planar
    one-way path pulled in and released (μ_k = 0.3, μ_s = 0.5: points 0 … 6 break loose and
    slide out at μ_k, the rest hold) the Jacobian at the equilibrium is the finite
    differences'."""
    rng = np.random.default_rng(34)
    string = {"friction_points": list(rng.uniform(0.1, 0.4, 9)), "static_friction": 0.6}
    models = {kernels: Model(Scene.from_dict(catheter(9, 0.0, 2.0, **string) | {
        "solver": {"integrator": "static", "kernels": kernels}}))
        for kernels in ("numpy", "compiled")}
    x = random_state(models["numpy"], rng)
    full = models["numpy"].full(x)
    pulled_in = string_term(models["numpy"]).chord_tensions(full)
    chords = len(pulled_in)
    history = np.concatenate([pulled_in * np.where(np.arange(chords) % 3 == 0, 0.8, 1.1),
                              np.resize([-1.0, 0.0, 1.0, 1.0], chords)])
    models = {k: m.with_terms([t.anchored(history) if isinstance(t, TendonString) else t
                               for t in m.terms]) for k, m in models.items()}
    term = string_term(models["numpy"])
    assert term.sticky and term.weighted
    assert not np.array_equal(term._mu_in, term._mu_out)
    slipping = term.chord_tensions(full) != term.profile
    assert 0 < np.sum(slipping) < chords
    force = models["numpy"].force(x)
    jacobian = models["numpy"].jacobian(x).toarray()
    assert np.max(np.abs(models["compiled"].force(x) - force)) < 1e-12 * np.max(np.abs(force))
    assert np.max(np.abs(models["compiled"].jacobian(x).toarray() - jacobian)) < 1e-11 * (
        np.max(np.abs(jacobian)))
    for kernels in ("numpy", "compiled"):
        data = catheter(11, 0.3, 3.0, static_friction=0.5)
        data["solver"]["kernels"] = kernels
        track = rodsim.track(Scene.from_dict(data), {TENSION: [3.0, 2.4]}, estimates=False)
        assert track.success
        model = track.last_model
        x = model.state_of(track.states[-1])  # the released equilibrium
        term = string_term(model)
        assert np.array_equal(term.state, np.where(np.arange(10) < 7, 1.0, -1.0))
        numeric = fd["jacobian"](model.force, x, fd["steps"](model, 1e-6))
        error = np.max(np.abs(model.jacobian(x).toarray() - numeric))
        assert error < 1e-8 * np.max(np.abs(numeric)), (kernels, error)
