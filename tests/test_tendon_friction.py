"""Friction between a string tendon and its routing (rodsim/core/tendon_friction.py; issue 34)
against closed forms derived in docs/tendon.md, "Friction".

- A catheter bent by its own tendon (planar, constant offset ρ, tension T0 at the base):
  the internal moment at s is T(s) ρ (cut the catheter and the tendon at s), so
  dΘ/ds = T ρ / EI and, sliding, dT/dΘ = −μ T. Pulled in from slack:
  T(s) = T0 / (1 + μ T0 ρ s / EI), Θ(s) = ln(1 + μ T0 ρ s / EI) / μ. Released from T_max
  to T0: the tendon slides outward up to the slip front
  s_f = (T_max − T0) EI / (2 μ T0 T_max ρ), where T(s) = T0 / (1 − μ T0 ρ s / EI); beyond
  it the pulled profile holds. The tip is the quadrature of (1 − T/EA)(cos Θ, sin Θ).
- A tendon on a rigid helix (a stiff straight rod): the wrap from the actuator to the path's
  arc length l is α + κ_h l (α the entry's turn from the axis), T = T0 e^{−μ(α + κ_h l)}.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from scipy.integrate import quad

import rodsim
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.core.terms._string_friction_coupling import one_way_coupling
from rodsim.core.terms.tendon_string import TendonString

#: The benchmark backbone (nitinol, r = 0.7 mm, 0.2 m) with a tendon on spacer disks 10 mm off.
E, RADIUS, LENGTH, OFFSET = 54e9, 0.7e-3, 0.2, 0.01
AREA, INERTIA = math.pi * RADIUS**2, math.pi * RADIUS**4 / 4
EI, EA = E * INERTIA, E * AREA
TENSION = "tendons.a.tendon_string.tension"


def catheter(nodes: int, friction: float, tension: float, **string) -> dict:
    return {"name": "friction-case", "rods": {"backbone": {
        "length": LENGTH, "radius": RADIUS, "youngs_modulus": E, "stretch_modulus": E,
        "poisson_ratio": 0.3, "density": 6450.0, "nodes": nodes, "clamp": "frame",
        "terms": ["stretch", "bend_twist", "centerline"],
        "centerline": {"K_P": E / 2.6 * AREA}}},
        "tendons": {"a": {"catheter": "backbone", "coupling": "string", "offset": OFFSET,
                          "direction": [1.0, 0.0], "tendon_string": {
                              "tension": tension, "spacers": True, "friction": friction,
                              **string}}},
        "solver": {"integrator": "static"}}


def string_term(model: Model) -> TendonString:
    return next(t for t in model.terms if isinstance(t, TendonString))


def _tip(theta, tension, pieces) -> np.ndarray:
    """∫ (1 − T/EA)(sin Θ, cos Θ) ds over ``pieces`` (lateral, axial)."""
    out = np.zeros(2)
    for a, b in pieces:
        for k, f in enumerate((math.sin, math.cos)):
            out[k] += quad(lambda s, f=f: (1 - tension(s) / EA) * f(theta(s)), a, b,
                           epsabs=1e-15, epsrel=1e-13)[0]
    return out


def pulled(mu: float, t0: float):
    """(Θ(s), T(s)) pulled in from slack (module docstring)."""
    c = mu * t0 * OFFSET / EI
    return (lambda s: math.log1p(c * s) / mu), (lambda s: t0 / (1 + c * s))


def pulled_tip(mu: float, t0: float) -> np.ndarray:
    theta, tension = pulled(mu, t0)
    return _tip(theta, tension, [(0.0, LENGTH)])


def released(mu: float, t_max: float, t0: float):
    """(Θ(s), T(s), s_f) released from t_max to t0 (module docstring)."""
    front = min((t_max - t0) * EI / (2 * mu * t0 * t_max * OFFSET), LENGTH)
    c = mu * t0 * OFFSET / EI
    theta_old, tension_old = pulled(mu, t_max)
    slip = lambda s: -math.log1p(-c * s) / mu  # noqa: E731

    def theta(s):
        return slip(s) if s <= front else slip(front) + theta_old(s) - theta_old(front)

    def tension(s):
        return t0 / (1 - c * s) if s <= front else tension_old(s)
    return theta, tension, front


def model_tip(positions: np.ndarray) -> np.ndarray:
    return np.array([positions[-1, 1], positions[-1, 0]])  # (lateral, axial)


def test_pulled_catheter_meets_the_closed_form_at_second_order():
    """Tip of the self-bent catheter pulled from straight (μ = 0.2, 3 N: a 32° bend) against
    the closed form, the chord tensions against T(s) at the chords' midpoints, and the
    termination's tension against the wrap measured on the state."""
    mu, t0 = 0.2, 3.0
    reference = pulled_tip(mu, t0)
    errors = {}
    for n in (21, 41, 81):
        scene = Scene.from_dict(catheter(n, mu, t0))
        result = rodsim.solve(scene)
        assert result.success, result.message
        errors[n] = float(np.linalg.norm(model_tip(result.positions()) - reference)) / LENGTH
        s, tension = result.tension_profiles["a"]
        expected = np.array([pulled(mu, t0)[1](v) for v in s])
        assert np.max(np.abs(tension - expected)) < 2.0 / n**2 * t0
        # Termination tension = T0 e^{−μΘ}, Θ the sum of the turns measured on the state.
        model = Model(scene)
        term = string_term(model)
        full = model.full(result.state)
        path = term.path(full)
        chords = np.diff(path, axis=0)
        chords /= np.linalg.norm(chords, axis=1)[:, None]
        rest = term.tendon.catheter.rest_positions()
        entry = rest[1] - rest[0]  # the clamped base frame's d3
        turns = [math.acos(min(1.0, float(a @ b))) for a, b in zip(
            np.vstack([entry / np.linalg.norm(entry), chords[:-1]]), chords, strict=True)]
        assert tension[-1] == pytest.approx(t0 * math.exp(-mu * sum(turns)), rel=1e-12)
    orders = [math.log2(errors[a] / errors[b]) for a, b in ((21, 41), (41, 81))]
    assert errors[41] < 1e-4 and min(orders) > 1.8, (errors, orders)


def test_tip_moment_is_the_termination_tension_times_the_offset():
    """The bending moment of the last element, E I κ, is T_tip ρ (to O(h))."""
    mu, t0, n = 0.3, 2.0, 81
    scene = Scene.from_dict(catheter(n, mu, t0))
    result = rodsim.solve(scene)
    r = result.positions()
    h = LENGTH / (n - 1)
    t1, t2 = r[-2] - r[-3], r[-1] - r[-2]
    kappa = math.atan2(np.linalg.norm(np.cross(t1, t2)), t1 @ t2) / h
    moment = EI * kappa
    tip_tension = result.tension_profiles["a"][1][-1]
    assert moment == pytest.approx(tip_tension * OFFSET, rel=2e-2)
    assert tip_tension == pytest.approx(pulled(mu, t0)[1](LENGTH), rel=2e-2)


def _pull_release(n: int, mu: float, up: np.ndarray, down: np.ndarray):
    values = np.concatenate([up, down])
    track = rodsim.track(Scene.from_dict(catheter(n, mu, float(up[0]))), {TENSION: values},
                         estimates=False)
    assert track.success, track.message
    return values, track


def test_release_meets_the_closed_form_and_its_slip_front():
    """Pulled to 3 N then released in steps: every released tip against the closed form
    with the slip front s_f, and the front's position within one segment."""
    mu, t_max, n = 0.25, 3.0, 41
    up, down = np.linspace(0.5, t_max, 6), np.linspace(2.7, 1.5, 5)
    values, track = _pull_release(n, mu, up, down)
    h = LENGTH / (n - 1)
    for k, t0 in enumerate(values):
        if k < len(up):
            reference = pulled_tip(mu, t0)
        else:
            theta, tension, front = released(mu, t_max, t0)
            reference = _tip(theta, tension, [(0.0, front), (front, LENGTH)])
            profile = track.tension[k]
            stuck = np.isclose(profile, track.tension[len(up) - 1], rtol=1e-12, atol=0)
            first_stuck = track.chords["a"][np.argmax(stuck)] if stuck.any() else LENGTH
            assert abs(first_stuck - front) <= h, (t0, first_stuck, front)
        error = float(np.linalg.norm(model_tip(track.positions[k]) - reference)) / LENGTH
        assert error < 2e-5, (k, t0, error)


def test_pull_release_hysteresis_and_the_dead_zone():
    """The same tension gives a larger bend on release; after the reversal the termination's
    tension holds while T0 > T_tip e^{−μΘ} and changes below (Θ the total wrap on the
    state), so the dead zone spans T_max e^{−μ(Θ_max + Θ)}: e^{2μΘ} on a rigid path."""
    mu, t_max, n = 0.2, 3.0, 41
    up = np.linspace(0.5, t_max, 11)
    down = np.linspace(t_max, 0.5, 11)[1:]
    values, track = _pull_release(n, mu, up, down)
    tips = track.tips()[:, 1]
    for t0 in values[1:len(up) - 1]:
        pull = tips[np.flatnonzero(np.isclose(values, t0))[0]]
        release = tips[np.flatnonzero(np.isclose(values, t0))[-1]]
        assert release - pull > 1e-3 * LENGTH
    model = Model(Scene.from_dict(catheter(n, mu, t_max)))
    term = string_term(model)
    top = track.tension[len(up) - 1][-1]
    for k in range(len(up), len(values)):
        wrap = float(np.sum(term.turning_angles(track.states[k])))
        held = track.tension[k][-1] == top
        assert held == (values[k] * math.exp(mu * wrap) >= top), (k, values[k])
    released = range(len(up), len(values))
    dead = [values[k] for k in released if track.tension[k][-1] == top]
    moved = [values[k] for k in released if track.tension[k][-1] != top]
    closed_edge = t_max / (1 + 2 * mu * t_max * OFFSET * LENGTH / EI)  # 2.428 N
    assert max(moved) < closed_edge <= min(dead)
    # The track reports the released steps above the closed form's edge as its dead zone,
    # and no step of the pull (each moves the termination).
    assert track.dead_zone_steps == [k for k in released if values[k] >= closed_edge]


def helix_scene(nodes: int, friction: float, tension: float) -> dict:
    scene = catheter(nodes, friction, tension, routing="helix", helix_radius=1.5e-3,
                     helix_pitch=0.05, spacers=False)
    scene["rods"]["backbone"] |= {"radius": 2e-3, "youngs_modulus": 200e9,
                                  "stretch_modulus": 200e9, "length": 0.1,
                                  "centerline": {"K_P": 200e9 / 2.6 * math.pi * 4e-6}}
    return scene


def helix_wrap(s: np.ndarray) -> np.ndarray:
    """α + κ_h l(s) on the helix of radius a, pitch p: tan α = a φ′, φ′ = 2π/p."""
    a, rate = 1.5e-3, 2 * math.pi / 0.05
    slope = a * rate
    return math.atan(slope) + a * rate**2 / (1 + slope**2) * s * math.sqrt(1 + slope**2)


def test_capstan_on_a_rigid_helix_and_the_hold_range():
    """A tendon on a helix around a stiff steel rod (0.1 N: rigid): each chord's tension
    T0 e^{−μ(α + κ_h l)} at its midpoint, converging at second order; released, the
    termination holds its tension down to T_max e^{−2μΘ} and not below."""
    mu = 0.3
    errors = {}
    for n in (21, 41, 81):
        result = rodsim.solve(Scene.from_dict(helix_scene(n, mu, 0.1)))
        s, tension = result.tension_profiles["a"]
        errors[n] = float(np.max(np.abs(tension / 0.1 - np.exp(-mu * helix_wrap(s)))))
    orders = [math.log2(errors[a] / errors[b]) for a, b in ((21, 41), (41, 81))]
    assert errors[81] < 1e-3 and min(orders) > 1.8, (errors, orders)
    scene = Scene.from_dict(helix_scene(41, mu, 0.1))
    term = string_term(Model(scene))
    track = rodsim.track(scene, {TENSION: [0.1, 1.0]}, estimates=False)
    wrap = float(np.sum(term.turning_angles(track.states[-1])))
    edge = 1.0 * math.exp(-2 * mu * wrap)
    top = track.tension[-1][-1]
    for factor, held in ((1.002, True), (0.998, False)):
        again = rodsim.track(scene, {TENSION: [0.1, 1.0, edge * factor]}, estimates=False)
        assert again.success
        assert (again.tension[-1][-1] == pytest.approx(top, rel=1e-9)) == held, factor


def test_zero_friction_is_the_frictionless_tendon_bitwise_and_small_friction_tends_to_it():
    base = catheter(31, 0.0, 2.0)
    without = copy.deepcopy(base)
    del without["tendons"]["a"]["tendon_string"]["friction"]
    a = rodsim.solve(Scene.from_dict(base))
    b = rodsim.solve(Scene.from_dict(without))
    assert np.array_equal(a.state, b.state) and not a.tension_profiles
    gaps = [np.max(np.abs(rodsim.solve(Scene.from_dict(catheter(31, mu, 2.0))).positions()
                          - a.positions())) for mu in (1e-2, 1e-3, 1e-4)]
    assert gaps[0] > 0.0
    assert gaps[1] / gaps[0] == pytest.approx(0.1, rel=0.05)
    assert gaps[2] / gaps[1] == pytest.approx(0.1, rel=0.05)


def _scatter(model: Model, term: TendonString, values: np.ndarray) -> np.ndarray:
    index = np.full(model.full_size, -1)
    index[model.free] = np.arange(model.n)
    target = index[term.dofs]
    if values.ndim == 2:
        keep = target >= 0
        return np.bincount(target[keep], weights=values[keep], minlength=model.n)
    out = np.zeros((model.n, model.n))
    rows = np.broadcast_to(target[:, :, None], values.shape)
    cols = np.broadcast_to(target[:, None, :], values.shape)
    keep = (rows >= 0) & (cols >= 0)
    np.add.at(out, (rows[keep], cols[keep]), values[keep])
    return out


def test_kernel_matches_the_reference_and_the_jacobian_off_one_way_paths(random_state, fd):
    """At a random (3-D) state with the history of another (sticking on part of the path,
    slipping on the rest) the compiled kernel's force and Jacobian equal the numpy
    reference's; the Jacobian is the derivative of the force at frozen chord tensions
    (finite differences) plus the one-way coupling, which only the first chord (whose wrap
    is always ∠(d3, u_0)) keeps off a planar one-way path."""
    rng = np.random.default_rng(3)
    models = {kernels: Model(Scene.from_dict(catheter(9, 0.3, 2.0) | {
        "solver": {"integrator": "static", "kernels": kernels}}))
        for kernels in ("numpy", "compiled")}
    x = random_state(models["numpy"], rng)
    full = models["numpy"].full(x)
    pulled_in = string_term(models["numpy"]).chord_tensions(full)
    history = pulled_in * np.where(np.arange(len(pulled_in)) % 3 == 0, 0.8, 1.1)
    models = {k: m.with_terms([t.anchored(history) if isinstance(t, TendonString) else t
                               for t in m.terms]) for k, m in models.items()}
    term = string_term(models["numpy"])
    slipping = term.chord_tensions(full) != term.profile
    assert 0 < np.sum(slipping) < len(slipping)  # both regimes are exercised
    assert not models["numpy"].conservative
    force = models["numpy"].force(x)
    jacobian = models["numpy"].jacobian(x).toarray()
    scale = np.max(np.abs(force))
    assert np.max(np.abs(models["compiled"].force(x) - force)) < 1e-12 * scale
    assert np.max(np.abs(models["compiled"].jacobian(x).toarray() - jacobian)) < 1e-11 * (
        np.max(np.abs(jacobian)))
    model = models["numpy"]
    tension = term.chord_tensions(full)
    unit = copy.copy(term)
    unit.friction, unit.tension = 0.0, 1.0  # each chord's force at unit tension

    def frozen(y: np.ndarray) -> np.ndarray:
        return _scatter(model, term, unit.element_forces(model.full(y)) * tension[:, None])

    geometry, u, length = term._chords(full)
    jd = np.concatenate([-geometry.jac[:-1], geometry.jac[1:]], axis=2)
    coupling = one_way_coupling(term, full, u, length, jd)
    assert np.any(coupling[0]) and not np.any(coupling[1:])
    analytic = _scatter(model, term, term.element_jacobians(full) - coupling)
    numeric = fd["jacobian"](frozen, x, fd["steps"](model, 1e-6))
    assert np.max(np.abs(analytic - numeric)) < 1e-6 * np.max(np.abs(analytic))
    assert np.max(np.abs(_scatter(model, term, term.element_forces(full))
                         - frozen(x))) < 1e-12 * np.max(np.abs(frozen(x)))


def test_with_exact_jacobian_the_jacobian_is_exact_off_one_way_paths(random_state, fd):
    """With ``exact_jacobian``, at the same random (3-D) state with the history of another
    (sticking on part of the path, slipping on the rest) the compiled kernel's force and
    Jacobian equal the numpy reference's, and the Jacobian is the derivative of the force
    (central differences, steps 1e-7), the coupling of every sliding chord's tension to
    every turn up to it included (rodsim/core/turn_gradient.py). Measured 3.1e-10 of its
    largest entry; without the option the Jacobian is the frozen-tension one plus the first
    chord's own (above)."""
    rng = np.random.default_rng(3)
    models = {kernels: Model(Scene.from_dict(catheter(9, 0.3, 2.0, exact_jacobian=True) | {
        "solver": {"integrator": "static", "kernels": kernels}}))
        for kernels in ("numpy", "compiled")}
    x = random_state(models["numpy"], rng)
    full = models["numpy"].full(x)
    pulled_in = string_term(models["numpy"]).chord_tensions(full)
    history = pulled_in * np.where(np.arange(len(pulled_in)) % 3 == 0, 0.8, 1.1)
    models = {k: m.with_terms([t.anchored(history) if isinstance(t, TendonString) else t
                               for t in m.terms]) for k, m in models.items()}
    term = string_term(models["numpy"])
    slipping = term.chord_tensions(full) != term.profile
    assert 0 < np.sum(slipping) < len(slipping)  # both regimes are exercised
    assert not models["numpy"].conservative
    force = models["numpy"].force(x)
    jacobian = models["numpy"].jacobian(x).toarray()
    scale = np.max(np.abs(force))
    assert np.max(np.abs(models["compiled"].force(x) - force)) < 1e-12 * scale
    assert np.max(np.abs(models["compiled"].jacobian(x).toarray() - jacobian)) < 1e-11 * (
        np.max(np.abs(jacobian)))
    model = models["numpy"]

    def tendon_force(y: np.ndarray) -> np.ndarray:
        return _scatter(model, term, term.element_forces(model.full(y)))

    analytic = _scatter(model, term, term.element_jacobians(full))
    numeric = fd["jacobian"](tendon_force, x, fd["steps"](model, 1e-7))
    error = np.max(np.abs(analytic - numeric)) / np.max(np.abs(analytic))
    assert error < 1e-7, error


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_the_jacobian_is_exact_on_a_planar_one_way_path(kernels, fd):
    """A tendon bending its catheter from a clamped base, pulled (sliding in everywhere)
    and then released part-way (sliding out near the base, stuck beyond): the model's
    Jacobian equals the finite differences of its force, friction's coupling included."""
    data = catheter(11, 0.3, 3.0)
    data["solver"]["kernels"] = kernels
    track = rodsim.track(Scene.from_dict(data), {TENSION: [3.0, 2.4]}, estimates=False)
    assert track.success
    model = track.last_model
    for state in track.states:
        x = model.state_of(state)
        jacobian = model.jacobian(x).toarray()
        numeric = fd["jacobian"](model.force, x, fd["steps"](model, 1e-6))
        assert np.max(np.abs(jacobian - numeric)) < 1e-8 * np.max(np.abs(numeric))


@pytest.mark.parametrize("values, message", [
    ({"friction": -0.1}, "friction"),
    ({"friction": float("nan")}, "not finite"),
    ({"friction": float("inf")}, "friction"),
    ({"friction": 0.2, "control": "displacement", "stiffness": 6e3, "tension": 1.0,
      "static_friction": 0.3}, "tension-controlled string only"),
])
def test_bad_friction_is_one_line(values, message):
    scene = catheter(11, 0.0, 1.0)
    scene["tendons"]["a"]["tendon_string"] |= values
    if values.get("control") == "displacement":
        del scene["tendons"]["a"]["tendon_string"]["tension"]
    with pytest.raises(SceneError, match=message) as info:
        Scene.from_dict(scene)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("where", ["tendon", "tendon_actuation"])
def test_friction_on_a_rod_tendon_is_one_line_naming_the_string(where):
    """The rod tendons (couplings paper, conserving) have no friction: a scene file that
    sets it on their table or on their actuation term gets one line saying where friction
    is (docs/tendon.md, "Friction": why the rod tendons are left out)."""
    import tomllib
    from pathlib import Path

    data = tomllib.loads((Path(__file__).parents[1] / "data" / "table3-catheter1.toml")
                         .read_text())
    table = data["tendons"]["tendon"]
    (table if where == "tendon" else table["tendon_actuation"])["friction"] = 0.2
    with pytest.raises(SceneError, match="friction is a key of tendons.<name>.tendon_string "
                       "only") as info:
        Scene.from_dict(data)
    assert "\n" not in str(info.value)


def user_robot(seed: int) -> tuple[dict, str]:
    """A user's robot as docs/tendon.md describes it, drawn from ``seed``: a TDCR on spacer
    disks (steel or nitinol backbone, N loads), a soft polymer catheter with lumens (mN
    to 0.5 N) or a nitinol tube, one to three tendons; returns (scene, first tendon)."""
    rng = np.random.default_rng(seed)
    kind = ("tdcr", "soft", "nitinol")[seed % 3]
    if kind == "tdcr":
        modulus = float(rng.choice([54e9, 200e9]))
        radius, length = rng.uniform(0.4e-3, 0.8e-3), rng.uniform(0.1, 0.3)
        offset, spacers = rng.uniform(4e-3, 1e-2), True
        scale = modulus * math.pi * radius**4 / 4 / (offset * length)  # T for 1 rad
    elif kind == "soft":
        modulus = rng.uniform(5e6, 5e7)
        radius, length = rng.uniform(1e-3, 2e-3), rng.uniform(0.05, 0.15)
        offset, spacers = rng.uniform(0.5, 0.8) * radius, False
        scale = modulus * math.pi * radius**4 / 4 / (offset * length)
    else:
        modulus, radius, length = 60e9, rng.uniform(0.5e-3, 1e-3), rng.uniform(0.05, 0.1)
        offset, spacers = rng.uniform(0.5, 0.8) * radius, False
        scale = modulus * math.pi * radius**4 / 4 / (offset * length)
    area = math.pi * radius**2
    tendons = {}
    for k in range(int(rng.integers(1, 4))):
        angle = 2 * math.pi * k / 3 + rng.uniform(-0.3, 0.3)
        tendons[f"t{k}"] = {
            "catheter": "body", "coupling": "string", "offset": offset,
            "direction": [math.cos(angle), math.sin(angle)],
            "tendon_string": {"tension": float(scale * rng.uniform(0.3, 1.0) / (k + 1)),
                              "spacers": spacers,
                              "friction": float(rng.uniform(0.0, 0.3))}}
    scene = {"name": f"user-{kind}-{seed}", "rods": {"body": {
        "length": length, "radius": radius, "youngs_modulus": modulus,
        "stretch_modulus": modulus, "poisson_ratio": 0.3, "density": 1100.0,
        "nodes": int(rng.integers(15, 31)), "clamp": "frame",
        "terms": ["stretch", "bend_twist", "centerline"],
        "centerline": {"K_P": modulus / 2.6 * area}}},
        "tendons": tendons, "solver": {"integrator": "static"}}
    return scene, "t0"


@pytest.mark.parametrize("seed", range(6))
def test_user_robots_with_friction_converge_and_tend_to_the_frictionless_solution(seed):
    """Each robot: a cold solve with its μ in [0, 0.3] converges, a pull–release cycle of its
    first tendon converges and ends bent further than the pull at the same tension (μ > 0),
    and μ → 0 (every tendon's μ scaled by 1e-2, 1e-3) tends to the frictionless shape
    linearly in μ."""
    data, first = user_robot(seed)
    scene = Scene.from_dict(data)
    tension = data["tendons"][first]["tendon_string"]["tension"]
    result = rodsim.solve(scene)
    assert result.success, result.message
    key = f"tendons.{first}.tendon_string.tension"
    track = rodsim.track(scene, {key: [tension, 1.5 * tension, tension]}, estimates=False)
    assert track.success, track.message
    bend = np.linalg.norm(track.positions[:, -1] - track.positions[0, -1][None, :], axis=1)
    assert bend[1] > 0.0
    frictions = {t: v["tendon_string"]["friction"] for t, v in data["tendons"].items()}
    # Released back to its tension, the tip stays off its pulled place (measured: 2 to 30 %
    # of the pull's travel for μ from 0.02 to 0.26).
    assert bend[2] > 0.2 * frictions[first] * bend[1], "no hysteresis"

    def shape(factor: float) -> np.ndarray:
        values = {f"tendons.{t}.tendon_string.friction": mu * factor
                  for t, mu in frictions.items()}
        out = rodsim.solve(scene.with_values(values))
        assert out.success, out.message
        return out.positions()

    frictionless = shape(0.0)
    gaps = [np.max(np.abs(shape(f) - frictionless)) for f in (1e-2, 1e-3)]
    assert gaps[1] < 0.12 * gaps[0] + 1e-12 * data["rods"]["body"]["length"]


def test_the_tension_profile_is_archived_for_a_run_and_a_track(tmp_path):
    """A run's archive and a track's hold ``tension_profile`` (per chord; per step and chord)
    with its chords' arc lengths and tendons, and the history a cold solve assumes; both
    read back through the archive checks. Without friction neither has them."""
    from rodsim.io.archive import read_dataset, write_content, write_dataset
    from rodsim.io.run_dataset import run_content

    scene = Scene.from_dict(catheter(21, 0.2, 3.0))
    result = rodsim.solve(scene)
    write_content(run_content(result), tmp_path / "run.nc")
    run = read_dataset(tmp_path / "run.nc")
    np.testing.assert_array_equal(run["tension_profile"].values, result.tension_profiles["a"][1])
    assert run["chord_s"].values[0] == pytest.approx(LENGTH / 40)
    assert set(run["chord_tendon"].values) == {"a"}
    assert "pulled in from slack" in run.attrs["friction_history"]
    track = rodsim.track(scene, {TENSION: [3.0, 1.0, 2.0]}, estimates=False)
    write_dataset(track.to_xarray(), tmp_path / "track.nc")
    stored = read_dataset(tmp_path / "track.nc")
    assert stored["tension_profile"].dims == ("step", "chord")
    np.testing.assert_array_equal(stored["tension_profile"].values, np.array(track.tension))
    assert "step 0" in stored.attrs["friction_history"]
    plain = rodsim.solve(Scene.from_dict(catheter(21, 0.0, 3.0)))
    assert "tension_profile" not in run_content(plain).data_vars
    # Both figures draw the tension: along the tendon (run), at the termination (track).
    import matplotlib.pyplot as plt

    from rodsim.app.figures.plot import draw_figure
    for archive, title in ((run, "tension along the tendons (friction)"),
                           (stored, "termination tension (friction)")):
        figure = draw_figure(archive)
        panel = next(ax for ax in figure.axes if ax.get_title() == title)
        assert np.allclose(panel.lines[0].get_ydata(), archive["tension_profile"].values[
            ..., -1] if archive is stored else archive["tension_profile"].values)
        plt.close(figure)


@pytest.mark.parametrize("integrator, options", [
    ("cvode", {}), ("ida", {}), ("paper", {"ramp_steps": 20})])
def test_every_integrator_reaches_the_static_equilibrium_with_friction(integrator, options):
    """The pseudo-dynamics (CVODE, IDA) and the paper's Euler steps reach static's
    equilibrium of a friction scene. The paper's integrator needs its load ramped: with
    friction the model has no energy for its line search, and its full-load first step
    from rest does not converge (measured: residual stuck at 1 for μ = 0.05 and 0.2; its
    failure message says to ramp)."""
    data = catheter(31, 0.2, 3.0)
    reference = rodsim.solve(Scene.from_dict(data), "static")
    data["solver"] = {"integrator": integrator, integrator: options}
    result = rodsim.solve(Scene.from_dict(data))
    assert result.success, result.message
    assert np.max(np.abs(result.positions() - reference.positions())) < 1e-6 * LENGTH
    if integrator == "paper":
        del data["solver"]["paper"]
        plain = rodsim.solve(Scene.from_dict(data))
        assert plain.success or "ramp_steps" in plain.message  # the advice it gets


def toml_scene(folder, tension: float):
    """The friction catheter (21 nodes, μ = 0.2) as a user's TOML file."""
    scene = folder / "friction.toml"
    scene.write_text("\n".join([
        'name = "friction-cli"', "[rods.backbone]", f"length = {LENGTH}",
        f"radius = {RADIUS}", f"youngs_modulus = {E}", f"stretch_modulus = {E}",
        "density = 6450.0", "nodes = 21",
        'terms = ["stretch", "bend_twist", "centerline"]',
        "[rods.backbone.centerline]", f"K_P = {E / 2.6 * AREA}",
        "[tendons.a]", 'catheter = "backbone"', 'coupling = "string"', f"offset = {OFFSET}",
        "[tendons.a.tendon_string]", f"tension = {tension}", "spacers = true",
        "friction = 0.2", "[solver]", 'integrator = "static"', ""]))
    return scene


def test_a_cold_run_says_which_history_it_assumed(tmp_path, capsys):
    """`rodsim run` of a friction scene prints the tension past the entry and at the
    termination with the history it assumed; the verdict of its equilibrium is given."""
    from rodsim.app.cli import main

    scene = toml_scene(tmp_path, 3.0)
    assert main(["run", str(scene), "-o", str(tmp_path / "out.nc")]) == 0
    out = capsys.readouterr().out
    line = next(text for text in out.splitlines() if text.startswith("tension"))
    assert "history: pulled in from slack, monotonically" in line
    termination = float(line.split(",")[1].split()[0])
    assert termination == pytest.approx(pulled(0.2, 3.0)[1](LENGTH), rel=1e-2)
    assert "stability   stable" in out
    assert main(["run", str(scene), "--set", "tendons.a.tendon_string.friction=-0.5",
                 "-o", str(tmp_path / "bad.nc")]) == 2


def test_a_ramp_with_legs_is_a_pull_release_cycle_on_the_command_line(tmp_path, capsys):
    """``--ramp KEY=START:STOP:COUNT:STOP:COUNT`` goes up and back down; its archive holds
    the loop (the same tension, a larger bend on the way back). Bad legs are one line."""
    from rodsim.app.cli import main
    from rodsim.app.inverse.ramps import parse_ramp
    from rodsim.io.archive import read_dataset

    key, values = parse_ramp(f"{TENSION}=0.5:3:6:0.5:5")
    assert key == TENSION
    np.testing.assert_allclose(values, [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 2.5, 2.0, 1.5, 1.0, 0.5])
    np.testing.assert_array_equal(parse_ramp("x=0:4:101")[1], np.linspace(0, 4, 101))
    for bad in ("x=0:1:5:2", "x=0:1:5:2:0", "x=0:1:1", "x=0:1:5:nan:3"):
        with pytest.raises(SceneError, match="--ramp"):
            parse_ramp(bad)
    scene = toml_scene(tmp_path, 0.5)
    archive = tmp_path / "cycle.nc"
    assert main(["track", str(scene), "--ramp", f"{TENSION}=0.5:3:6:0.5:5",
                 "-o", str(archive)]) == 0
    ds = read_dataset(archive)
    lateral = ds["position"].values[:, -1, 1]
    assert ds.sizes["step"] == 11 and lateral[6] > lateral[4] + 1e-3 * LENGTH
    # Released from 3 N, the termination holds down to the closed form's edge (2.43 N at
    # μ = 0.2, docs/tendon.md): step 6 (2.5 N) is in the dead zone, step 7 (2 N) is not.
    line = next(t for t in capsys.readouterr().out.splitlines() if t.startswith("dead zone"))
    assert "1 of 11 steps (first: step 6)" in line
    assert ds.attrs["dead_zone_steps"] == "[6]"
