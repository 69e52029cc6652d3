"""One kernel call for several terms (rodsim/core/kernel_group.py): the string tendons of a
catheter evaluated by ``evaluate_group`` against the same tendons evaluated one call each
(their own ``evaluate``, the reference tests/test_kernels.py checks against numpy) and
against the numpy path, with friction, stiction, a slack tendon, a load fraction and a
member scaled away."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.core.kernel_group import KernelGroup
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.terms.tendon_string import TendonString

E, RADIUS, LENGTH = 54e9, 0.7e-3, 0.2
AREA = np.pi * RADIUS**2


def three_tendons(tensions: tuple[float, float, float]) -> dict:
    """A catheter with three string tendons: frictionless to the tip, with friction to
    0.13 m, with one μ given as a profile (the weighted bounds) to the tip; and a fourth
    rod term after them (it must not join their group)."""
    nodes = 17
    string = {"spacers": True}
    return {"name": "group-case", "rods": {"backbone": {
        "length": LENGTH, "radius": RADIUS, "youngs_modulus": E, "stretch_modulus": E,
        "poisson_ratio": 0.3, "density": 6450.0, "nodes": nodes, "clamp": "frame",
        "terms": ["stretch", "bend_twist", "centerline"],
        "centerline": {"K_P": E / 2.6 * AREA}}},
        "tendons": {
            "a": {"catheter": "backbone", "coupling": "string", "offset": 0.01,
                  "direction": [1.0, 0.0],
                  "tendon_string": {**string, "tension": tensions[0]}},
            "b": {"catheter": "backbone", "coupling": "string", "offset": 0.008,
                  "direction": [0.0, 1.0],
                  "tendon_string": {**string, "tension": tensions[1], "end": 0.13,
                                    "friction": 0.2}},
            "c": {"catheter": "backbone", "coupling": "string", "offset": 0.009,
                  "direction": [-0.6, -0.8],
                  # weighted with one μ (grouped; a μ that varies, or stiction, puts a
                  # tendon on its span's own element: rodsim/core/terms/_string_span.py)
                  "tendon_string": {**string, "tension": tensions[2],
                                    "friction_profile": [0.1], "friction_profile_s": [0.05]}}},
        "solver": {"integrator": "static"}}


def one_call_each(model: Model, group: KernelGroup, full: np.ndarray, scales: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """F and ∂F/∂x data of the group's members, one ``evaluate`` call each, in order."""
    force, data = np.zeros(model.n + 1), np.zeros(model.nnz + 1)
    for call, scale in zip(group.calls, scales, strict=True):
        if scale != 0.0:
            call.evaluate(full, *call.arguments, scale, True, force, call.force_target, True,
                          data, call.jacobian_target)
    return force, data


def grouped(model: Model, group: KernelGroup, full: np.ndarray, scales: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    force, data = np.zeros(model.n + 1), np.zeros(model.nnz + 1)
    group.evaluate(full, *group.arguments, scales, True, force, group.force_target, True, data,
                   group.jacobian_target)
    return force, data


@pytest.mark.parametrize("tensions", [(3.0, 2.0, 4.0), (3.0, 0.0, 4.0)])
def test_a_group_adds_what_its_members_add_one_call_each(tensions, random_state):
    model = Model(Scene.from_dict(three_tendons(tensions)), "compiled")
    rng = np.random.default_rng(35)
    x = random_state(model, rng)
    # a friction history for the tendons that rub: tensions below and above the bounds
    terms = list(model.terms)
    for index, term in enumerate(terms):
        anchors = term.anchor_positions()
        if anchors is not None:
            anchors = anchors.copy()
            chords = len(term.profile)
            anchors[:chords] = rng.uniform(0.0, 6.0, chords)
            terms[index] = term.anchored(anchors)
    model = model.with_terms(terms)
    units = model._kernel_unit_list()
    groups = [u for u in units if isinstance(u, KernelGroup)]
    assert len(groups) == 1 and len(groups[0].calls) == 3
    assert all(isinstance(c.term, TendonString) for c in groups[0].calls)
    group = groups[0]
    full = model.full(x)
    scale = np.max(np.abs(one_call_each(model, group, full, np.ones(3))[1]))
    for scales in (np.ones(3), np.array([0.5, 0.0, 0.25])):
        f_ref, j_ref = one_call_each(model, group, full, scales)
        f, j = grouped(model, group, full, scales)
        assert np.array_equal(f, f_ref)
        assert np.max(np.abs(j - j_ref)) <= 1e-13 * scale
    # the assembled model on both paths, at a load fraction
    f_c, j_c = model.evaluate(x, 0.6)
    f_n, j_n = Model(Scene.from_dict(three_tendons(tensions)), "numpy").with_terms(
        terms).evaluate(x, 0.6)
    assert np.max(np.abs(f_c - f_n)) <= 1e-11 * np.max(np.abs(f_n))
    assert np.max(np.abs(j_c - j_n)) <= 1e-11 * np.max(np.abs(j_n))


def test_only_consecutive_terms_of_one_catheter_share_a_call():
    scene = rodsim.load_scene("tdcr-two-segment")
    model = Model(scene, "compiled")
    units = model._kernel_unit_list()
    kinds = [len(u.calls) if isinstance(u, KernelGroup) else type(u.term).__name__
             for u in units]
    assert kinds == ["Stretch", "BendTwist", "Centerline", "TipLoad", 6]
