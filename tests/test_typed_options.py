"""Typed options: the rod, tendon, generic solver and term tables are read through frozen
dataclasses made from their Parameter declarations (rodsim.core.schema.options_type), views
of the resolved scene dict (which archives store as JSON and which stays as it is)."""

from __future__ import annotations

import dataclasses

import pytest

import rodsim
from rodsim.core.model import Model
from rodsim.core.rod.rod import ROD_PARAMETERS, RodOptions
from rodsim.core.scene import SOLVER_PARAMETERS, SolverSettings, scene_paths
from rodsim.core.tendon import TENDON_PARAMETERS, TendonOptions
from rodsim.core.terms import registered_terms


def declared(parameters) -> dict:
    return {p.name: p.default for p in parameters}


@pytest.mark.parametrize("cls, parameters", [
    (RodOptions, ROD_PARAMETERS), (TendonOptions, TENDON_PARAMETERS),
    (SolverSettings, SOLVER_PARAMETERS),
    *[(term.Options, term.parameters) for term in registered_terms().values()]],
    ids=lambda x: getattr(x, "__name__", ""))
def test_each_options_type_has_one_field_per_declared_parameter(cls, parameters):
    fields = dataclasses.fields(cls)
    assert [f.name for f in fields] == [p.name for p in parameters]
    assert cls.__dataclass_params__.frozen
    defaults = {p.name: p.default for p in parameters if p.default is not None}
    if len(defaults) == len(parameters):  # every value has a default: the defaults agree
        assert dataclasses.asdict(cls()) == declared(parameters)


@pytest.mark.parametrize("name", sorted(scene_paths()))
def test_the_views_agree_with_the_resolved_scene(name):
    scene = rodsim.load_scene(name)
    data = scene.data
    assert dataclasses.asdict(scene.solver) == {p.name: data["solver"][p.name]
                                                for p in SOLVER_PARAMETERS}
    for rod, options in scene.rods.items():
        assert dataclasses.asdict(options) == {p.name: data["rods"][rod][p.name]
                                               for p in ROD_PARAMETERS}
        for term in options.terms:
            assert dataclasses.asdict(scene.term_options("rods", rod, term)) == \
                data["rods"][rod][term]
    for tendon, options in scene.tendons.items():
        assert dataclasses.asdict(options) == {p.name: data["tendons"][tendon][p.name]
                                               for p in TENDON_PARAMETERS}
        for term in options.terms:
            assert dataclasses.asdict(scene.term_options("tendons", tendon, term)) == \
                data["tendons"][tendon][term]
    model = Model(scene, "numpy")
    for term in model.terms:
        assert isinstance(term.options, type(term).Options)
    for rod in model.rods.values():
        assert isinstance(rod.options, RodOptions)


def test_a_term_not_listed_has_no_options():
    scene = rodsim.load_scene("table1-50g")
    assert scene.term_options("rods", "catheter", "gravity") is None
