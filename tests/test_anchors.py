"""Anchors (rodsim/core/anchors.py): two backbone rods joined end to end by a ``joint`` are
the single rod to within the joint's penalty compliance F/K_J; bad joints are one-line
SceneErrors. (The joint's forces and Jacobian are under the term contract test:
tests/test_term_contract.py, SMALL_JOINT_SCENE.)"""

from __future__ import annotations

import copy

import numpy as np
import pytest

import rodsim
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError

MASS, GRAVITY = 0.05, 9.81  # tip_load's standard gravity


def _rod(length: float, nodes: int, **values) -> dict:
    table = {"length": length, "radius": 0.006, "youngs_modulus": 5.9e6,
             "stretch_modulus": 5.9e6, "density": 11040.0, "nodes": nodes,
             "terms": ["stretch", "bend_twist", "centerline"]}
    return table | values


def joined(k_j: float, nodes: int = 11) -> dict:
    """Table 1's 0.12 m catheter as two 0.06 m rods welded end to end, 50 g at the tip."""
    return {"name": "joined", "rods": {
        "proximal": _rod(0.06, nodes),
        "distal": _rod(0.06, nodes, clamp="free",
                       terms=["stretch", "bend_twist", "centerline", "joint", "tip_load"],
                       joint={"rod": "proximal", "s": 0.06, "K_J": k_j},
                       tip_load={"mass": MASS})}}


def single(nodes: int) -> dict:
    return {"name": "single", "rods": {"one": _rod(
        0.12, nodes, terms=["stretch", "bend_twist", "centerline", "tip_load"],
        tip_load={"mass": MASS})}}


def _solve(data: dict):
    result = rodsim.solve(Scene.from_dict(copy.deepcopy(data)), "static")
    assert result.success, result.message
    return result


@pytest.mark.parametrize("k_j", [1e5, 1e6, 1e7])
def test_two_rods_welded_end_to_end_are_the_single_rod(k_j):
    """Same segments, and the welded frame is the single rod's bending element between the
    two segments: every node of the distal rod is the single rod's, moved by the joint's
    gap F/K_J along the tip force (the whole force passes through the joint); the proximal
    rod is the single rod's first half."""
    one = _solve(single(21)).rods["one"].positions
    two = _solve(joined(k_j))
    gap = np.array([0.0, -MASS * GRAVITY / k_j, 0.0])
    distal = two.rods["distal"].positions
    proximal = two.rods["proximal"].positions
    print(f"\nK_J = {k_j:g}: tip - single tip = {distal[-1] - one[-1]}, F/K_J = {gap[1]:.4g}")
    assert np.abs(proximal - one[:11]).max() < 1e-12 + 1e-3 * abs(gap[1])
    assert np.abs(distal - one[10:] - gap).max() < 1e-3 * abs(gap[1])


def test_inserting_the_base_moves_the_joined_rods():
    """The base support's insertion and rotation carry the rods joined to it."""
    data = joined(1e6)
    at_rest = _solve(data)
    data["rods"]["proximal"]["base"] = {"insertion": 0.01}
    moved = _solve(data)
    for rod in ("proximal", "distal"):
        shift = moved.rods[rod].positions - at_rest.rods[rod].positions
        assert np.abs(shift - [0.01, 0.0, 0.0]).max() < 1e-12


def _with(edit) -> dict:
    data = joined(1e6)
    edit(data["rods"])
    return data


@pytest.mark.parametrize(("edit", "message"), [
    (lambda r: r["distal"]["joint"].update(rod="middle"),
     r"^rods\.distal\.joint\.rod = 'middle': no such rod"),
    (lambda r: r["distal"]["joint"].update(rod="distal"),
     r"^rods\.distal\.joint\.rod = 'distal': a rod cannot be joined to itself"),
    (lambda r: r["distal"].update(clamp="frame"),
     r"^rods\.distal\.clamp = 'frame': the base is also held by rods\.distal\.joint"),
    (lambda r: r["distal"]["joint"].update(s=0.07),
     r"^rods\.distal\.joint\.s = 0\.07: beyond rod 'proximal'"),
    (lambda r: r["distal"]["joint"].update(s=0.031),
     r"^rods\.distal\.joint\.s = 0\.031: between two nodes of rod 'proximal'"),
    (lambda r: r["distal"].update(base={"insertion": 0.01}),
     r"^rods\.distal\.base: a joined rod's base follows its joint"),
    (lambda r: r["proximal"].update(
        clamp="free", terms=["stretch", "bend_twist", "centerline", "joint"],
        joint={"rod": "distal", "s": 0.0}),
     r"the joints close a loop"),
])
def test_bad_joints_are_one_line_scene_errors(edit, message):
    with pytest.raises(SceneError, match=message) as error:
        Scene.from_dict(_with(edit))
    assert "\n" not in str(error.value)


def test_a_joint_on_a_tendon_rod_is_refused():
    """A tendon is anchored to its catheter by its coupling terms (its termination); a
    joint on it as well is refused."""
    data = copy.deepcopy(rodsim.load_scene("table3-catheter1").data)
    data["rods"]["tendon"]["terms"].append("joint")
    data["rods"]["tendon"]["joint"] = {"rod": "catheter", "s": 0.0}
    with pytest.raises(SceneError, match=r"^rods\.tendon\.joint: rod 'tendon' is a tendon"):
        Scene.from_dict(data)


def test_a_joint_between_two_sections_is_second_order():
    """A 0.072 m rod of radius 6 mm welded to a 0.048 m rod of radius 4 mm, tip force P
    small enough for linear beam theory (tip deflection 2.5e-4 L): the tip deflection is
    P[(L³ − L₂³)/(3 E I₁) + L₂³/(3 E I₂)] (∫ M²/EI) plus the model's two penalty
    compliances, P L/K_P (the centerline penalty acting as a shear compliance) and P/K_J
    (the joint), and the error falls at second order in N. With rod B's stiffness alone at
    the joint element instead of the two half segments in series the order drops to 1.1.
    (Finer N puts the load under the round-off of the internal forces.)"""
    e, l1, l2, r1, r2, penalty = 5.9e6, 0.072, 0.048, 0.006, 0.004, 1e6
    ei1, ei2 = e * np.pi * r1**4 / 4, e * np.pi * r2**4 / 4
    length = l1 + l2
    force = 1e-3 * length * 3 * ei2 / length**3
    expected = (force * ((length**3 - l2**3) / (3 * ei1) + l2**3 / (3 * ei2))
                + force / penalty + force * length / penalty)
    errors = []
    for k in (1, 2, 4):
        data = {"name": "two-sections", "solver": {"static": {"max_newton": 200}}, "rods": {
            "proximal": _rod(l1, 3 * k + 1, radius=r1, centerline={"K_P": penalty}),
            "distal": _rod(l2, 2 * k + 1, radius=r2, clamp="free",
                           terms=["stretch", "bend_twist", "centerline", "joint", "tip_load"],
                           centerline={"K_P": penalty},
                           joint={"rod": "proximal", "s": l1, "K_J": penalty},
                           tip_load={"force": [0.0, -force, 0.0]})}}
        errors.append(abs(-_solve(data).tip("distal")[1] - expected) / expected)
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    print(f"\ntwo sections: relative tip errors {errors}, orders {orders}")
    assert errors[-1] < 3e-3
    assert np.all(orders > 1.9) and np.all(orders < 2.1)


def test_the_base_of_a_joined_rod_is_no_actuation_value():
    """A joined rod's base follows its joint: ramping its base is refused, not ignored."""
    scene = Scene.from_dict(joined(1e6))
    with pytest.raises(SceneError, match=r"rod 'distal' is joined to another rod"):
        rodsim.track(scene, {"rods.distal.base.insertion": [0.0, 0.01]}, "static")


def test_the_joint_is_found_by_its_declaration_not_its_name():
    """The joined base and the joint's node (``s``) are refused as parameters by the term's
    ``joins_rods``; its stiffness and a supported rod's base are parameters."""
    from rodsim.app.inverse.parameter_keys import numeric_key
    from rodsim.core.anchors import scene_joints

    scene = Scene.from_dict(joined(1e6))
    assert list(scene_joints(scene)) == ["distal"]
    assert scene_joints(scene)["distal"].rod == "proximal"
    with pytest.raises(SceneError, match="changes the discretisation"):
        numeric_key(scene, "rods.distal.joint.s")
    with pytest.raises(SceneError, match="is joined to another rod"):
        numeric_key(scene, "rods.distal.base.insertion")
    numeric_key(scene, "rods.distal.joint.K_J")
    numeric_key(scene, "rods.proximal.base.insertion")
