"""The support kind contract (rodsim/core/supports.py, ``SupportKind``): every registered kind
builds on a small rod, removes exactly the coordinates it says it holds (at their held
values), hands the bending term the frame element it says it does, and with the kind in
place the model's F is −∂E/∂x and its J is ∂F/∂x by central differences.

A new kind adds its example scene to ``EXAMPLES`` (the walk fails on a kind without one)."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

import rodsim
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.core.supports import Support, SupportKind, registered_support_kinds
from rodsim.core.terms import term_class
from rodsim.core.terms.bend_twist import BendTwist

FD_RELATIVE_STEP = 1e-6
TOLERANCE = 1e-6


def _rod(**values: Any) -> dict[str, Any]:
    rod = {"length": 0.1, "radius": 0.003, "youngs_modulus": 3e6, "stretch_modulus": 4e6,
           "poisson_ratio": 0.35, "density": 1100.0, "nodes": 7, "clamp": "frame",
           "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
           "tip_load": {"force": [0.01, -0.02, 0.015]}} | values
    if "tip_load" not in rod["terms"]:
        del rod["tip_load"]
    return rod


#: kind → (scene, the rod held by the kind, the support's name: "base" or a node support's).
EXAMPLES: dict[str, tuple[dict[str, Any], str, str]] = {
    "frame": ({"name": "kind-frame", "rods": {"rod": _rod(
        base={"insertion": 0.01, "rotation": 0.4},
        supports={"guide": {"s": 0.05, "orientation": True,
                            "displacement": [0.0, 0.001, -0.002]}})}}, "rod", "base"),
    "first_segment": ({"name": "kind-first-segment", "rods": {"rod": _rod(
        clamp="first_segment", origin=[0.0, 0.02, 0.01])}}, "rod", "base"),
    "orientation": ({
        "name": "kind-orientation",
        "rods": {"catheter": _rod(nodes=6, terms=["stretch", "bend_twist", "centerline"]),
                 "tendon": _rod(radius=0.0005, youngs_modulus=1e8, stretch_modulus=1e8,
                                nodes=6, clamp="orientation",
                                terms=["stretch", "bend_twist", "centerline"])},
        "tendons": {"tendon": {
            "catheter": "catheter", "offset": 0.002, "direction": [0.6, 0.8],
            "coupling": "conserving",
            "terms": ["lumen", "endpoint_compliance", "endpoint_coupling", "tendon_actuation"],
            "lumen": {"K_L": 500.0}, "endpoint_compliance": {"K_E": 800.0},
            "endpoint_coupling": {"K_C": 1e4},
            "tendon_actuation": {"force": 1.5, "point": "proximal"}}}}, "tendon", "base"),
    "free": ({"name": "kind-free", "rods": {
        "proximal": _rod(nodes=5, terms=["stretch", "bend_twist", "centerline"]),
        "distal": _rod(length=0.06, nodes=5, clamp="free",
                       terms=["stretch", "bend_twist", "centerline", "joint", "tip_load"],
                       joint={"rod": "proximal", "s": 0.1, "K_J": 3e3})}}, "distal", "base"),
    "elastic": ({"name": "kind-elastic", "rods": {"rod": _rod(
        clamp="elastic", origin=[0.0, 0.01, 0.0],
        base={"insertion": 0.004, "rotation": -0.7, "translational_stiffness": 40.0,
              "rotational_stiffness": 2e-3, "torsional_stiffness": 7e-4})}}, "rod", "base"),
    "position": ({"name": "kind-position", "rods": {"rod": _rod(
        supports={"pin": {"s": 0.1, "displacement": [0.0, 0.002, 0.001]}})}}, "rod", "pin"),
}


def _support(model: Model, rod: str, which: str) -> Support:
    held = model.rods[rod]
    if which == "base":
        return held.support
    table = model.scene.support_tables(rod)
    index = list(table).index(which)
    return held.node_supports[index]


def _perturbed(model: Model, rng: np.random.Generator) -> np.ndarray:
    """Free coordinates of a state well away from rest: positions moved by a few percent of
    the length, quaternions turned by up to 0.2 rad and scaled off the unit sphere."""
    x = np.zeros(model.n)
    quaternion = model.is_quaternion
    x[~quaternion] = 0.03 * model.length_scale * rng.standard_normal(np.sum(~quaternion))
    x[quaternion] = 0.08 * rng.standard_normal(np.sum(quaternion))
    return x


def _central(function: Any, x: np.ndarray, steps: np.ndarray) -> np.ndarray:
    columns = []
    for i, h in enumerate(steps):
        plus, minus = x.copy(), x.copy()
        plus[i] += h
        minus[i] -= h
        columns.append((np.atleast_1d(function(plus)) - np.atleast_1d(function(minus)))
                       / (2 * h))
    return np.array(columns).T


def test_every_registered_kind_has_an_example():
    assert set(registered_support_kinds()) <= set(EXAMPLES), (
        "a support kind without an example scene in tests/test_support_kinds.py: "
        f"{sorted(set(registered_support_kinds()) - set(EXAMPLES))}")


@pytest.mark.parametrize("name", sorted(registered_support_kinds()))
def test_a_kind_holds_what_it_says(name):
    kind = registered_support_kinds()[name]
    scene, rod_name, which = EXAMPLES[name]
    model = rodsim.build_model(copy.deepcopy(scene))
    support = _support(model, rod_name, which)
    assert support.kind is kind
    assert (kind.at_base if which == "base" else kind.at_node)
    rod = model.rods[rod_name]
    layout = rod.layout
    fixed = support.fixed_index(layout)
    free = np.zeros(model.full_size, dtype=bool)
    free[model.free] = True
    assert not np.any(free[fixed]), "a coordinate the kind holds is free"
    node = support.node
    position = layout.position_index[node]
    first = layout.quaternion_index[min(node, len(layout.quaternion_index) - 1)]
    # What it does not hold stays free (no other support on this node or segment here).
    assert np.all(free[position]) != kind.holds_position
    assert np.all(free[first]) != kind.holds_first_segment
    # The held coordinates keep their held values at any state.
    full = model.full(_perturbed(model, np.random.default_rng(3)))
    if kind.holds_position:
        np.testing.assert_array_equal(full[position], support.position)
    if kind.holds_first_segment:
        np.testing.assert_array_equal(full[first], rod.base_quaternion)
    # The bending term's frame element: the support frame on one side of the element(s)
    # at the held node, exactly when the kind says so.
    bend = next(t for t in model.terms if isinstance(t, BendTwist) and t.rod is rod)
    quaternions = layout.quaternion_index
    at_node = [i for i, side in enumerate(bend._fixed) if side and (
        (side == 1 and bend.dofs[i, 0] == quaternions[min(node, len(quaternions) - 1)][0])
        or (side == 2 and node > 0 and bend.dofs[i, 0] == quaternions[node - 1][0]))]
    assert bool(at_node) == kind.frame_element
    for i in at_node:
        np.testing.assert_array_equal(bend._frames[i], support.frame)
    # The terms the kind adds at a base are in the model, under the rod's key "base": for a
    # kind with an energy, the generic support term asking this kind, once.
    if which == "base":
        added = kind.terms(model.scene.data["rods"][rod_name].get("base") or {})
        mine = [(type(term).key, term.options) for term, key in
                zip(model.terms, model.term_keys, strict=True) if key == ("rods", rod_name, "base")]
        assert mine == [(key, term_class(key, values).Options.of(values))
                        for key, values in added]
        energies = [term for term, key in zip(model.terms, model.term_keys, strict=True)
                    if key == ("rods", rod_name, "base")
                    and getattr(term, "support_kind", None) is kind]
        assert len(energies) == kind.has_energy
        for term in energies:
            assert type(term).scope == "support" and term.dofs.shape == (1, 7)
        # An older scene's term for this kind is pointed to the kind in one line.
        for key in kind.former_terms:
            listed = copy.deepcopy(scene)
            listed["rods"][rod_name]["terms"] = [*listed["rods"][rod_name].get(
                "terms", ["stretch", "bend_twist", "centerline"]), key]
            with pytest.raises(SceneError, match=rf"^rods\.{rod_name}\.{key}: .*clamp = "
                               rf"'{name}'") as refused:
                Scene.from_dict(listed)
            assert "\n" not in str(refused.value)


def _local_state(rng: np.random.Generator, support: Support) -> np.ndarray:
    """(r, q) of a held node well away from its support: moved by 1 mm, turned by up to
    0.3 rad and scaled off the unit sphere."""
    return np.concatenate([support.position + 1e-3 * rng.standard_normal(3),
                           support.frame + 0.15 * rng.standard_normal(4)])


def check_energy_methods(kind: type[SupportKind], constants: dict[str, Any],
                         support: Support, seed: int) -> None:
    """A kind's ``forces`` is −∂``energy``/∂x and its ``jacobian`` ∂``forces``/∂x (and
    symmetric) by central differences, at random states of its 7 coordinates."""
    rng = np.random.default_rng(seed)
    for _ in range(3):
        x = _local_state(rng, support)
        steps = np.array([1e-7] * 3 + [1e-6] * 4)
        force = kind.forces(constants, x)
        gradient = _central(lambda y: kind.energy(constants, y), x, steps)[0]
        assert np.max(np.abs(force + gradient)) < TOLERANCE * np.max(np.abs(force))
        jac, jac_fd = kind.jacobian(constants, x), _central(
            lambda y: kind.forces(constants, y), x, steps)
        for rows in (slice(0, 3), slice(3, 7)):
            for cols in (slice(0, 3), slice(3, 7)):
                scale = max(np.max(np.abs(jac_fd[rows, cols])), 1e-300)
                assert np.max(np.abs(jac[rows, cols] - jac_fd[rows, cols])) < TOLERANCE * scale
        np.testing.assert_allclose(jac, jac.T, rtol=0.0, atol=1e-12 * np.max(np.abs(jac)))


@pytest.mark.parametrize("name", sorted(n for n, k in registered_support_kinds().items()
                                        if k.has_energy))
def test_an_energetic_kind_s_force_and_jacobian_are_its_energy_s(name):
    kind = registered_support_kinds()[name]
    scene, rod_name, _ = EXAMPLES[name]
    model = rodsim.build_model(copy.deepcopy(scene))
    term = next(t for t in model.terms if getattr(t, "support_kind", None) is kind)
    check_energy_methods(kind, term.constants, model.rods[rod_name].support,
                         len(name))


@pytest.mark.parametrize("name", sorted(registered_support_kinds()))
def test_force_and_jacobian_with_the_kind_in_place_match_finite_differences(name):
    scene, _, _ = EXAMPLES[name]
    model = rodsim.build_model(copy.deepcopy(scene))
    x = _perturbed(model, np.random.default_rng(list(map(ord, name))))
    model = model.reregistered(x) or model  # a tendon's registration at this state
    steps = FD_RELATIVE_STEP * np.where(model.is_quaternion, 1.0, model.length_scale)
    force = model.force(x)
    if all(term.conservative for term in model.terms):
        gradient = _central(model.energy, x, steps)[0]
        assert np.max(np.abs(force + gradient)) < TOLERANCE * np.max(np.abs(force))
    jac = model.jacobian(x).toarray()
    jac_fd = _central(model.force, x, steps)
    quaternion = model.is_quaternion
    for rows in (quaternion, ~quaternion):  # blocks differ by orders of magnitude
        for cols in (quaternion, ~quaternion):
            block, block_fd = jac[np.ix_(rows, cols)], jac_fd[np.ix_(rows, cols)]
            scale = max(np.max(np.abs(block_fd), initial=0.0), 1e-300)
            assert np.max(np.abs(block - block_fd), initial=0.0) < TOLERANCE * scale, name


#: What the kinds that predate the registry hold (position, q_0, frame element; base, node):
#: the registry must keep it.
BUILT_IN = {"frame": (True, False, True, True, True),
            "first_segment": (True, True, False, True, False),
            "orientation": (False, False, True, True, False),
            "free": (False, False, False, True, False),
            "position": (True, False, False, False, True)}


@pytest.mark.parametrize("name", sorted(BUILT_IN))
def test_the_built_in_kinds_hold_what_they_held(name):
    kind = registered_support_kinds()[name]
    assert (kind.holds_position, kind.holds_first_segment, kind.frame_element, kind.at_base,
            kind.at_node) == BUILT_IN[name]


#: base place → (an example scene of EXAMPLES, the rod it places), for the place contract.
PLACE_EXAMPLES: dict[str, tuple[str, str]] = {
    "origin": ("frame", "rod"), "tendon": ("orientation", "tendon"), "joined": ("free", "distal"),
}


def test_every_registered_base_place_has_an_example():
    from rodsim.core.base_places import registered_base_places

    assert set(registered_base_places()) <= set(PLACE_EXAMPLES), (
        "a base place without an example in PLACE_EXAMPLES (tests/test_support_kinds.py): "
        f"{sorted(set(registered_base_places()) - set(PLACE_EXAMPLES))}")


@pytest.mark.parametrize("name", sorted(PLACE_EXAMPLES))
def test_a_base_place_places_the_rods_it_claims(name):
    """The place that claims a rod puts its base: the model's rod holds the support the
    place gives, built after the rod it is placed on (its parent), which holds its base
    where its own place says; a place's own claim is checked, not inferred."""
    from rodsim.core.base_places import base_place, registered_base_places
    from rodsim.core.model import build_order

    place = registered_base_places()[name]
    example, rod_name = PLACE_EXAMPLES[name]
    scene = Scene.from_dict(copy.deepcopy(EXAMPLES[example][0]))
    assert base_place(scene, rod_name) is place
    model = rodsim.build_model(scene)
    expected = place.support(scene, rod_name, model.rods)
    support = model.rods[rod_name].support
    assert support.holds == scene.rods[rod_name].clamp
    np.testing.assert_array_equal(support.position, expected.position)
    np.testing.assert_array_equal(support.frame, expected.frame)
    order = build_order(scene)
    parent = place.parent(scene, rod_name)
    if parent is not None:
        assert order.index(parent) < order.index(rod_name)
        assert model.rods[parent].layout.offset < model.rods[rod_name].layout.offset
