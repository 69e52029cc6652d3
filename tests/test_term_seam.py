"""The term ↔ model seam (issue 21 item 3): what the model asks of a term is declared on the
term base class (rodsim/core/terms/base.py), and the model knows no term by name."""

from __future__ import annotations

import importlib
import inspect
import math

import numpy as np
import pytest

import rodsim
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.terms import registered_terms
from rodsim.core.terms.base import REGISTRY, Term

MODEL_PARTS = ("model_base", "model_pattern", "model_manifold", "model_evaluation",
               "model_scales", "model")


@pytest.mark.parametrize("part", MODEL_PARTS)
def test_the_model_names_no_term(part):
    source = inspect.getsource(importlib.import_module(f"rodsim.core.{part}"))
    named = [name for name in registered_terms() if f'"{name}"' in source
             or f"'{name}'" in source]
    assert not named, f"rodsim/core/{part}.py names the terms {named}: use a Term hook"


#: Modules above the terms that ask a term what it declares (``Term.unilateral``,
#: ``figure_layer``, ``penalty_advice``, ``joins_rods``, ``holds_base``), never its name.
DECLARATION_READERS = ("rodsim.solvers.base", "rodsim.core.anchors", "rodsim.app.trust")


@pytest.mark.parametrize("module", DECLARATION_READERS)
def test_the_layers_above_name_no_term(module):
    source = inspect.getsource(importlib.import_module(module))
    named = [name for name in registered_terms() if f'"{name}"' in source
             or f"'{name}'" in source]
    assert not named, f"{module} names the terms {named}: read a Term declaration"


def test_every_penalty_term_declares_its_penalty_ratio():
    """``penalty_ratio`` is part of the contract: every penalty term of the shipped scenes
    carries a finite positive one (the solvers lower the penalty by it)."""
    penalties = 0
    for name in ("table1-50g", "table3-catheter1", "tendon-conserving"):
        for term in Model(rodsim.load_scene(name)).terms:
            if term.penalty:
                penalties += 1
                assert isinstance(term.penalty_ratio, float)
                assert 0.0 < term.penalty_ratio < math.inf
    assert penalties >= 3
    assert "penalty_ratio" in Term.__annotations__ and "penalty_ratio" in (
        inspect.getsource(Term))


def test_a_penalty_term_without_its_ratio_is_refused(monkeypatch):
    catalogue = registered_terms()
    centerline = catalogue["centerline"]

    class NoRatio(centerline):  # no ``name`` of its own: not registered
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            del self.penalty_ratio

    monkeypatch.setitem(REGISTRY, "centerline", NoRatio)
    with pytest.raises(TypeError, match="penalty term 'centerline' must set"):
        Model(rodsim.load_scene("table1-50g"))


def test_terms_built_from_a_scene_table_come_from_their_hook():
    """Contact terms are built by ``Contact.from_table`` from ``[obstacles.<name>]``, one per
    rod the obstacle lists, under the keys the model has always used."""
    scene = rodsim.load_scene("table1-50g").data
    data = {**scene, "obstacles": {"floor": {"type": "plane", "point": [0.0, -0.05, 0.0],
                                              "normal": [0.0, 1.0, 0.0], "rods": ["catheter"]}}}
    model = Model(Scene.from_dict(data))
    contacts = [(key, term) for key, term in zip(model.term_keys, model.terms, strict=True)
                if term.scene_table]
    assert [key for key, _ in contacts] == [("obstacles", "floor", "catheter")]
    assert contacts[0][1].name == "contact" and contacts[0][1].rod is model.rods["catheter"]


@pytest.mark.parametrize(("name", "kinds"), [("table1-50g", ("exact", "paper", "extensible")),
                                             ("tendon-conserving", ("arc",))])
def test_analytic_references_read_the_rods_without_a_model(name, kinds, monkeypatch):
    """rodsim/core/analytic/reference.py reads E I, E_s A, L and the base from the scene's
    rods (issue 21 item 3): with Model blocked it gives the centerlines the references give
    for the constants of an assembled model's rods."""
    from rodsim.core.analytic import reference
    from rodsim.core.analytic.elastica import exact_elastica
    from rodsim.core.analytic.extensible import extensible_elastica
    from rodsim.core.analytic.tendon_arc import tendon_arc

    scene = rodsim.load_scene(name)
    model = Model(scene)  # the constants of the assembled model, before blocking it
    first = next(iter(model.rods.values()))
    s = np.linspace(0.0, first.length, 17)
    expected = {}
    if name == "table1-50g":
        load = scene.term_options("rods", first.name, "tip_load")
        force = load.mass * load.gravity
        shape = exact_elastica(force, first.bending_stiffness, first.length, s)
        expected["exact"] = np.stack([shape.x, shape.y, 0.0 * s], axis=1)
        shape = extensible_elastica((0.0, -force), first.bending_stiffness,
                                    first.stretch_stiffness, first.length, s)
        expected["extensible"] = np.stack([shape.x, shape.y, 0.0 * s], axis=1)
    else:
        (tendon_name, tendon), = model.tendons.items()
        pull = scene.term_options("tendons", tendon_name, "tendon_actuation").force
        shape = tendon_arc(pull, tendon.offset, first.bending_stiffness
                           + model.rods[tendon_name].bending_stiffness,
                           first.stretch_stiffness, first.length, s)
        expected["arc"] = first.origin + np.stack(
            [shape.x, tendon.alpha * shape.y, tendon.beta * shape.y], axis=1)

    def blocked(*args, **kwargs):
        raise AssertionError("a reference built a Model")

    monkeypatch.setattr(Model, "__init__", blocked)
    for kind in kinds:
        centerline = reference.reference_centerline(scene, kind, s)
        assert centerline is not None and centerline.shape == (len(s), 3)
        if kind in expected:
            np.testing.assert_allclose(centerline, expected[kind], rtol=0, atol=1e-15)


def test_the_tendon_coupling_selects_one_of_two_registered_lumen_terms():
    """The lumen is two registered terms under one scene key: the tendon's ``coupling``
    picks the paper's (K_L in N/m per point) or the conserving one (N/m² per unit length);
    a scene's lumen table stays valid when its coupling changes."""
    from rodsim.core.terms.lumen import Lumen
    from rodsim.core.terms.lumen_conserving import ConservingLumen

    catalogue = registered_terms()
    assert catalogue["lumen"] is Lumen and catalogue["lumen_conserving"] is ConservingLumen
    assert Lumen.key == ConservingLumen.key == "lumen"
    units = {cls.name: next(p.unit for p in cls.parameters if p.name == "K_L")
             for cls in (Lumen, ConservingLumen)}
    assert units == {"lumen": "N/m", "lumen_conserving": "N/m²"}
    assert ([p.name for p in Lumen.parameters]
            == [p.name for p in ConservingLumen.parameters])
    for scene, expected in (("table3-catheter1", Lumen), ("tendon-conserving", ConservingLumen)):
        loaded = rodsim.load_scene(scene)
        lumens = [t for t in Model(loaded).terms if t.key == "lumen"]
        assert lumens and all(type(t) is expected for t in lumens)
        assert all(isinstance(t.options, expected.Options) for t in lumens)
    switched = rodsim.load_scene("table3-catheter1", ["tendons.tendon.coupling=conserving"])
    lumens = [t for t in Model(switched).terms if t.key == "lumen"]
    assert lumens and all(type(t) is ConservingLumen and t.conservative for t in lumens)
