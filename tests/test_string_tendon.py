"""The string tendon (coupling = "string", rodsim/core/terms/tendon_string.py) against the
Rucker–Webster reference (rodsim/core/analytic/tendon_bvp.py), and the reference itself
against closed forms.

Each case is a scene solved by ``static`` at several N; the catheter's tip is compared with
the reference's (which includes rodsim's axial law and its K_P shear law, so the only
difference left is the discretisation). The tests print the table: error / L and the
observed order log2(e(N) / e(2N − 1)). Found: order 2.0 on every case (1.85–2.07 for a
termination inside a segment, whose place in the segment changes with N); the K_P floor (the
reference with the rod unshearable against the one with shear stiffness K_P = G A) is
6e-7 L on tdcr-two-segment and 6.6e-4 L on catheter-helical (a soft, thick catheter: its
physical shear compliance), so the accuracy aim is stated against the shearable reference.
"""

from __future__ import annotations

import copy
import functools
import math

import numpy as np
import pytest

import rodsim
from rodsim.core.analytic.extensible import extensible_elastica
from rodsim.core.analytic.tendon_arc import tendon_arc
from rodsim.core.analytic.tendon_bvp import (
    BVPTendon,
    Section,
    scene_reference,
    tendon_rod,
)
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError

#: The benchmark backbone (Rao et al. 2021): nitinol, r = 0.7 mm, one 0.2 m segment.
E, RADIUS, LENGTH = 54e9, 0.7e-3, 0.2
AREA = math.pi * RADIUS**2
SHEAR = E / 2.6 * AREA  # G A, the scenes' K_P


def backbone(nodes: int, tendons: dict, force=(0.0, 0.0, 0.0)) -> dict:
    return {"name": "string-case", "rods": {"backbone": {
        "length": LENGTH, "radius": RADIUS, "youngs_modulus": E, "stretch_modulus": E,
        "poisson_ratio": 0.3, "density": 6450.0, "nodes": nodes, "clamp": "frame",
        "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
        "centerline": {"K_P": SHEAR}, "tip_load": {"force": list(force)}}},
        "tendons": tendons, "solver": {"integrator": "static"}}


def string(direction, tension, **values) -> dict:
    return {"catheter": "backbone", "coupling": "string", "offset": 0.01,
            "direction": list(direction), "tendon_string": {"tension": tension,
                                                            "spacers": True, **values}}


#: name -> (tendons, tip force).
CASES = {
    "one tendon": ({"a": string((1, 0), 3.0)}, (0.0, 0.0, 0.0)),
    "two tendons, one ends part-way": (
        {"a": string((1, 0), 2.0, end=0.12), "b": string((-0.5, 0.8660254), 1.5)},
        (0.0, 0.0, 0.0)),
    "one ends mid-segment, tip force": (
        {"a": string((1, 0), 2.0, end=0.1234), "b": string((-0.5, 0.8660254), 1.5)},
        (0.0, 0.02, 0.03)),
    "entry past the base (0.05 m)": (
        {"a": string((1, 0), 2.0, start=0.05), "b": string((-0.5, 0.8660254), 1.0)},
        (0.0, 0.0, 0.0)),
    "helical tendon": ({"h": {"catheter": "backbone", "coupling": "string", "tendon_string": {
        "tension": 2.0, "spacers": True, "routing": "helix", "helix_radius": 0.01,
        "helix_pitch": 0.4}}}, (0.0, 0.0, 0.0)),
    "tip force in plane": ({"a": string((1, 0), 2.0)}, (0.0, -0.1, 0.0)),
    "tip force out of plane": ({"a": string((1, 0), 2.0, end=0.15)}, (0.0, 0.05, 0.08)),
}

#: Node counts of the convergence tables (each halves h).
NODES = (21, 41, 81)
#: Shipped-N aim: tip within this fraction of L of the reference.
AIM = 1e-4


@functools.cache
def reference_tip(case: str) -> np.ndarray:
    tendons, force = CASES[case]
    return scene_reference(Scene.from_dict(backbone(11, copy.deepcopy(tendons), force))).tip


def tip_error(scene, rod: str, reference: np.ndarray) -> float:
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    length = scene.rods[rod].length
    return float(np.linalg.norm(result.rods[rod].positions[-1] - reference) / length)


def convergence_table(label: str, errors: dict[int, float]) -> list[float]:
    print(f"\n{label}")
    print("   N   |tip - reference| / L   order")
    orders, previous = [], None
    for nodes, error in errors.items():
        order = math.log2(previous / error) if previous else math.nan
        if previous:
            orders.append(order)
        print(f"{nodes:5d}   {error:.3e}              {order:.2f}")
        previous = error
    return orders


@pytest.mark.parametrize("case", list(CASES))
def test_string_tendon_converges_to_the_rucker_webster_reference(case):
    tendons, force = CASES[case]
    reference = reference_tip(case)
    errors = {n: tip_error(Scene.from_dict(backbone(n, copy.deepcopy(tendons), force)),
                           "backbone", reference) for n in NODES}
    orders = convergence_table(case, errors)
    assert min(orders) >= 1.8, orders
    assert errors[NODES[-1]] <= AIM


@pytest.mark.parametrize(("name", "rod"), [("tdcr-two-segment", "backbone"),
                                           ("catheter-helical", "catheter")])
def test_shipped_string_scenes_meet_the_accuracy_aim(name, rod):
    """At the shipped N the tip is within 1e-4 L of the reference, and halving h shows
    second order."""
    scene = rodsim.load_scene(name)
    reference = scene_reference(scene).tip
    shipped = scene.rods[rod].nodes
    coarse = (shipped - 1) // 2 + 1
    errors = {n: tip_error(scene.with_values({f"rods.{rod}.nodes": n}), rod, reference)
              for n in (coarse, shipped)}
    orders = convergence_table(name, errors)
    assert errors[shipped] <= AIM
    assert min(orders) >= 1.8


def test_tdcr_s_shape_and_a_helical_tip_leave_the_plane():
    """The shipped scenes do what their descriptions say: the helical tendon moves the tip
    out of the plane it starts bending in (z), the two segments bend opposite ways."""
    helical = rodsim.solve("catheter-helical", "static").rods["catheter"].positions
    assert helical[-1, 1] > 0.005 and abs(helical[-1, 2]) > 0.005
    tdcr = rodsim.solve(rodsim.load_scene("tdcr-two-segment", ["tip_load.force=[0, 0, 0]"]),
                        "static").rods["backbone"].positions
    middle = len(tdcr) // 2
    slope_1 = tdcr[middle, 1] - tdcr[middle - 1, 1]
    slope_2 = tdcr[-1, 1] - tdcr[-2, 1]
    assert tdcr[middle, 1] > 0.005 and slope_1 > 0 and slope_2 < slope_1


# ------------------------------------------------------------ the reference on its own
def constant(values):
    return lambda s: np.tile(values, (len(s), 1))


def test_reference_is_the_constant_curvature_arc_for_one_straight_tendon():
    """A tendon at constant offset ending at the tip bends an extensible rod into the arc
    κ = T ρ / EI with the axial strain −T / EA (rodsim/core/analytic/tendon_arc.py)."""
    ei, ea = E * math.pi * RADIUS**4 / 4, E * AREA
    s = np.linspace(0.0, LENGTH, 7)
    for shear in (math.inf, SHEAR):
        solution = tendon_rod(LENGTH, [Section(LENGTH, ei, 0.8 * ei, ea, shear)],
                              [BVPTendon(3.0, LENGTH, constant([0.0, 0.01]),
                                         constant([0.0, 0.0]))], s=s)
        arc = tendon_arc(3.0, 0.01, ei, ea, LENGTH, s)
        np.testing.assert_allclose(solution.positions[:, 0], arc.x, rtol=0, atol=1e-12)
        np.testing.assert_allclose(solution.positions[:, 2], arc.y, rtol=0, atol=1e-12)
        np.testing.assert_allclose(solution.positions[:, 1], 0.0, atol=1e-14)


def test_reference_without_tendons_is_the_extensible_elastica():
    """A tip force alone (no tendon) on an unshearable rod: the extensible elastica."""
    ei, ea = E * math.pi * RADIUS**4 / 4, 1e3
    s = np.linspace(0.0, LENGTH, 5)
    solution = tendon_rod(LENGTH, [Section(LENGTH, ei, 0.8 * ei, ea)], [],
                          tip_force=(0.05, -0.2, 0.0), s=s, load_steps=2)
    elastica = extensible_elastica((0.05, -0.2), ei, ea, LENGTH, s)
    np.testing.assert_allclose(solution.positions[:, 0], elastica.x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(solution.positions[:, 1], elastica.y, rtol=0, atol=1e-10)


def test_reference_terminations_and_sections_are_consistent():
    """A tendon ending at 0.1 m equals, on [0, 0.1], the same tendon on a rod cut there
    (beyond the termination the unloaded rest is straight, with the tip frame's direction);
    splitting one section into two equal ones changes nothing."""
    ei, ea = E * math.pi * RADIUS**4 / 4, E * AREA
    tendon = BVPTendon(2.0, 0.1, constant([0.01, 0.0]), constant([0.0, 0.0]))
    full = tendon_rod(LENGTH, [Section(LENGTH, ei, 0.8 * ei, ea)], [tendon],
                      s=np.array([0.1, LENGTH]))
    short = tendon_rod(0.1, [Section(0.1, ei, 0.8 * ei, ea)], [tendon],
                       s=np.array([0.1]))
    np.testing.assert_allclose(full.positions[0], short.positions[0], rtol=0, atol=1e-12)
    straight = short.positions[0] + 0.1 * short.frames[0][:, 2]
    np.testing.assert_allclose(full.positions[1], straight, rtol=0, atol=1e-12)
    split = tendon_rod(LENGTH, [Section(0.07, ei, 0.8 * ei, ea), Section(LENGTH, ei, 0.8 * ei,
                                                                          ea)],
                       [tendon], s=np.array([0.1, LENGTH]))
    np.testing.assert_allclose(split.positions, full.positions, rtol=0, atol=1e-12)


def test_reference_tip_moment_on_two_sections_is_two_arcs():
    """A tip moment alone bends each span into an arc of curvature M / E I_span (no axial
    force, so no stretch): a stiff proximal and a soft distal section."""
    ei, ea, moment, joint = E * math.pi * RADIUS**4 / 4, E * AREA, 0.01, 0.12
    solution = tendon_rod(LENGTH, [Section(joint, ei, 0.8 * ei, ea),
                                   Section(LENGTH, ei / 3, 0.8 * ei / 3, ea)], [],
                          tip_moment=(0.0, 0.0, moment), s=np.array([joint, LENGTH]))
    k1, k2 = moment / ei, 3 * moment / ei
    t1 = k1 * joint
    first = np.array([math.sin(t1) / k1, (1 - math.cos(t1)) / k1, 0.0])
    t2 = t1 + k2 * (LENGTH - joint)
    tip = first + [(math.sin(t2) - math.sin(t1)) / k2, (math.cos(t1) - math.cos(t2)) / k2, 0]
    np.testing.assert_allclose(solution.positions, [first, tip], rtol=0, atol=1e-12)


def test_reference_entry_past_the_base_leaves_the_rod_straight_before_it():
    """A tendon entering at 0.1 m (its pull's reaction acting there) leaves [0, 0.1] unloaded
    and straight; beyond, the rod bends as a 0.1 m rod clamped there with the tendon from
    its base."""
    ei, ea = E * math.pi * RADIUS**4 / 4, E * AREA
    offset, slope = constant([0.006, -0.008]), constant([0.0, 0.0])
    entering = tendon_rod(LENGTH, [Section(LENGTH, ei, 0.8 * ei, ea, SHEAR)],
                          [BVPTendon(2.0, LENGTH, offset, slope, start=0.1)],
                          s=np.array([0.1, LENGTH]))
    clamped = tendon_rod(0.1, [Section(0.1, ei, 0.8 * ei, ea, SHEAR)],
                         [BVPTendon(2.0, 0.1, offset, slope)], s=np.array([0.1]))
    np.testing.assert_allclose(entering.positions[0], [0.1, 0.0, 0.0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(entering.positions[1],
                               clamped.positions[0] + [0.1, 0.0, 0.0], rtol=0, atol=1e-12)


# ------------------------------------------------------------------------ bad input
BAD = [
    ({"end": 0.25}, "beyond the catheter's tip"),
    ({"start": 0.1, "end": 0.05}, "not before the termination"),
    ({"routing": "table", "table_s": [0.0, 0.1, 0.05], "table_y": [0.0, 0.0, 0.0],
      "table_z": [0.0, 0.0, 0.0]}, "not strictly increasing"),
    ({"routing": "table", "table_s": [0.0, 0.1], "table_y": [0.0, 0.0], "table_z": [0.0]},
     "the same number"),
    ({"routing": "table", "table_s": [0.05, 0.2], "table_y": [0.0, 0.0],
      "table_z": [0.0, 0.0]}, "does not cover"),
    ({"routing": "helix", "helix_radius": 0.0}, "needs a radius"),
    ({"spacers": False}, "outside the catheter"),
]


@pytest.mark.parametrize(("values", "message"), BAD)
def test_bad_string_input_is_one_line(values, message):
    scene = backbone(11, {"a": string((1, 0), 1.0)})
    scene["tendons"]["a"]["tendon_string"] |= values
    with pytest.raises(SceneError, match=message) as info:
        Scene.from_dict(scene)
    assert "\n" not in str(info.value)


def test_nan_routing_and_unknown_catheter_are_refused():
    scene = backbone(11, {"a": string((1, 0), 1.0)})
    scene["tendons"]["a"]["tendon_string"] |= {
        "routing": "table", "table_s": [0.0, math.nan], "table_y": [0.0, 0.0],
        "table_z": [0.0, 0.0]}
    with pytest.raises(SceneError, match="not finite"):
        Scene.from_dict(scene)
    scene = backbone(11, {"a": string((1, 0), 1.0) | {"catheter": "shaft"}})
    with pytest.raises(SceneError, match="no such rod"):
        Scene.from_dict(scene)
    scene = backbone(11, {"backbone2": string((1, 0), 1.0)})
    scene["rods"]["backbone2"] = copy.deepcopy(scene["rods"]["backbone"])
    with pytest.raises(SceneError, match="needs no rod"):
        Scene.from_dict(scene)
    lumen = {key: value for key, value in string((1, 0), 1.0).items()
             if key != "tendon_string"}
    scene = backbone(11, {"a": lumen | {"terms": ["lumen"]}})
    with pytest.raises(SceneError, match="one term 'tendon_string'"):
        Scene.from_dict(scene)


def test_bad_string_input_exits_2_on_the_cli(capsys):
    from rodsim.app.cli import main

    code = main(["run", "tdcr-two-segment", "--set", "s1a.tendon_string.end=0.5"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "beyond the catheter's tip" in err[0]


def test_a_slack_string_tendon_contributes_nothing_even_where_its_path_degenerates():
    """A tendon at tension 0 (five of six in most load cases of tdcr-two-segment) adds
    nothing to F, ∂F/∂x or the energy — its kernel returns at once — including at a state
    where two of its routing points coincide (a chord of length 0, whose direction is 0/0)."""
    from rodsim.core.model import Model

    scene = rodsim.load_scene("tdcr-two-segment", ["s1a.tendon_string.tension=0"])
    model = Model(scene)
    model.evaluate(model.x0)
    call = next(c for c in model._kernel_calls
                if c.term.name == "tendon_string" and c.term.tendon.name == "s1a")
    full = model.full(model.x0)
    full[call.term.dofs[3, 14:17]] = full[call.term.dofs[3, 0:3]]  # node m+1 onto node m
    full[call.term.dofs[3, 20:28]] = full[call.term.dofs[3, 6:14]]  # and its frames
    force, jacobian = np.full(model.n + 1, 7.0), np.full(model.nnz + 1, 7.0)
    call.kernel.evaluate(full, *call.arguments, 1.0, True, force, call.force_target, True,
                         jacobian, call.jacobian_target)
    assert np.all(force == 7.0) and np.all(jacobian == 7.0)
    assert call.kernel.energy(full, *call.arguments) == 0.0
