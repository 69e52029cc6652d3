"""Point wrenches (``point_loads``) and loads per length (``distributed_load``) against
independent references: the circular arc of a pure moment, the Euler–Bernoulli cantilever, the
extensible elastica, and gravity. Only ``static`` is used (the exact discrete equilibrium), so
the errors are the model's; run with ``pytest -s`` for the tables.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import rodsim
from rodsim.core.analytic import exact_elastica, extensible_elastica
from rodsim.core.schema import SceneError

LENGTH, RADIUS, MODULUS = 0.12, 0.006, 5.9e6
EI = MODULUS * math.pi * RADIUS**4 / 4.0
EA = MODULUS * math.pi * RADIUS**2


def cantilever(nodes: int, terms: dict, K_P: float = 1e6, sections: list | None = None
               ) -> dict:
    """A Table-1-like cantilever (rest along +x, 'frame' clamp) with the given load terms."""
    rod = {"length": LENGTH, "radius": RADIUS, "youngs_modulus": MODULUS,
           "stretch_modulus": MODULUS, "density": 1000.0, "nodes": nodes, "clamp": "frame",
           "terms": ["stretch", "bend_twist", "centerline", *terms],
           "centerline": {"K_P": K_P}, **terms}
    if sections is not None:
        rod["sections"] = sections
    return {"name": "loads", "rods": {"c": rod}, "solver": {"integrator": "static"}}


def static_tip(scene: dict) -> np.ndarray:
    result = rodsim.solve(scene, "static", overrides=["static.max_newton=200"])
    assert result.success, result.message
    return result.tip()


def observed_order(nodes: tuple[int, ...], errors: list[float]) -> float:
    """Least-squares slope of log error against log segment length."""
    h = np.log([1.0 / (n - 1) for n in nodes])
    return float(np.polyfit(h, np.log(errors), 1)[0])


def arc_tip(curvature: float, length: float) -> np.ndarray:
    """Tip of a circular arc from the origin along +x, bending toward +y."""
    return np.array([math.sin(curvature * length), 1.0 - math.cos(curvature * length)]) / (
        curvature)


NODES = (10, 20, 40, 80)


@pytest.mark.parametrize("frame, moment", [("world", [0.0, 0.0, 0.05]),
                                           ("body", [0.0, 0.05, 0.0])])
def test_tip_moment_bends_a_cantilever_into_the_exact_arc(frame, moment):
    """Pure bending: a tip moment M about z (d2 at rest, and all along a planar arc) gives
    κ = M / (E I) exactly (κ L ≈ 1 here); the tip converges at second order."""
    kappa = 0.05 / EI
    exact = arc_tip(kappa, LENGTH)
    errors = []
    for nodes in NODES:
        tip = static_tip(cantilever(nodes, {"point_loads": {"loads": [
            {"s": LENGTH, "moment": moment, "frame": frame}]}}))
        errors.append(float(np.hypot(*(tip[:2] - exact)) / LENGTH))
        assert abs(tip[2]) < 1e-12 * LENGTH
    order = observed_order(NODES, errors)
    print(f"\ntip moment ({frame}), κL = {kappa * LENGTH:.3f}: |tip − arc| / L at N = "
          f"{NODES}: {', '.join(f'{e:.3g}' for e in errors)}; order {order:.2f}")
    assert order > 1.9
    assert errors[-1] < 2e-5


@pytest.mark.parametrize("frame, moment, where", [
    ("world", [0.0, 0.0, 0.05], 0.5), ("body", [0.0, 0.05, 0.0], 0.5),
    ("world", [0.0, 0.0, 0.05], 0.37)])
def test_an_interior_moment_bends_the_span_before_it_into_the_exact_arc(frame, moment, where):
    """Pure bending again, the moment at s₀ inside the rod (on a node for s₀ = L/2 at every
    N here; between nodes for 0.37 L): the arc of κ = M / (E I) up to s₀, then straight along
    its tangent. Second order: the moment shared by the two quaternions around s₀ (with it
    all on the segment holding s₀ the tip converged at first order, 1.0)."""
    kappa, s0 = 0.05 / EI, where * LENGTH
    angle = kappa * s0
    exact = arc_tip(kappa, s0) + (LENGTH - s0) * np.array([math.cos(angle), math.sin(angle)])
    nodes = (11, 21, 41, 81)
    errors = []
    for n in nodes:
        tip = static_tip(cantilever(n, {"point_loads": {"loads": [
            {"s": s0, "moment": moment, "frame": frame}]}}))
        errors.append(float(np.hypot(*(tip[:2] - exact)) / LENGTH))
    order = observed_order(nodes, errors)
    print(f"\nmoment at {where} L ({frame}): |tip − exact| / L at N = {nodes}: "
          f"{', '.join(f'{e:.3g}' for e in errors)}; order {order:.2f}")
    assert order > 1.8
    assert errors[-1] < 1e-4


def test_point_force_between_nodes_matches_euler_bernoulli():
    """A small force P at a = 3L/8 (mid-segment at every N below): tip deflection
    P a² (3L − a) / (6 E I), converging at second order (α = P L²/(2EI) = 3.6e-3, so the
    geometric non-linearity is below 1e-5 of it)."""
    force, at = 3e-3, 0.375 * LENGTH
    expected = force * at**2 * (3.0 * LENGTH - at) / (6.0 * EI)
    nodes = (13, 21, 29, 37)
    errors = []
    for n in nodes:
        tip = static_tip(cantilever(n, {"point_loads": {"loads": [
            {"s": at, "force": [0.0, -force, 0.0]}]}}, K_P=1e5))
        errors.append(abs(-tip[1] / expected - 1.0))
    order = observed_order(nodes, errors)
    print(f"\npoint force at 3L/8: relative tip deflection error at N = {nodes}: "
          f"{', '.join(f'{e:.3g}' for e in errors)}; order {order:.2f}")
    assert order > 1.8
    assert errors[-1] < 3e-3


@pytest.mark.parametrize("reference", ["extensible", "exact"])
def test_point_force_at_the_tip_matches_the_elastica(reference):
    """A point load at s = L is the hanging-mass experiment: α = F L² / (2 E I) = 0.36,
    against the extensible elastica with the rod's E_s A, and against the exact (inextensible)
    elastica for a rod with E_s = 1e4 E (stretch below 5e-8), both at second order."""
    force = 0.3
    stretch = 1.0 if reference == "extensible" else 1e4
    ends = np.array([0.0, LENGTH])
    exact = (extensible_elastica((0.0, -force), EI, EA, LENGTH, ends)
             if reference == "extensible" else exact_elastica(force, EI, LENGTH, ends))
    errors = []
    for nodes in NODES:
        scene = cantilever(nodes, {"point_loads": {"loads": [
            {"s": LENGTH, "force": [0.0, -force, 0.0]}]}}, K_P=1e8)
        scene["rods"]["c"]["stretch_modulus"] = stretch * MODULUS
        tip = static_tip(scene)
        errors.append(float(np.hypot(tip[0] - exact.x[-1], tip[1] - exact.y[-1]) / LENGTH))
    order = observed_order(NODES, errors)
    print(f"\npoint force at s = L vs {reference} elastica: "
          f"{', '.join(f'{e:.3g}' for e in errors)}; order {order:.2f}")
    assert order > 1.9
    assert errors[-1] < 3e-5


def test_distributed_load_equals_gravity_of_the_same_weight():
    """q = −ρ A g ŷ per length on the whole rod is the rod's own weight: same equilibrium
    as the ``gravity`` term (round-off); half of it on each of two spans covering the rod,
    plus the other half uniform, gives the same again."""
    weight = 1000.0 * math.pi * RADIUS**2 * 9.81 * 20.0  # a heavy rod: α ≈ 0.4
    gravity = cantilever(30, {"gravity": {"gravity": 9.81 * 20.0}})
    uniform = cantilever(30, {"distributed_load": {"force_per_length": [0.0, -weight, 0.0]}})
    spans = cantilever(30, {"distributed_load": {
        "force_per_length": [0.0, -0.5 * weight, 0.0],
        "spans": [{"start": 0.0, "end": 0.0537, "force_per_length": [0.0, -0.5 * weight, 0.0]},
                  {"start": 0.0537, "end": LENGTH,
                   "force_per_length": [0.0, -0.5 * weight, 0.0]}]}})
    reference = static_tip(gravity)
    assert reference[1] < -0.1 * LENGTH
    np.testing.assert_allclose(static_tip(uniform), reference, rtol=0, atol=1e-12)
    np.testing.assert_allclose(static_tip(spans), reference, rtol=0, atol=1e-12)


def test_distributed_load_on_a_span_matches_euler_bernoulli():
    """A small load q on [a, b] of a cantilever (a boundary mid-segment): tip deflection by
    superposition of the point-load formula, ∫_a^b q s² (3L − s) / (6 E I) ds."""
    q, a, b = 0.05, 0.031, 0.097
    expected = q * ((b**3 - a**3) * LENGTH / 6.0 - (b**4 - a**4) / 24.0) / EI
    errors = []
    nodes = (13, 25, 49)
    for n in nodes:
        tip = static_tip(cantilever(n, {"distributed_load": {"spans": [
            {"start": a, "end": b, "force_per_length": [0.0, -q, 0.0]}]}}, K_P=1e5))
        errors.append(abs(-tip[1] / expected - 1.0))
    print(f"\nload on a span: relative tip error at N = {nodes}: "
          f"{', '.join(f'{e:.3g}' for e in errors)}")
    assert errors[-1] < 2e-3
    assert errors[-1] < errors[0] / 8.0


@pytest.mark.parametrize("change, message", [
    ({"point_loads": {"loads": [{"s": 0.2, "force": [0.0, 1.0, 0.0]}]}}, "beyond the rod"),
    ({"point_loads": {"loads": [{"s": -0.01}]}}, "out of range"),
    ({"point_loads": {"loads": [{"s": 0.1, "frame": "tip"}]}}, "unknown choice"),
    ({"point_loads": {"loads": [{"s": float("nan")}]}}, "not finite"),
    ({"point_loads": {"loads": [{"force": [0.0, 1.0, 0.0]}]}}, "required value missing"),
    ({"point_loads": {"loads": [{"s": 0.1, "torque": [0.0, 1.0, 0.0]}]}}, "unknown key"),
    ({"point_loads": {"loads": {"s": 0.1}}}, "wrong type"),
    ({"distributed_load": {"spans": [{"start": 0.05, "end": 0.02,
                                      "force_per_length": [0.0, 1.0, 0.0]}]}}, "not below"),
    ({"distributed_load": {"spans": [{"start": 0.05, "end": 0.2,
                                      "force_per_length": [0.0, 1.0, 0.0]}]}}, "beyond"),
])
def test_bad_loads_are_one_line_scene_errors(change, message):
    with pytest.raises(SceneError) as error:
        rodsim.load_scene(cantilever(10, change))
    text = str(error.value)
    assert message in text and "\n" not in text, text


def kirchhoff_tip(moment: np.ndarray, stiffness: np.ndarray, frame: str) -> np.ndarray:
    """Tip of an inextensible, unshearable Kirchhoff cantilever (rest frame d1 = y, d2 = z,
    d3 = x at s = 0) with a tip moment and no force, integrated by scipy at 1e-12: the
    internal moment is the tip moment everywhere, so the body curvature is
    u = K⁻¹ Rᵀ M (a world moment M), and R′ = R [u]×, r′ = R e3. A body-frame (follower)
    moment m is the world moment R(L) m: integrated from the tip backward in the tip's frame,
    then placed so that the base has the rest frame."""
    from scipy.integrate import solve_ivp

    def skew(u: np.ndarray) -> np.ndarray:
        return np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])

    def rhs(_s: float, y: np.ndarray) -> np.ndarray:
        rot = y[3:].reshape(3, 3)
        u = (rot.T @ moment) / stiffness
        return np.concatenate([rot[:, 2], (rot @ skew(u)).ravel()])

    base = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # columns d1, d2, d3
    if frame == "world":
        y = solve_ivp(rhs, (0.0, LENGTH), np.concatenate([np.zeros(3), base.ravel()]),
                      rtol=1e-12, atol=1e-14).y[:, -1]
        return y[:3]
    y = solve_ivp(rhs, (LENGTH, 0.0), np.concatenate([np.zeros(3), np.eye(3).ravel()]),
                  rtol=1e-12, atol=1e-14).y[:, -1]
    place = base @ y[3:].reshape(3, 3).T  # R_true(s) = base R_rel(0)ᵀ R_rel(s)
    return place @ (np.zeros(3) - y[:3])


@pytest.mark.parametrize("frame, moment", [("world", [0.02, 0.03, -0.04]),
                                           ("body", [0.03, -0.04, 0.02])])
def test_three_dimensional_tip_moment_matches_the_kirchhoff_rod(frame, moment):
    """A tip moment with bending and twist components (|θ| ≈ 1–2 rad): the rod winds into a
    helix. The world-frame moment is not conservative in 3-D (its exact Jacobian is
    non-symmetric), the body-frame one follows the tip; both converge at second order to the
    Kirchhoff rod integrated by scipy."""
    stiffness = np.array([EI, EI, 2.0 * EI / 3.0])  # ν = 0.5: G J = E (2 I) / 3
    exact = kirchhoff_tip(np.asarray(moment), stiffness, frame)
    errors = []
    for nodes in NODES:
        tip = static_tip(cantilever(nodes, {"point_loads": {"loads": [
            {"s": LENGTH, "moment": moment, "frame": frame}]}}, K_P=1e7))
        errors.append(float(np.linalg.norm(tip - exact) / LENGTH))
    order = observed_order(NODES, errors)
    print(f"\n3-D tip moment ({frame}) vs Kirchhoff rod: |tip − exact| / L at N = {NODES}: "
          f"{', '.join(f'{e:.3g}' for e in errors)}; order {order:.2f}")
    assert abs(exact[2]) > 0.1 * LENGTH  # out of plane indeed
    assert order > 1.8
    assert errors[-1] < 5e-5
