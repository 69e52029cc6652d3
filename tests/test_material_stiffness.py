"""Term.material_stiffness (rodsim/core/terms/base.py), what Kelvin–Voigt damping is made of
(rodsim/core/damping.py): for every term that has one, at random strained states of a
user's rods (steel and nitinol wires, a polymer catheter; a clamp, a frame held at a node),
it is symmetric and positive semi-definite, and at the stress-free rest state it is the
term's whole stiffness −∂F_e/∂x_e (the geometric part vanishes with the stress)."""

from __future__ import annotations

import numpy as np
import pytest

from rodsim.core.model import Model
from rodsim.core.scene import Scene


def _rod(modulus: float, radius: float, length: float, clamp: str) -> dict:
    return {"length": length, "radius": radius, "youngs_modulus": modulus, "density": 6000.0,
            "nodes": 9, "clamp": clamp, "terms": ["stretch", "bend_twist", "centerline"],
            "supports": {"mid": {"s": length / 2, "orientation": True}}}


SCENE = {"name": "materials", "rods": {
    "steel": _rod(2e11, 3e-4, 0.2, "frame"),
    "nitinol": _rod(6e10, 4e-4, 0.15, "first_segment") | {"origin": [0.0, 0.05, 0.0]},
    "polymer": _rod(3e7, 1.5e-3, 0.1, "frame") | {"origin": [0.0, -0.05, 0.0]}}}


@pytest.mark.parametrize("seed", range(3))
def test_material_stiffness_is_symmetric_positive_and_the_stiffness_at_rest(seed):
    model = Model(Scene.from_dict(SCENE))
    rng = np.random.default_rng(seed)
    strained = model.x0 + 2e-3 * rng.standard_normal(model.n)
    checked = 0
    for term in model.terms:
        for x, at_rest in ((model.x0, True), (strained, False)):
            state = model.offsets(x) if term.offsets else model.full(x)
            blocks = term.material_stiffness(state)
            if blocks is None:
                continue
            checked += 1
            np.testing.assert_allclose(blocks, np.swapaxes(blocks, 1, 2), rtol=0.0,
                                       atol=1e-12 * np.max(np.abs(blocks)))
            lowest = np.linalg.eigvalsh(0.5 * (blocks + np.swapaxes(blocks, 1, 2))).min()
            assert lowest > -1e-10 * np.max(np.abs(blocks)), (term.name, lowest)
            if at_rest:
                np.testing.assert_allclose(blocks, -term.element_jacobians(state), rtol=0.0,
                                           atol=1e-9 * np.max(np.abs(blocks)))
    assert checked == 2 * 2 * 3  # stretch and bend_twist of each rod, at rest and strained
