"""Term.material_stiffness (rodsim/core/terms/base.py), what Kelvin–Voigt damping is made of
(rodsim/core/damping.py): for every term that has one, at random strained states of a
user's rods (steel and nitinol wires, a polymer catheter; a clamp, a frame held at a node),
it is symmetric and positive semi-definite, and at the stress-free rest state it is the
term's whole stiffness −∂F_e/∂x_e (the geometric part vanishes with the stress); with a
weight per strain kind (a retardation time each, docs/dynamics.md) it is the weighted sum
of each kind's own part, and that of bending about d1 alone is the rank-one l̄ K_11 ∇u_1 ∇u_1ᵀ
of finite-differenced strains."""

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
    assert checked == 3 * 2 * 3  # stretch, bend_twist, centerline of each rod, rest and strained


def test_weights_split_the_material_stiffness_by_strain_kind():
    """Bend–twist with weights (a, b) is a × bending's part + b × twist's; each part is the
    Gauss–Newton product of the strains' finite-difference gradients (u_1, u_2 for bending,
    u_3 for twist: l̄ K_k ∇u_k ∇u_kᵀ), at a strained state; stretch's and the centerline's
    single weight scales the whole."""
    model = Model(Scene.from_dict(SCENE))
    strained = model.x0 + 2e-3 * np.random.default_rng(5).standard_normal(model.n)
    for term in model.terms:
        if not term.strain_kinds:
            continue
        state = model.offsets(strained) if term.offsets else model.full(strained)
        whole = term.material_stiffness(state)
        if term.name != "bend_twist":
            np.testing.assert_allclose(term.material_stiffness(state, np.array([0.3])),
                                       0.3 * whole, rtol=1e-14, atol=0.0)
            continue
        bending = term.material_stiffness(state, np.array([1.0, 0.0]))
        twist = term.material_stiffness(state, np.array([0.0, 1.0]))
        np.testing.assert_allclose(bending + twist, whole, rtol=0.0,
                                   atol=1e-12 * np.abs(whole).max())
        np.testing.assert_allclose(term.material_stiffness(state, np.array([2.0, 0.5])),
                                   2.0 * bending + 0.5 * twist, rtol=0.0,
                                   atol=1e-12 * np.abs(whole).max())
        # finite-difference strain gradients of the free elements (no held frame)
        free = np.flatnonzero(term._fixed == 0)
        grads = np.zeros((len(free), 3, 8))
        step = 1e-7
        for i, element in enumerate(free):
            for c in range(8):
                plus, minus = state.copy(), state.copy()
                plus[term.dofs[element, c]] += step
                minus[term.dofs[element, c]] -= step
                grads[i, :, c] = ((term.strains(plus) - term.strains(minus))[element]
                                  / (2.0 * step))
        weights = (term._dual_lengths[free, None] * term._stiffness[free])  # l̄ K_k
        for kind, rows in ((bending, (0, 1)), (twist, (2,))):
            expected = sum(weights[:, k, None, None] * grads[:, k, :, None]
                           * grads[:, k, None, :] for k in rows)
            np.testing.assert_allclose(kind[free], expected, rtol=0.0,
                                       atol=1e-6 * np.abs(expected).max())
