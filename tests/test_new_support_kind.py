"""A new support kind with an energy is one file (docs/architecture.md, "How to add a support
kind"): this test defines one, a torsion-spring base, and nothing else in the package
changes. Its class alone — where it holds (``holds_position``), its key in
``[rods.<rod>.base]`` and its energy, force and exact Jacobian on (r_0, q_0) — makes it a
scene's ``clamp``, a model's support (the generic support term,
rodsim/core/terms/support_energy.py, asks it for its energy; with no kernel of its own it runs
its numpy methods on the compiled path too), and it is checked here against central
differences and a closed form.

The kind: the base node held in place, the first segment held at the base frame q_c by the
rigid clamp's half-segment bending element (q_c, q_0) (l̄ = l/2, docs/model.md, "Clamp") for
bending, and by that element in series with a torsional spring k_τ about the rod's axis:

    E = ½ l̄ Σ_k K̃_k u_k(q_c, q_0)²,   K̃_1,2 = K_1,2,   K̃_3 = l̄ / (l̄/K_3 + 1/k_τ).

Closed form (small twist): a tip torque M about the axis turns the tip section by
M s/(G J) + M/k_τ (s the last segment's arclength); a tip force across the axis bends the rod
as the rigid ``frame`` clamp does (the bending element is the clamp's)."""

from __future__ import annotations

import copy
import math
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np
import pytest
from test_support_kinds import EXAMPLES, check_energy_methods

import rodsim
from rodsim.core import supports
from rodsim.core.rod.quaternion import directors
from rodsim.core.schema import Parameter, SceneError
from rodsim.core.supports import Support, SupportKind
from rodsim.core.terms.bend_twist import (
    bend_forces,
    bend_jacobians,
    bend_kinematics,
    element_stiffness,
)

E, RADIUS, LENGTH, POISSON = 5e6, 0.002, 0.05, 0.3
GJ = E / (2.0 * (1.0 + POISSON)) * math.pi * RADIUS**4 / 2.0
K_TAU = 0.4 * GJ / LENGTH  # the spring takes 2.5 times the rod's twist compliance


def define_torsion_spring_kind() -> type[SupportKind]:
    """The throwaway kind, defined (and so registered) when called."""

    class TorsionSpringSupport(SupportKind):
        name = "torsion_spring"
        doc = "position held, bending clamped, twist on a spring k_tau"
        holds_position = True
        has_energy = True
        base_parameters = (Parameter("twist_stiffness", "float", None, "N*m/rad",
                                     "clamp = 'torsion_spring': spring k_tau about d3",
                                     0.0, 1e15, exclusive_minimum=True),)

        @classmethod
        def energy_constants(cls, values: Sequence[float], support: Support,
                             rod: Any) -> dict[str, Any]:
            half = 0.5 * rod.geometry.segment_length
            k = element_stiffness(rod, "corrected", 0.0, np.zeros(1), np.array([half]))[0]
            k[2] = half / (half / k[2] + 1.0 / values[0])
            return {"frame": np.asarray(support.frame, float)[None, :],
                    "dual": np.array([half]), "stiffness": k[None, :]}

        @classmethod
        def energy(cls, constants: Mapping[str, Any], x: np.ndarray) -> float:
            u = bend_kinematics(constants["frame"], x[None, 3:], constants["dual"]).u
            return float(0.5 * np.sum(constants["dual"][:, None] * constants["stiffness"]
                                      * u**2))

        @classmethod
        def forces(cls, constants: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
            turn = bend_forces(constants["frame"], x[None, 3:], constants["dual"],
                               constants["stiffness"])[0, 4:]
            return np.concatenate([np.zeros(3), turn])

        @classmethod
        def jacobian(cls, constants: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
            jac = np.zeros((7, 7))
            jac[3:, 3:] = bend_jacobians(constants["frame"], x[None, 3:], constants["dual"],
                                         constants["stiffness"])[0, 4:, 4:]
            return jac

    return TorsionSpringSupport


@pytest.fixture
def torsion_spring(monkeypatch: pytest.MonkeyPatch) -> Iterator[type[SupportKind]]:
    """The kind, registered for one test (the registry is restored after it)."""
    monkeypatch.setattr(supports, "_KINDS", dict(supports.registered_support_kinds()))
    yield define_torsion_spring_kind()


def scene(clamp: str, force: Sequence[float], moment: Sequence[float], nodes: int = 21,
          kernels: str = "auto") -> dict[str, Any]:
    base: dict[str, Any] = {"rotation": 0.6, "insertion": 0.003}
    if clamp == "torsion_spring":
        base["twist_stiffness"] = K_TAU
    return {"name": "torsion-spring-base", "solver": {"kernels": kernels}, "rods": {"rod": {
        "length": LENGTH, "radius": RADIUS, "youngs_modulus": E, "poisson_ratio": POISSON,
        "density": 1100.0, "nodes": nodes, "clamp": clamp, "base": base,
        "terms": ["stretch", "bend_twist", "centerline", "point_loads"],
        "point_loads": {"loads": [{"s": LENGTH, "force": list(force),
                                   "moment": list(moment)}]}}}}


def test_a_kind_defined_elsewhere_is_refused_until_defined():
    with pytest.raises(SceneError, match=r"clamp = 'torsion_spring'"):
        rodsim.load_scene(scene("torsion_spring", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))


def test_the_new_kind_s_force_and_jacobian_match_finite_differences(torsion_spring):
    model = rodsim.build_model(scene("torsion_spring", (0.0, -1e-3, 0.0), (1e-5, 0.0, 0.0),
                                     nodes=6))
    rod = model.rods["rod"]
    assert rod.support.kind is torsion_spring
    (term,) = [t for t in model.terms if getattr(t, "support_kind", None) is torsion_spring]
    assert not term.compiled  # no kernel of its own: its numpy methods on every path
    check_energy_methods(torsion_spring, term.constants, rod.support, 11)
    # The model with the kind in place, compiled path and numpy path: F = −∂E/∂x and
    # J = ∂F/∂x (the contract test of every kind, on this kind's example).
    EXAMPLES["torsion_spring"] = (scene("torsion_spring", (0.0, -1e-3, 0.0),
                                        (1e-5, 0.0, 0.0), nodes=6), "rod", "base")
    try:
        from test_support_kinds import (
            test_a_kind_holds_what_it_says,
            test_force_and_jacobian_with_the_kind_in_place_match_finite_differences,
        )

        test_a_kind_holds_what_it_says("torsion_spring")
        test_force_and_jacobian_with_the_kind_in_place_match_finite_differences(
            "torsion_spring")
    finally:
        del EXAMPLES["torsion_spring"]
    x = 1e-3 * np.random.default_rng(2).standard_normal(model.n)
    numpy = rodsim.build_model(scene("torsion_spring", (0.0, -1e-3, 0.0), (1e-5, 0.0, 0.0),
                                     nodes=6, kernels="numpy"))
    np.testing.assert_allclose(model.force(x), numpy.force(x), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(model.jacobian(x).toarray(), numpy.jacobian(x).toarray(),
                               rtol=1e-12, atol=1e-12 * np.max(np.abs(numpy.jacobian(x).data)))


def test_a_tip_torque_twists_the_rod_and_the_spring(torsion_spring):
    torque = 1e-3 / (LENGTH / GJ + 1.0 / K_TAU)  # about 1 mrad at the tip
    result = rodsim.solve(scene("torsion_spring", (0.0, 0.0, 0.0), (torque, 0.0, 0.0)),
                          integrator="static")
    assert result.success, result.message
    shape = result.rods["rod"]
    d1 = directors(shape.quaternions[-1])[0]
    twist = math.remainder(math.atan2(d1[2], d1[1]) - 0.6, 2.0 * math.pi)
    expected = torque * shape.segment_s[-1] / GJ + torque / K_TAU
    np.testing.assert_array_equal(shape.positions[0], [0.003, 0.0, 0.0])  # held
    # Measured 6.3e-8 of it (6.5e-8 at N = 11, 6.2e-8 at 41): the small-twist law's own
    # error; bound with a margin of about 150.
    assert abs(twist - expected) < 1e-5 * expected, (twist, expected)


def test_a_tip_force_bends_the_rod_as_the_rigid_clamp(torsion_spring):
    force = (0.0, -2e-3, 1e-3)
    sprung = rodsim.solve(scene("torsion_spring", force, (0.0, 0.0, 0.0)), integrator="static")
    clamped = rodsim.solve(scene("frame", force, (0.0, 0.0, 0.0)), integrator="static")
    assert sprung.success and clamped.success
    deflection = np.linalg.norm(clamped.tip() - [LENGTH + 0.003, 0.0, 0.0])
    assert deflection > 1e-3 * LENGTH  # a real bend
    # A force through the axis twists neither: the same tip to round-off (measured 1.4e-14
    # of the deflection, 3 % of L).
    assert np.max(np.abs(sprung.tip() - clamped.tip())) < 1e-9 * deflection


def test_the_kind_leaves_the_registry_with_its_test():
    assert "torsion_spring" not in supports.registered_support_kinds()
    assert copy.copy(supports.CLAMPS) is not None and "torsion_spring" not in supports.CLAMPS


def test_a_kind_with_an_energy_but_a_missing_method_is_refused_when_defined(monkeypatch):
    monkeypatch.setattr(supports, "_KINDS", dict(supports.registered_support_kinds()))
    with pytest.raises(TypeError, match=r"'half_spring' has an energy but does not define "
                                        r"forces, jacobian"):
        class HalfSpring(SupportKind):
            name = "half_spring"
            has_energy = True

            @classmethod
            def energy_constants(cls, values: Sequence[float], support: Support,
                                 rod: Any) -> dict[str, Any]:
                return {}

            @classmethod
            def energy(cls, constants: Mapping[str, Any], x: np.ndarray) -> float:
                return 0.0
    assert "half_spring" not in supports._KINDS
