"""The elastic base (``clamp = "elastic"``, its energy rodsim/core/support_kinds/elastic.py): a
rod held at its base by a translational spring k_t and rotational springs k_b (bending) and
k_tau (twist) instead of a rigid clamp.

Closed forms (small deflections, Euler-Bernoulli): a cantilever of bending stiffness E I
under a tip force F across its axis deflects at the tip by

    w = F L^3 / (3 E I) + F L^2 / k_b + F / k_t

(the beam, the base turned by F L / k_b, the base moved by F / k_t), and under a moment T
about its axis it twists at arclength s by T s / (G J) + T / k_tau. Checked on a seeded
family of robots a user might build (steel and nitinol wires, polymer catheters; loads
from mN to N, each sized to a deflection of 1e-3 L), at second order in N, and in the
limit of stiff springs against the rigid `frame` clamp."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rodsim
from rodsim.core.rod.quaternion import directors
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError

MATERIALS = {  # E [Pa], radius range [m], length range [m], density
    "steel wire": (2.0e11, (2e-4, 6e-4), (0.1, 0.4), 7900.0),
    "nitinol wire": (6.0e10, (2e-4, 5e-4), (0.08, 0.3), 6450.0),
    "polymer catheter": (5.0e7, (1e-3, 2e-3), (0.05, 0.2), 1100.0),
}


def _robot(material: str, seed: int) -> dict[str, float]:
    """A robot of ``material`` with springs that each take a share of the compliance
    comparable to the beam's, and a tip force that deflects it by 1e-3 L."""
    rng = np.random.default_rng(seed)
    modulus, radii, lengths, density = MATERIALS[material]
    radius, length = rng.uniform(*radii), rng.uniform(*lengths)
    ei = modulus * math.pi * radius**4 / 4.0
    beam = length**3 / (3.0 * ei)  # tip compliance of the beam [m/N]
    k_b = length**2 / (beam * rng.uniform(0.3, 3.0))
    k_t = 1.0 / (beam * rng.uniform(0.3, 3.0))
    compliance = beam + length**2 / k_b + 1.0 / k_t
    return {"E": modulus, "radius": radius, "length": length, "density": density,
            "k_b": k_b, "k_t": k_t, "k_tau": rng.uniform(0.3, 3.0) * ei / length,
            "force": 1e-3 * length / compliance, "compliance": compliance}


def _scene(robot: dict[str, float], nodes: int, force: tuple[float, float, float] = (0, 0, 0),
           moment: tuple[float, float, float] = (0, 0, 0), clamp: str = "elastic",
           scale: float = 1.0) -> Scene:
    rod = {"length": robot["length"], "radius": robot["radius"],
           "youngs_modulus": robot["E"], "poisson_ratio": 0.3, "density": robot["density"],
           "nodes": nodes, "clamp": clamp,
           "terms": ["stretch", "bend_twist", "centerline", "point_loads"],
           "point_loads": {"loads": [{"s": robot["length"], "force": list(force),
                                      "moment": list(moment)}]}}
    if clamp == "elastic":
        rod["base"] = {"translational_stiffness": scale * robot["k_t"],
                       "rotational_stiffness": scale * robot["k_b"],
                       "torsional_stiffness": scale * robot["k_tau"]}
    return Scene.from_dict({"name": "elastic-base", "rods": {"rod": rod}})


FAMILY = [(material, 3 * index + seed) for index, material in enumerate(MATERIALS)
          for seed in range(3)]


@pytest.mark.parametrize(("material", "seed"), FAMILY)
def test_a_cantilever_on_springs_is_beam_theory_plus_the_springs(material, seed):
    robot = _robot(material, seed)
    result = rodsim.solve(_scene(robot, 41, force=(0.0, -robot["force"], 0.0)),
                          integrator="static")
    assert result.success, result.message
    tip = result.tip()
    exact = robot["force"] * robot["compliance"]
    # The discretisation, second order in N (below): measured 6.9e-5 to 1.8e-4 at N = 41
    # (4.4e-5 or less at N = 81), as the rigid clamp's.
    assert abs(-tip[1] - exact) < 3e-4 * exact, (tip, exact)


def test_the_elastic_base_converges_at_second_order_in_n():
    robot = _robot("steel wire", 7)
    exact = robot["force"] * robot["compliance"]
    errors = []
    for nodes in (11, 21, 41):
        result = rodsim.solve(_scene(robot, nodes, force=(0.0, -robot["force"], 0.0)),
                              integrator="static")
        assert result.success, result.message
        errors.append(abs(-result.tip()[1] - exact) / exact)
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 1.8), (errors, orders)  # measured 2.0, 2.0


@pytest.mark.parametrize("material", list(MATERIALS))
def test_a_twisted_rod_on_a_torsion_spring(material):
    robot = _robot(material, 11)
    gj = robot["E"] / (2.0 * 1.3) * math.pi * robot["radius"]**4 / 2.0
    torque = 1e-3 / (robot["length"] / gj + 1.0 / robot["k_tau"])  # 1 mrad at the tip
    nodes = 21
    result = rodsim.solve(_scene(robot, nodes, moment=(torque, 0.0, 0.0)),
                          integrator="static")
    assert result.success, result.message
    shape = result.rods["rod"]
    d1 = directors(shape.quaternions[-1])[0]
    twist = math.atan2(d1[2], d1[1])
    s_last = shape.segment_s[-1]
    expected = torque * s_last / gj + torque / robot["k_tau"]
    assert abs(twist - expected) < 1e-3 * expected, (twist, expected)


def test_stiff_springs_tend_to_the_rigid_clamp_as_their_compliance():
    robot = _robot("nitinol wire", 3)
    force = (0.0, -robot["force"], 0.3 * robot["force"])
    rigid = rodsim.solve(_scene(robot, 21, force=force, clamp="frame"), integrator="static")
    assert rigid.success, rigid.message
    gaps = []
    for scale in (1e2, 1e4):
        sprung = rodsim.solve(_scene(robot, 21, force=force, scale=scale), integrator="static")
        assert sprung.success, sprung.message
        gaps.append(np.max(np.abs(sprung.positions() - rigid.positions())))
    # The springs' share of the compliance falls 100-fold, and so does the gap (measured
    # 8.1e-6 L and 8.1e-8 L): the elastic base's limit is the rigid clamp's element.
    assert gaps[1] < 1e-7 * robot["length"]
    assert gaps[0] / gaps[1] == pytest.approx(100.0, rel=1e-3)


OLD_SPRINGS = {"stiffness": 10.0, "rotational_stiffness": 1e-3, "torsional_stiffness": 1e-3}


@pytest.mark.parametrize("change", [
    {"terms": ["stretch", "bend_twist", "centerline", "elastic_base"],
     "elastic_base": OLD_SPRINGS},
    {"elastic_base": OLD_SPRINGS},
    {"terms": ["stretch", "bend_twist", "centerline", "elastic_base"]},
    {"clamp": "frame", "terms": ["stretch", "bend_twist", "centerline", "elastic_base"],
     "elastic_base": OLD_SPRINGS},
])
def test_the_older_elastic_base_term_points_to_the_support_kind(change):
    """The elastic base was once also a term a ``free`` rod listed (``[rods.<rod>.elastic_base]``
    with ``stiffness``): one way now, the support kind; the older spelling, in any of its
    parts, is one line naming the keys to write instead."""
    rod = {"length": 0.1, "radius": 1e-3, "youngs_modulus": 1e8, "density": 1000.0, "nodes": 6,
           "clamp": "free", "terms": ["stretch", "bend_twist", "centerline"]} | change
    with pytest.raises(SceneError) as caught:
        Scene.from_dict({"name": "old", "rods": {"rod": rod}})
    message = str(caught.value)
    assert message.startswith("rods.rod.elastic_base: ") and "\n" not in message, message
    for words in ("rods.rod.clamp = 'elastic'", "[rods.rod.base]", "translational_stiffness",
                  "rotational_stiffness", "torsional_stiffness"):
        assert words in message, message


def test_a_joint_and_an_elastic_base_cannot_both_hold_a_base():
    rods = {
        "a": {"length": 0.1, "radius": 1e-3, "youngs_modulus": 1e8, "density": 1000.0, "nodes": 6},
        "b": {"length": 0.1, "radius": 1e-3, "youngs_modulus": 1e8, "density": 1000.0, "nodes": 6,
              "clamp": "elastic", "terms": ["stretch", "bend_twist", "centerline", "joint"],
              "joint": {"rod": "a", "s": 0.1},
              "base": {"translational_stiffness": 10.0, "rotational_stiffness": 1e-3,
                       "torsional_stiffness": 1e-3}},
    }
    with pytest.raises(SceneError, match="also held by rods.b.joint"):
        Scene.from_dict({"name": "bad", "rods": rods})
