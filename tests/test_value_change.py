"""``rodsim.core.value_change.force_change``: F of a model of other term values minus F of
the model, from the changed terms alone, against the difference of the two models' own F
(``Model.with_values``, then ``Model.force``), on the compiled and the numpy paths."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with
from rodsim.core.model import Model
from rodsim.core.value_change import force_change

CASES = [("tdcr-two-segment", ["s1a.tendon_string.tension", "s2b.tendon_string.tension"],
          [3.1, 1.7]),
         ("table3-catheter1", ["tendons.tendon.tendon_actuation.force"], [0.9])]


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
@pytest.mark.parametrize(("name", "keys", "values"), CASES)
def test_force_change_is_the_difference_of_the_two_models(name, keys, values, kernels):
    scene = rodsim.load_scene(name).with_overrides([f"solver.kernels={kernels}"])
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    model = Model(result.scene).reregistered(result.state, exact=True) or Model(result.scene)
    x = result.state
    other = scene_with(model.scene, numeric_keys(model.scene, keys), values)
    change = force_change(model, other, x)
    assert change is not None
    reference = model.with_values(other).force(x) - model.force(x)
    size = np.abs(reference).max()
    assert size > 0.0
    # Round-off of the two models' F (sums of internal forces far above the change).
    assert np.abs(change - reference).max() <= 1e-9 * size


def test_force_change_of_a_moved_base_is_none():
    """A base insertion moves the rest state: no term-only change (the caller builds the
    model)."""
    scene = rodsim.load_scene("table3-catheter1")
    model = Model(scene)
    keys = numeric_keys(scene, ["insertion"])
    assert force_change(model, scene_with(scene, keys, [0.01]), model.x0) is None


@pytest.mark.parametrize(("name", "key"), [
    ("tdcr-two-segment", "s1a.tendon_string.tension"),
    ("table3-catheter1", "tendons.tendon.tendon_actuation.force")])
def test_a_linear_option_is_differenced_on_one_point_as_the_stencil_gives(name, key):
    """A tendon's tension (no friction) and an actuation force: F is linear in them, and the
    one-point difference is the fourth-order stencil's derivative to round-off (measured:
    4.1e-10 and 2.0e-10 of the largest dx/dp)."""
    from rodsim.app.inverse import sensitivity as module

    scene = rodsim.load_scene(name)
    result = rodsim.solve(scene, "static")
    model = module.registered_model(Model(result.scene), result.state)
    keys = numeric_keys(model.scene, [key])
    values = [keys[0].value(model.scene)]
    one = module._linear_column(model, result.state, keys, values, 0)
    assert one is not None
    original = module._linear_column
    try:
        module._linear_column = lambda *args: None  # type: ignore[assignment]
        stencil, _ = module.equilibrium_sensitivity(model, result.state, keys)
    finally:
        module._linear_column = original  # type: ignore[assignment]
    solved, _ = module.equilibrium_sensitivity(model, result.state, keys)
    assert np.abs(solved - stencil).max() <= 1e-6 * np.abs(stencil).max()


def test_a_nonlinear_option_keeps_the_stencil():
    """A string tendon's friction coefficient (T e^{−μθ} along it): not linear (None)."""
    from rodsim.app.inverse import sensitivity as module

    scene = rodsim.load_scene("tdcr-two-segment")
    result = rodsim.solve(scene, "static")
    model = module.registered_model(Model(result.scene), result.state)
    keys = numeric_keys(model.scene, ["s1a.tendon_string.friction"])
    assert module._linear_column(model, result.state, keys,
                                 [keys[0].value(model.scene)], 0) is None


@pytest.mark.parametrize("kernels", ["compiled", "numpy"])
@pytest.mark.parametrize(("key", "tension"), [("s1a.tendon_string.tension", 3.0),
                                              ("s1b.tendon_string.tension", 0.0)])
def test_a_tensions_sensitivity_is_its_unit_force(key, tension, kernels):
    """A frictionless string tendon's force is T times its force at 1 N
    (``Term.linear_unit``): ``unit_forces`` gives ∂F/∂T as that unit force, against the
    difference of F between the models at T + 1 and T (``force_change``), to round-off —
    at a taut tendon and at a slack one (T = 0, whose own force is zero)."""
    from rodsim.core.value_change import unit_forces

    scene = rodsim.load_scene("tdcr-two-segment").with_overrides(
        [f"solver.kernels={kernels}", f"tendons.{key}={tension}"])
    result = rodsim.solve(scene, "static")
    model = Model(result.scene).reregistered(result.state, exact=True) or Model(result.scene)
    x = result.state
    keys = numeric_keys(model.scene, [key])
    assert keys[0].value(model.scene) == tension
    owner = tuple(keys[0].path.split(".")[:3])
    indices = [index for index, term_key in enumerate(model.term_keys) if term_key == owner]
    assert len(indices) == 1
    unit = unit_forces(model, "tension", indices, x)
    assert unit is not None
    change = force_change(model, scene_with(model.scene, keys, [tension + 1.0]), x)
    assert change is not None and np.abs(change).max() > 0.0
    assert np.abs(unit - change).max() <= 1e-12 * np.abs(change).max()
    assert unit_forces(model, "friction", indices, x) is None  # not linear in μ
