"""Sensitivities at equilibrium (rodsim/sensitivity.py) against finite differences of
re-solved equilibria, for every kind of parameter, on one rod and on tendon scenes."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.app.inverse.parameter_keys import numeric_key, scene_with
from rodsim.core.model import Model
from rodsim.core.schema import SceneError

#: Tight static equilibria: the finite differences of re-solves divide their error by 2h.
TIGHT = "tolerance=1e-12"


def _positions(result) -> np.ndarray:
    return np.concatenate([shape.positions for shape in result.rods.values()])


def _resolved_difference(scene, key: str, relative: float = 1e-4) -> np.ndarray:
    """d(positions)/dp by central differences of two re-solved static equilibria."""
    numeric = numeric_key(scene, key)
    value = numeric.value(scene)
    h = relative * abs(value) if value else relative
    shapes = []
    for point in (value - h, value + h):
        result = rodsim.solve(scene_with(scene, [numeric], [point]), "static")
        assert result.success, result.message
        shapes.append(_positions(result))
    return (shapes[1] - shapes[0]) / (2 * h)


CASES = [
    ("table1-50g", ["youngs_modulus", "stretch_modulus", "K_P", "tip_load.mass", "length",
                    "tip_load.force[0]"], ()),
    ("table3-catheter1", ["tendon_actuation.force", "offset", "K_E", "K_L",
                          "catheter.youngs_modulus"], ()),
    ("tendon-conserving", ["tendon_actuation.force", "K_E", "offset"],
     ("catheter.nodes=12", "tendon.nodes=12")),
]


@pytest.mark.parametrize(("name", "keys", "overrides"), CASES, ids=[c[0] for c in CASES])
def test_sensitivity_matches_finite_differences_of_resolved_equilibria(name, keys, overrides):
    scene = rodsim.load_scene(name, [TIGHT, *overrides])
    result = rodsim.solve(scene, "static")
    assert result.success
    sens = rodsim.sensitivity(result, keys)
    assert sens.keys == [numeric_key(scene, k).name for k in keys]
    for column, key in enumerate(keys):
        analytic = np.concatenate([sens.positions[rod][column] for rod in sens.positions])
        numeric = _resolved_difference(scene, key)
        scale = np.abs(numeric).max()
        assert scale > 0, key
        assert np.abs(analytic - numeric).max() < 1e-5 * scale, key


def test_a_tip_load_moves_the_tip_down_and_a_stiffer_rod_moves_it_up():
    result = rodsim.solve(rodsim.load_scene("table1-50g"), "static")
    tip = rodsim.sensitivity(result, ["tip_load.mass", "youngs_modulus"]).tip()
    assert tip[0, 1] < 0 and tip[1, 1] > 0


def test_an_origin_shift_translates_every_node_rigidly():
    """The clamped base moves with the origin: exactly 1 m/m on every node, free or not."""
    result = rodsim.solve(rodsim.load_scene("table1-50g"), "static")
    sens = rodsim.sensitivity(result, ["origin[2]"])
    moved = sens.positions["catheter"][0]
    np.testing.assert_allclose(moved[:, 2], 1.0, atol=1e-8)
    np.testing.assert_allclose(moved[:, :2], 0.0, atol=1e-8)
    np.testing.assert_allclose(sens.quaternions["catheter"][0], 0.0, atol=1e-8)


def test_a_parameter_at_its_lower_bound_gets_a_one_sided_difference():
    """mass = 0 is the bottom of its range: F is linear in it, so one side is exact."""
    scene = rodsim.load_scene("table1-50g", ["tip_load.mass=0", "tip_load.force=[0, -0.5, 0]",
                                             TIGHT])
    result = rodsim.solve(scene, "static")
    sens = rodsim.sensitivity(result, ["tip_load.mass"])
    numeric = _resolved_difference(
        scene.with_values({"rods.catheter.tip_load.mass": 1e-3}), "tip_load.mass")
    # Linear in m g over 1 g: compare with the tangent at 1 g loosely, the sign exactly.
    assert sens.tip()[0, 1] < 0
    np.testing.assert_allclose(sens.positions["catheter"][0], numeric, rtol=0,
                               atol=0.05 * np.abs(numeric).max())


@pytest.mark.parametrize(("key", "reason"), [
    ("catheter.nodes", "discretisation"),
    ("tolerance", "solver setting"),
    ("clamp", "not a number"),
    ("origin", "name one component"),
    ("origin[3]", "3 components"),
    ("no_such_key", "unknown key"),
])
def test_non_differentiable_or_unknown_keys_are_refused(key, reason):
    result = rodsim.solve(rodsim.load_scene("table1-50g", ["nodes=10"]), "static")
    with pytest.raises(SceneError, match=reason):
        rodsim.sensitivity(result, [key])


def test_a_tendon_length_change_alone_is_refused_by_the_scene_rules():
    scene = rodsim.load_scene("tendon-conserving", ["catheter.nodes=10", "tendon.nodes=10"])
    result = rodsim.solve(scene, "static")
    with pytest.raises(SceneError, match="tendon"):
        rodsim.sensitivity(result, ["catheter.length"])


def test_a_failed_result_has_no_sensitivity():
    scene = rodsim.load_scene("table1-50g", ["nodes=10", "solver.static.max_newton=1",
                                             "solver.static.min_load_step=0.5"])
    result = rodsim.solve(scene, "static")
    assert not result.success
    with pytest.raises(ValueError, match="not an equilibrium"):
        rodsim.sensitivity(result, ["K_P"])


def test_the_model_passed_in_is_reused_and_left_unchanged():
    scene = rodsim.load_scene("table3-catheter1")
    model = Model(scene)
    result = rodsim.solve(scene, "static", model=model)
    lumen = next(term for term in model.terms if term.name == "lumen")
    parents = lumen.parent.copy()
    first = rodsim.sensitivity(result, ["K_E"], model=model)
    np.testing.assert_array_equal(lumen.parent, parents)
    second = rodsim.sensitivity(result, ["K_E"])
    np.testing.assert_allclose(first.state, second.state, rtol=1e-12, atol=0)
