"""Model.with_values (rodsim/core/model.py): a model whose scene differs only in term options
rebuilds those terms alone and shares everything else — and gives the same numbers as the
full re-assembly (Model.with_scene, itself checked against Model(scene) by the tracking
tests): F, J, energy, the scales and the round-off floor, bit for bit; any other change
falls back to the re-assembly. A track made with it reaches the same equilibria."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with
from rodsim.core.model import Model

TENDON_FORCE = "tendons.tendon.tendon_actuation.force"


def _same_numbers(a: Model, b: Model, x: np.ndarray) -> None:
    fa, ja = a.evaluate(x)
    fb, jb = b.evaluate(x)
    np.testing.assert_array_equal(fa, fb)
    np.testing.assert_array_equal(ja, jb)
    np.testing.assert_array_equal(a.pattern.indices, b.pattern.indices)
    np.testing.assert_array_equal(a.pattern.indptr, b.pattern.indptr)
    assert a.force_scale == b.force_scale
    assert a.residual_floor == b.residual_floor
    np.testing.assert_array_equal(a.residual_weight, b.residual_weight)
    np.testing.assert_array_equal(a.rest_stiffness, b.rest_stiffness)
    if a.conservative:
        assert a.energy(x) == b.energy(x)


@pytest.mark.parametrize("scene_name, key, value", [
    ("table3-catheter1", TENDON_FORCE, 2.5),
    ("table1-50g", "tip_load.mass", 0.08),
    ("tendon-conserving", "tendon_actuation.force", 1.5),
    ("tdcr-two-segment", "tendons.s1a.tendon_string.tension", 2.0),
])
def test_a_changed_term_option_gives_the_numbers_of_a_full_reassembly(scene_name, key, value):
    scene = rodsim.load_scene(scene_name)
    model = Model(scene)
    x = model.x0 + 1e-4 * np.random.default_rng(1).standard_normal(model.n)
    moved = model.reregistered(x)  # a registration other than the rest one, if any
    model = moved or model
    model.evaluate(x)  # its kernels loaded, as in a track
    keys = numeric_keys(scene, [key])
    other = scene_with(scene, keys, [value])
    fast = model.with_values(other)
    assert fast.pattern is model.pattern  # shared, not rebuilt
    assert fast.scene is other
    changed = [k for k, (a, b) in enumerate(zip(fast.terms, model.terms, strict=True))
               if a is not b]
    assert len(changed) == 1  # only the term that owns the value
    _same_numbers(fast, model.with_scene(other), x)
    # and the force really changed with the value (the test can see a stale term)
    assert not np.array_equal(fast.force(x), model.force(x))


def test_a_string_tendons_new_tension_keeps_its_routing_points_and_other_options_do_not():
    scene = rodsim.load_scene("tdcr-two-segment")
    model = Model(scene)
    index = model.term_keys.index(("tendons", "s1a", "tendon_string"))
    pulled = model.with_values(scene_with(scene, numeric_keys(
        scene, ["tendons.s1a.tendon_string.tension"]), [2.0]))
    term, before = pulled.terms[index], model.terms[index]
    assert term is not before and term.tension == 2.0 and before.tension != 2.0
    assert term.points is before.points  # the routing is not recomputed for a tension
    # the copy is the term the constructor builds from the same options
    built = type(term)(pulled.tendons["s1a"], term.options)
    for name, value in built.kernel_arguments().items():
        np.testing.assert_array_equal(term.kernel_arguments()[name], value)
    # only that term's share of the rest stiffness was evaluated again
    for k, (_, _, share) in model._diagonal_shares.items():
        assert (pulled._diagonal_shares[k][2] is share) == (k != index), k
    # and the shares add up to the diagonal of one whole Jacobian at rest (to round-off)
    whole = np.abs(pulled.jacobian_data(pulled.x0)[pulled._diagonal_slots])
    np.testing.assert_allclose(pulled.rest_stiffness, whole, rtol=1e-14, atol=0)
    assert not np.array_equal(pulled.rest_stiffness, model.rest_stiffness)  # T stiffens
    # another option of the term (where the tendon ends) builds it anew
    moved = model.with_values(scene_with(scene, numeric_keys(
        scene, ["tendons.s1a.tendon_string.end"]), [0.9 * before.end]))
    assert moved.terms[index].points is not before.points


def test_an_unchanged_scene_shares_the_model_and_other_changes_fall_back():
    scene = rodsim.load_scene("table1-50g")
    model = Model(scene)
    same = model.with_values(rodsim.load_scene("table1-50g"))
    assert same.terms == model.terms and same.pattern is model.pattern
    x = model.x0 + 1e-4
    # a rod's own value (the modulus): every term of the rod changes, the full path
    stiffer = scene.with_overrides(["youngs_modulus=2e9"])
    _same_numbers(model.with_values(stiffer), model.with_scene(stiffer), x)
    # a layout change is refused as by with_scene
    with pytest.raises(ValueError, match="layout"):
        model.with_values(scene.with_overrides(["nodes=12"]))


def test_a_track_with_shared_models_reaches_the_same_equilibria(monkeypatch):
    scene = rodsim.load_scene("table3-catheter1")
    ramp = {TENDON_FORCE: np.linspace(0.0, 4.0, 41)}
    fast = rodsim.track(scene, ramp, estimates=False)
    monkeypatch.setattr(Model, "with_values", Model.with_scene)
    full = rodsim.track(scene, ramp, estimates=False)
    assert fast.success and full.success
    np.testing.assert_allclose(np.array(fast.states), np.array(full.states), rtol=0,
                               atol=1e-14)
    assert fast.iterations == full.iterations


def test_a_frictionless_string_tendons_share_is_its_tension_times_the_unit_share(monkeypatch):
    """The rest-diagonal share of a frictionless string tendon (Term.linear_unit) is its
    tension times the share at 1 N, found once and kept by the model's copies: a new
    tension evaluates no tendon, and the share is the one its own evaluation gives."""
    scene = rodsim.load_scene("tdcr-two-segment")
    model = Model(scene)
    index = model.term_keys.index(("tendons", "s1a", "tendon_string"))
    keys = numeric_keys(scene, ["tendons.s1a.tendon_string.tension"])
    evaluated: list[object] = []
    original = Model._share

    def counted(self, position, term, *args, **kwargs):
        evaluated.append(term)
        return original(self, position, term, *args, **kwargs)

    monkeypatch.setattr(Model, "_share", counted)
    for tension in (0.5, 2.0, 3.7):
        pulled = model.with_values(scene_with(scene, keys, [tension]))
        term = pulled.terms[index]
        assert term.tension == tension
        target = pulled._term_targets[sum(t.has_jacobian for t in pulled.terms[:index])]
        own = original(pulled, index, term, 1.0, target,
                       pulled.full(pulled.x0), pulled.rest_offsets, [])
        assert np.any(own != 0.0)
        np.testing.assert_allclose(pulled._diagonal_shares[index][2], own, rtol=1e-15,
                                   atol=0)
    assert evaluated == []  # no share evaluated for a new tension: the unit's was kept


def test_copies_of_a_model_never_evaluated_share_its_kernel_groups():
    """A batch's shared model is never evaluated itself: Model.with_values makes its kernel
    units first, so that each copy keeps the string tendons' stacked targets and arrays
    (rodsim/core/kernel_group.py) — and gives the numbers of a model built afresh."""
    from rodsim.core.kernel_group import KernelGroup

    scene = rodsim.load_scene("tdcr-two-segment")
    model = Model(scene)
    keys = numeric_keys(scene, ["tendons.s1a.tendon_string.tension",
                                "tendons.s2b.tendon_string.tension"])
    copies = [model.with_values(scene_with(scene, keys, values))
              for values in ([1.0, 2.0], [2.5, 0.5])]
    groups = [[u for u in c._kernel_unit_list() if isinstance(u, KernelGroup)]
              for c in copies]
    assert groups[0] and len(groups[0]) == len(groups[1])
    for a, b in zip(*groups, strict=True):
        assert a.force_target is b.force_target and a.jacobian_target is b.jacobian_target
        assert a.calls[0].term is not b.calls[0].term  # other tensions
    x = model.x0 + 1e-4 * np.random.default_rng(2).standard_normal(model.n)
    own = Model(scene_with(scene, keys, [2.5, 0.5]))
    np.testing.assert_array_equal(copies[1].force(x), own.force(x))
    np.testing.assert_array_equal(copies[1].jacobian_data(x), own.jacobian_data(x))


def test_the_unloaded_rest_force_is_kept_by_copies_of_other_loads_only():
    """Model.unloaded_rest_force, F(x0, load 0): a copy whose changed terms are loads (new
    tensions, a tip force) takes the one kept by its model, bit for bit what it evaluates
    itself; a model of other scales evaluates its own."""
    scene = rodsim.load_scene("tdcr-two-segment")
    model = Model(scene)
    first = model.unloaded_rest_force()
    loads = numeric_keys(scene, ["tendons.s1a.tendon_string.tension", "tip_load.force[2]"])
    pulled = model.with_values(scene_with(scene, loads, [2.0, 0.03]))
    kept = pulled._rest_units[-1][3]
    again = pulled.unloaded_rest_force()
    np.testing.assert_array_equal(again, pulled.force(pulled.x0, 0.0))
    np.testing.assert_array_equal(again, first)
    assert pulled._rest_units[-1][3] is kept  # taken again, not evaluated
    scales = list(pulled._scale_list)
    scales[0] = 2.0 * scales[0]  # the stretch term scaled (a continuation): not the same
    pulled._scale_list = scales
    moved = pulled.unloaded_rest_force()
    np.testing.assert_array_equal(moved, pulled.force(pulled.x0, 0.0))
    assert pulled._rest_units[-1][3] is not kept  # evaluated anew
