"""A string tendon's routing must be sampled by the catheter's nodes (rodsim/core/routing.py,
"Sampling"): a helix with fewer than SEGMENTS_PER_TURN segments per turn, or a table with
knots closer than SEGMENTS_PER_KNOT segments, is refused with the number of nodes that is
enough; above the rule the tip converges at second order to the Rucker–Webster reference
(rodsim/core/analytic/tendon_bvp.py) on a seeded family of helices (issue 37, item 3a).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import rodsim
from rodsim.core.analytic.tendon_bvp import scene_reference
from rodsim.core.routing import SEGMENTS_PER_KNOT, SEGMENTS_PER_TURN
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError


def test_an_aliased_helix_is_refused_with_the_nodes_that_are_enough():
    """helix_pitch = 0.004 m on catheter-helical (h = 0.004 m at N = 41: one segment per
    turn) moved the tip 0.159 L sideways with exit 0; now refused, naming N >= 161."""
    scene = rodsim.load_scene("catheter-helical")
    with pytest.raises(SceneError, match=r"nodes >= 161") as caught:
        scene.with_values({"tendons.helix.tendon_string.helix_pitch": 0.004})
    assert "\n" not in str(caught.value)
    # 161 nodes (4 segments per turn) are accepted, and one fewer is not.
    scene.with_values({"tendons.helix.tendon_string.helix_pitch": 0.004,
                       "rods.catheter.nodes": 161})
    with pytest.raises(SceneError, match="alias"):
        scene.with_values({"tendons.helix.tendon_string.helix_pitch": -0.004,
                           "rods.catheter.nodes": 160})


def test_the_cli_refuses_an_aliased_helix_with_exit_2(capsys):
    from rodsim.app.cli.main import main

    assert main(["run", "catheter-helical", "--set", "helix_pitch=0.004"]) == 2
    err = capsys.readouterr().err
    assert "nodes >= 161" in err and "Traceback" not in err


def _table_scene(nodes: int, knots: list[float]) -> dict:
    return {"name": "table-sampling", "rods": {"c": {
        "length": 0.1, "radius": 0.004, "youngs_modulus": 5e6, "stretch_modulus": 5e6,
        "density": 1100.0, "nodes": nodes, "clamp": "frame",
        "terms": ["stretch", "bend_twist", "centerline"]}},
        "tendons": {"t": {"catheter": "c", "coupling": "string", "tendon_string": {
            "tension": 0.5, "spacers": True, "routing": "table", "table_s": knots,
            "table_y": [0.002 * (-1) ** i for i in range(len(knots))],
            "table_z": [0.0] * len(knots)}}}}


def test_a_table_with_knots_closer_than_the_segments_is_refused():
    knots = [0.0, 0.04, 0.045, 0.1]  # 5 mm apart in the middle: h <= 2.5 mm, N >= 41
    assert SEGMENTS_PER_KNOT == 2
    with pytest.raises(SceneError, match=r"nodes >= 41"):
        Scene.from_dict(_table_scene(21, knots))
    Scene.from_dict(_table_scene(41, knots))
    # Knots outside the tendon's span do not count (a tendon ending at 0.08 m; knots beyond
    # the rod itself are refused by another rule, tests/test_small_defects.py).
    scene = _table_scene(21, [0.0, 0.04, 0.08, 0.095, 0.1])
    scene["tendons"]["t"]["tendon_string"]["end"] = 0.08
    Scene.from_dict(scene)
    with pytest.raises(SceneError, match=r"nodes >= "):
        Scene.from_dict(_table_scene(21, [0.0, 0.04, 0.08, 0.095, 0.1]))


def _helix(rng: np.random.Generator) -> tuple[Scene, float]:
    """One user-like helical robot: nitinol or steel wire on spacer disks, or a soft polymer
    catheter with the tendon in its wall; 4 to 10 segments per turn, either hand."""
    material = int(rng.integers(3))
    modulus = (54e9, 200e9, 5e6)[material]
    radius = (0.7e-3, 0.5e-3, 4e-3)[material]
    length = float(rng.uniform(0.08, 0.25))
    nodes = int(rng.integers(21, 41))
    per_turn = float(rng.uniform(SEGMENTS_PER_TURN, 10.0))
    pitch = per_turn * length / (nodes - 1) * float(rng.choice([-1.0, 1.0]))
    spacers = material != 2
    helix = float(rng.uniform(1.5, 10.0) * radius if spacers else rng.uniform(0.3, 0.8) * radius)
    bending = modulus * math.pi * radius**4 / 4
    tension = float(rng.uniform(0.2, 1.0) * bending / (helix * length))
    area = math.pi * radius**2
    data = {"name": "helix-family", "rods": {"c": {
        "length": length, "radius": radius, "youngs_modulus": modulus,
        "stretch_modulus": modulus, "poisson_ratio": 0.3, "density": 6000.0, "nodes": nodes,
        "clamp": "frame", "terms": ["stretch", "bend_twist", "centerline"],
        "centerline": {"K_P": modulus / 2.6 * area}}},
        "tendons": {"h": {"catheter": "c", "coupling": "string", "tendon_string": {
            "tension": tension, "spacers": spacers, "routing": "helix",
            "helix_radius": helix, "helix_pitch": pitch,
            "helix_phase": float(rng.uniform(0.0, 2 * math.pi))}}},
        "solver": {"integrator": "static"}}
    return Scene.from_dict(data), length


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_accepted_helices_converge_to_the_reference_at_second_order(seed):
    """Measured (seed 37 family): 1e-3 to 3e-3 L at 4 to 6 segments per turn, order 2.05 to
    2.11 on halving h: the discretisation's own error, no aliasing."""
    scene, length = _helix(np.random.default_rng(3700 + seed))
    reference = scene_reference(scene).tip
    nodes = scene.rods["c"].nodes
    errors = []
    for n in (nodes, 2 * nodes - 1):
        result = rodsim.solve(scene.with_values({"rods.c.nodes": n}), "static")
        assert result.success, result.message
        errors.append(float(np.linalg.norm(result.rods["c"].positions[-1] - reference))
                      / length)
    assert errors[0] <= 5e-3, errors
    assert math.log2(errors[0] / errors[1]) >= 1.8, errors


@pytest.mark.slow
def test_the_refused_case_at_enough_nodes_agrees_with_the_reference():
    """catheter-helical at helix_pitch = 0.004 m and N = 161 (the refusal's minimum): tip
    within 5e-4 L of the reference (measured 1.4e-4 L), and no sideways tip (y ~ 0)."""
    scene = rodsim.load_scene("catheter-helical").with_values(
        {"tendons.helix.tendon_string.helix_pitch": 0.004, "rods.catheter.nodes": 161})
    reference = scene_reference(scene).tip
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    tip = result.rods["catheter"].positions[-1]
    assert np.linalg.norm(tip - reference) / 0.16 < 5e-4
    assert abs(tip[1]) / 0.16 < 5e-3
