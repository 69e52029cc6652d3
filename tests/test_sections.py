"""Sections that vary along a rod (``[[rods.<name>.sections]]``) against independent
references: the two-curvature arc of a pure moment, Euler–Bernoulli with piecewise E I, the
exact mass and first moment of the weight, and the uniform rod they must reduce to. Run with
``pytest -s`` for the tables.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from test_loads import EI, LENGTH, MODULUS, RADIUS, cantilever, observed_order, static_tip

import rodsim
from rodsim.core.analytic.reference import cantilever_reference
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError

#: The proximal part stiffer (E × 4) and the distal part a tube (r_i = r / 2).
#: At 3/8 L the boundary sits at the same place in a bending element (a quarter into its dual
#: interval, three quarters into a segment) at every N of NODES, so the error constant is the
#: same and the observed order is clean (elsewhere it varies with that place, bounded).
SPLIT = 0.375 * LENGTH
STIFF, TUBE = 4.0, 1.0 - 0.5**4  # E I of each part relative to the rod's
TWO_SECTIONS = [{"start": 0.0, "end": SPLIT, "youngs_modulus": STIFF * MODULUS},
                {"start": SPLIT, "end": LENGTH, "inner_radius": 0.5 * RADIUS}]
NODES = (11, 19, 27, 43)


def two_arcs(moment: float) -> np.ndarray:
    """Tip of an arc of curvature M/(E I₁) over [0, a] followed by one of M/(E I₂)."""
    k1, k2 = moment / (STIFF * EI), moment / (TUBE * EI)
    turn = k1 * SPLIT
    first = np.array([math.sin(turn), 1.0 - math.cos(turn)]) / k1
    rest = LENGTH - SPLIT
    return first + np.array([math.sin(turn + k2 * rest) - math.sin(turn),
                             math.cos(turn) - math.cos(turn + k2 * rest)]) / k2


def test_two_section_cantilever_with_a_tip_moment_is_two_exact_arcs():
    """Pure bending of a piecewise-uniform rod: curvature M/(E I) in each part, exactly; the
    boundary between the parts falls inside a bending element (harmonic mean over its dual
    length). Tip converges at second order."""
    moment = 0.03
    exact = two_arcs(moment)
    errors = []
    for nodes in NODES:
        tip = static_tip(cantilever(nodes, {"point_loads": {"loads": [
            {"s": LENGTH, "moment": [0.0, 0.0, moment]}]}}, sections=TWO_SECTIONS))
        errors.append(float(np.hypot(*(tip[:2] - exact)) / LENGTH))
    order = observed_order(NODES, errors)
    print(f"\ntwo sections, tip moment: |tip − two arcs| / L at N = {NODES}: "
          f"{', '.join(f'{e:.3g}' for e in errors)}; order {order:.2f}")
    assert order > 1.8
    assert errors[-1] < 1e-5


def test_two_section_cantilever_with_a_small_tip_force_matches_euler_bernoulli():
    """δ = P ∫₀ᴸ (L − s)² / (E I(s)) ds for a small tip force P (α = 3.6e-3)."""
    force = 3e-3
    rest = LENGTH - SPLIT
    expected = force * ((LENGTH**3 - rest**3) / (3.0 * STIFF * EI) + rest**3 / (3.0 * TUBE * EI))
    errors = []
    nodes = NODES
    for n in nodes:
        tip = static_tip(cantilever(n, {"point_loads": {"loads": [
            {"s": LENGTH, "force": [0.0, -force, 0.0]}]}}, K_P=1e5, sections=TWO_SECTIONS))
        errors.append(abs(-tip[1] / expected - 1.0))
    order = observed_order(nodes, errors)
    print(f"\ntwo sections, small tip force vs Euler–Bernoulli at N = {nodes}: "
          f"{', '.join(f'{e:.3g}' for e in errors)}; order {order:.2f}")
    assert order > 1.8
    assert errors[-1] < 1e-3


def test_sections_equal_to_the_rod_change_nothing():
    """One span with the rod's own values, and the same split in two, give the uniform rod's
    equilibrium to round-off; an explicit A, I, J equal to the radius' gives it too."""
    load = {"tip_load": {"mass": 0.05}, "gravity": {}}
    uniform = static_tip(cantilever(25, load))
    area, second = math.pi * RADIUS**2, math.pi * RADIUS**4 / 4.0
    for sections in (
            [{"start": 0.0, "end": LENGTH}],
            [{"start": 0.0, "end": SPLIT}, {"start": SPLIT, "end": LENGTH}],
            [{"start": 0.0, "end": LENGTH, "area": area, "second_moment": second,
              "polar_moment": 2.0 * second}]):
        tip = static_tip(cantilever(25, load, sections=sections))
        np.testing.assert_allclose(tip, uniform, rtol=0, atol=1e-13, err_msg=str(sections))


def test_a_change_of_the_rod_reaches_the_spans_that_inherit_it():
    """--set youngs_modulus (or a fit) changes every span that does not set its own E: the
    resolved scene does not freeze the rod's values into the spans."""
    scene = rodsim.load_scene(cantilever(10, {}, sections=TWO_SECTIONS))
    stiffer = scene.with_overrides(["rods.c.youngs_modulus=2.0e7", "rods.c.density=2000.0"])
    rod = rodsim.build_model(stiffer).rods["c"]
    assert np.array_equal(rod.profile.youngs_modulus, [STIFF * MODULUS, 2.0e7])
    assert np.array_equal(rod.profile.density, [2000.0, 2000.0])
    with pytest.raises(SceneError, match="not below the radius"):
        scene.with_overrides(["rods.c.radius=0.002"])  # below the tube's inner radius


def test_mass_and_weight_follow_the_sections():
    """The lumped masses add up to ∫ ρ A ds and their first moment to ∫ s ρ A ds, exactly,
    for spans that end inside segments; gravity hangs on that weight."""
    sections = [{"start": 0.0, "end": 0.0311, "density": 3000.0},
                {"start": 0.0311, "end": 0.0777, "inner_radius": 0.003},
                {"start": 0.0777, "end": LENGTH, "radius": 0.004, "density": 500.0}]
    model = rodsim.build_model(cantilever(17, {"gravity": {}}, sections=sections))
    rod = model.rods["c"]
    masses = rod.node_masses()
    parts = [(0.0, 0.0311, 3000.0 * math.pi * RADIUS**2),
             (0.0311, 0.0777, 1000.0 * math.pi * (RADIUS**2 - 0.003**2)),
             (0.0777, LENGTH, 500.0 * math.pi * 0.004**2)]
    total = sum((b - a) * line for a, b, line in parts)
    moment = sum(0.5 * (b * b - a * a) * line for a, b, line in parts)
    assert math.isclose(masses.sum(), total, rel_tol=1e-13)
    assert math.isclose(masses @ rod.geometry.node_s, moment, rel_tol=1e-13)
    weights = -next(t for t in model.terms if t.name == "gravity").element_forces(None)[:, 1]
    np.testing.assert_allclose(weights, 9.81 * masses, rtol=1e-15)


def test_compliance_fraction_measures_the_interval_in_compliance():
    """Where s lies in [a, b] measured in ∫ 1/p ds: by hand, spans p = 10 on [0, 0.5] and
    p = 1 on [0.5, 1] give 0.05 / 0.55 = 1/11 at the jump and 0.3 / 0.55 = 6/11 at 0.75;
    clipped to [0, 1] outside [a, b]; an interval inside one span gets the linear
    (s − a)/(b − a) to the bit, as does every interval of equal values."""
    from rodsim.core.rod.sections import SectionProfile

    ones = np.ones(2)
    profile = SectionProfile(np.array([0.0, 0.5]), np.array([0.5, 1.0]), ones, ones, ones,
                             ones, ones, ones, ones)
    values = np.array([10.0, 1.0])
    a, b = np.zeros(4), np.ones(4)
    s = np.array([0.5, 0.75, -0.2, 1.3])
    np.testing.assert_allclose(profile.compliance_fraction(values, a, s, b),
                               [1 / 11, 6 / 11, 0.0, 1.0], rtol=1e-15, atol=0)
    a, s, b = np.array([0.1, 0.6]), np.array([0.13, 0.77]), np.array([0.35, 0.95])
    linear = np.clip((s - a) / (b - a), 0.0, 1.0)
    assert np.array_equal(profile.compliance_fraction(values, a, s, b), linear)
    assert np.array_equal(profile.compliance_fraction(np.array([3.0, 3.0]), np.zeros(1),
                                                      np.full(1, 0.3), np.ones(1)), [0.3])


def test_references_follow_uniform_sections_and_refuse_varying_ones():
    """A tube over the whole rod is scored against the elastica with the tube's E I; a rod
    whose sections vary has no uniform-rod reference."""
    tube = [{"start": 0.0, "end": LENGTH, "inner_radius": 0.5 * RADIUS}]
    reference = cantilever_reference(rodsim.load_scene(cantilever(
        20, {"tip_load": {"mass": 0.02}}, sections=tube)))
    assert reference is not None
    assert math.isclose(reference.bending_stiffness, TUBE * EI, rel_tol=1e-14)
    assert cantilever_reference(rodsim.load_scene(cantilever(
        20, {"tip_load": {"mass": 0.02}}, sections=TWO_SECTIONS))) is None


@pytest.mark.parametrize("sections, message", [
    ([], "no span"),
    ({"start": 0.0, "end": LENGTH}, "wrong type"),
    ([{"start": 0.01, "end": LENGTH}], "leaves a gap"),
    ([{"start": 0.0, "end": 0.06}, {"start": 0.05, "end": LENGTH}], "overlaps"),
    ([{"start": 0.0, "end": 0.06}, {"start": 0.07, "end": LENGTH}], "leaves a gap"),
    ([{"start": 0.0, "end": 0.0}, {"start": 0.0, "end": LENGTH}], "not above its start"),
    ([{"start": 0.0, "end": 0.06}], "do not cover the rod"),
    ([{"start": 0.0, "end": 0.2}], "do not cover the rod"),
    ([{"start": 0.0, "end": LENGTH, "youngs_modulus": float("nan")}], "not finite"),
    ([{"start": 0.0, "end": LENGTH, "inner_radius": RADIUS}], "not below the radius"),
    ([{"start": 0.0, "end": LENGTH, "modulus": 1.0}], "unknown key"),
    ([{"end": LENGTH}], "required value missing"),
])
def test_bad_sections_are_one_line_scene_errors(sections, message):
    with pytest.raises(SceneError) as error:
        rodsim.load_scene(cantilever(10, {}, sections=sections))
    text = str(error.value)
    assert message in text and "\n" not in text, text


def test_integrators_agree_on_loads_and_sections_in_three_dimensions():
    """A non-conservative 3-D scene with every new piece (two sections, a body-frame tip force,
    a world moment between nodes, a load per length on a span, gravity): cvode and ida, which
    reach the equilibrium through the pseudo-dynamics, land on static's to 1e-9 L."""
    scene = cantilever(25, {
        "point_loads": {"loads": [{"s": LENGTH, "force": [0.0, -0.4, 0.2], "frame": "body"},
                                  {"s": 0.071, "moment": [0.03, 0.0, 0.04]}]},
        "distributed_load": {"spans": [{"start": 0.02, "end": 0.09,
                                        "force_per_length": [0.0, 0.0, -3.0]}]},
        "gravity": {}}, K_P=1e5, sections=TWO_SECTIONS)
    static = static_tip(scene)
    assert abs(static[2]) > 0.1 * LENGTH and abs(static[1]) > 0.1 * LENGTH
    for integrator in ("cvode", "ida"):
        result = rodsim.solve(scene, integrator)
        assert result.success, result.message
        assert np.linalg.norm(result.tip() - static) < 1e-9 * LENGTH, integrator


def test_body_frame_force_on_a_twist_stiffness_jump_converges_at_second_order():
    """A body-frame (follower) point force at catheter-pull-ring's section boundary
    (s = 0.06 m, a node; the wires twist the rod under the force's out-of-plane part): its
    frame between the two midpoints around s is interpolated in the twist compliance, as the
    string tendon's is. Successive tip differences over N = 41 -> 81 -> 161, measured:
    9.8e-5, 2.6e-5 L, order 1.92 (then 1.96 to N = 321); with the linear weight ½ the frame
    sat O(h) off and the order was 1.02, 1.01."""
    data = copy.deepcopy(rodsim.load_scene("catheter-pull-ring").data)
    table = data["rods"]["catheter"]
    table["terms"] = [*table["terms"], "point_loads"]
    table["point_loads"] = {"loads": [{"s": 0.06, "force": [0.0, 0.0, 0.05],
                                       "frame": "body"}]}
    scene = Scene.from_dict(data)
    tips = []
    for nodes in (41, 81, 161):
        result = rodsim.solve(scene.with_values({"rods.catheter.nodes": nodes}), "static")
        assert result.success, result.message
        tips.append(result.rods["catheter"].positions[-1])
    differences = [float(np.linalg.norm(b - a)) / 0.1
                   for a, b in zip(tips[:-1], tips[1:], strict=True)]
    order = math.log2(differences[0] / differences[1])
    print(f"\nbody force at the boundary: differences {differences}, order {order:.2f}")
    assert order >= 1.8, differences
