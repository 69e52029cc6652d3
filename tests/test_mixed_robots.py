"""A seeded family of user robots that mix the features of "any robot" (docs/scenes.md):
soft distal sections, an inserted and turned base, a node support moved from its rest
place, point wrenches (world and body frame) anywhere, self-weight, distributed loads, and
string tendons that end part-way or wind as helices — written from the scene reference
alone, with sizes and moduli over several decades.

What every member must give: a converged equilibrium whose stability verdict is that of
K's dense eigenvalues (numpy, independent of rodsim/core/stability.py), or a failure that
says what to try. Found with this family (seed 1): static failed on three robots whose
mid-span support was moved (tests/test_supports.py), and a stable verdict was given to a
state with an eigenvalue −0.084 behind 51 smaller positive ones
(tests/test_stability_band.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rodsim
from rodsim.core.model import Model

SEED, FAMILY = 1, 20


def mixed_robot(rng: np.random.Generator, index: int) -> dict:
    """One robot: L in [0.03, 0.6] m, r in [0.4, 8] mm (L/r ≥ 25), E in [0.3 MPa, 30 GPa],
    12–44 nodes; each feature drawn independently; loads sized by E I / L²."""
    length = rng.uniform(0.03, 0.6)
    radius = rng.uniform(4e-4, min(8e-3, length / 25))
    young = 10 ** rng.uniform(5.5, 10.5)
    bending = young * math.pi * radius**4 / 4
    nodes = int(rng.integers(12, 45))
    terms = ["stretch", "bend_twist", "centerline"]
    rod: dict = {"length": length, "radius": radius, "youngs_modulus": young,
                 "density": rng.uniform(900, 8000), "nodes": nodes,
                 "poisson_ratio": rng.uniform(0.25, 0.5)}
    if rng.uniform() < 0.4:  # a soft distal section
        cut = rng.uniform(0.5, 0.9) * length
        rod["sections"] = [{"start": 0.0, "end": cut},
                           {"start": cut, "end": length,
                            "youngs_modulus": young * 10 ** rng.uniform(-2, -0.3),
                            "radius": radius * rng.uniform(0.7, 1.0)}]
    if rng.uniform() < 0.5:
        rod["base"] = {"insertion": rng.uniform(-0.02, 0.05), "rotation": rng.uniform(-3, 3)}
    force = bending / length**2
    if rng.uniform() < 0.5:
        terms.append("point_loads")
        rod["point_loads"] = {"loads": [
            {"s": float(rng.uniform(0.1, 1.0) * length),
             "force": list(rng.normal(0, 1.0, 3) * force),
             "moment": list(rng.normal(0, 0.3, 3) * force * length),
             "frame": str(rng.choice(["world", "body"]))}
            for _ in range(int(rng.integers(1, 3)))]}
    if rng.uniform() < 0.3:
        terms.append("gravity")
    if rng.uniform() < 0.3:
        terms.append("distributed_load")
        rod["distributed_load"] = {"force_per_length": list(rng.normal(0, 1.0, 3) * force
                                                            / length)}
    if rng.uniform() < 0.25:
        node = int(rng.integers(2, nodes))
        rod["supports"] = {"mid": {"s": node * length / (nodes - 1),
                                   "displacement": list(rng.normal(0, 0.02, 3) * length),
                                   "orientation": bool(rng.uniform() < 0.3)}}
    rod["terms"] = terms
    robot: dict = {"name": f"mixed-robot-{index}", "rods": {"catheter": rod}, "tendons": {},
                   "solver": {"max_wall_time": 30.0}}
    for k in range(int(rng.integers(0, 3))):
        angle = rng.uniform(0, 2 * math.pi)
        offset = rng.uniform(0.3, 0.8) * radius
        string: dict = {"tension": rng.uniform(0.1, 2.0) * bending / (offset * length)}
        draw = rng.uniform()
        if draw < 0.25:
            string["end"] = rng.uniform(0.4, 0.95) * length
        elif draw < 0.45:
            string.update(routing="helix", helix_radius=offset, helix_phase=angle,
                          helix_pitch=rng.choice([-1, 1]) * rng.uniform(1.0, 4.0) * length)
        robot["tendons"][f"t{k}"] = {"catheter": "catheter", "coupling": "string",
                                     "offset": offset,
                                     "direction": [math.cos(angle), math.sin(angle)],
                                     "tendon_string": string}
    return robot


@pytest.mark.slow  # 20 robots, static and CVODE each: ~10 s of CPU
def test_mixed_robots_converge_with_the_verdict_of_their_eigenvalues():
    """static and CVODE on every robot: each run converges or fails with advice; every
    converged state's verdict is the sign of the smallest real part of K's dense
    eigenvalues; static converges on every robot (17 of 20 before its supports moved with
    the loads) and at least one verdict of the family is 'unstable' (the check is not
    vacuous)."""
    rng = np.random.default_rng(SEED)
    verdicts, static_failures = [], []
    for index in range(FAMILY):
        robot = mixed_robot(rng, index)
        model = Model(rodsim.load_scene(robot))
        for integrator in ("static", "cvode"):
            result = rodsim.solve(robot, integrator, model=model)
            if not result.success:
                assert "try" in result.message, result.message
                if integrator == "static":
                    static_failures.append(robot["name"])
                continue
            stiffness = -model.pattern_matrix(model.jacobian_data(result.state)).toarray()
            smallest = float(np.linalg.eigvals(stiffness).real.min())
            assert result.stability.stable == (smallest > 0.0), (
                robot["name"], integrator, result.stability, smallest)
            verdicts.append(result.stability.stable)
    assert not static_failures, static_failures
    assert False in verdicts and len(verdicts) >= 2 * FAMILY - 2
