"""The scenes ``rodsim compile`` solves besides the shipped ones, so that every compiled
kernel a scene can ask for is compiled with the argument types a solve gives it
(rodsim/app/precompile.py).

The shipped scenes (rodsim/data/) use most terms; these small scenes add what none of them
has: every rod load (point wrenches in both frames, loads per length, gravity), sections,
every obstacle type with and without friction, string tendons of every routing and control
with friction (kinetic per point, a profile, static), joints and an elastic base, the
momentum-conserving and the paper's tendon coupling. Each is a few nodes: solving it costs
milliseconds; compiling what it uses costs seconds, once.
"""

from __future__ import annotations

import copy
from typing import Any

from rodsim.core.obstacles import registered_obstacles

__all__ = ["LARGE_SCENE", "coverage_scenes"]

_ROD: dict[str, Any] = {"length": 0.1, "radius": 0.004, "youngs_modulus": 2e6,
                        "stretch_modulus": 5e6, "density": 1200.0, "nodes": 7}

_LOADS: dict[str, Any] = {
    "name": "compile-loads",
    "rods": {"loaded": _ROD | {
        "clamp": "first_segment",
        "terms": ["stretch", "bend_twist", "centerline", "tip_load", "point_loads",
                  "distributed_load", "gravity"],
        "sections": [{"start": 0.0, "end": 0.03, "youngs_modulus": 6e6, "inner_radius": 0.002},
                     {"start": 0.03, "end": 0.07, "density": 2000.0},
                     {"start": 0.07, "end": 0.1, "radius": 0.003}],
        "tip_load": {"mass": 0.001, "force": [0.001, 0.0, -0.001]},
        "distributed_load": {"force_per_length": [0.0, -0.01, 0.0], "spans": [
            {"start": 0.01, "end": 0.05, "force_per_length": [0.0, 0.0, 0.01]}]},
        "point_loads": {"loads": [
            {"s": 0.031, "force": [0.0, -0.002, 0.001], "moment": [0.0, 1e-4, 0.0],
             "frame": "body"},
            {"s": 0.1, "force": [0.001, 0.0, 0.0], "moment": [0.0, 0.0, 1e-4]}]},
    }},
}

_CONTACT: dict[str, Any] = {
    "name": "compile-contact",
    "rods": {"catheter": _ROD | {"nodes": 9, "terms": ["stretch", "bend_twist", "centerline",
                                                        "tip_load"],
                                 "tip_load": {"force": [0.0, -0.01, 0.0]}},
             "wire": _ROD | {"length": 0.08, "radius": 0.002, "origin": [0.0, 0.0, 0.3],
                             "terms": ["stretch", "bend_twist", "centerline"]}},
    "obstacles": {
        "tissue": {"type": "plane", "rods": ["catheter"], "point": [0.0, -0.02, 0.0],
                   "normal": [0.0, 1.0, 0.0]},
        "bulge": {"type": "sphere", "rods": ["catheter"], "center": [0.05, -0.03, 0.0],
                  "radius": 0.02},
        "pillar": {"type": "capsule", "rods": ["catheter"], "start": [0.08, 0.02, -0.01],
                   "end": [0.08, 0.02, 0.01], "radius": 0.01},
        "vessel": {"type": "tube", "rods": ["catheter"], "centerline": "csv",
                   "points": [-0.01, 0.0, 0.0, 0.011, 0.03, 0.003, 0.0, 0.013,
                              0.07, 0.0, 0.003, 0.012, 0.12, -0.004, 0.0, 0.011]},
        "torus": {"type": "tube", "rods": ["wire"], "centerline": "arc", "radius": 0.0045,
                  "start": [-0.01, 0.0, 0.3], "bend_radius": 2.0, "bend_toward": [0, 1, 1],
                  "angle": 0.5},
        "coil": {"type": "tube", "rods": ["wire"], "centerline": "helix", "radius": 0.0045,
                 "start": [-0.01, -0.002, 0.3], "direction": [1, 0, 0], "bend_radius": 0.002,
                 "pitch": 0.2, "turns": 0.6},
    },
}

_FRICTION: dict[str, Any] = copy.deepcopy(_CONTACT) | {"name": "compile-contact-friction"}
for _obstacle in _FRICTION["obstacles"].values():
    _obstacle |= {"friction": 0.3}

_STRINGS: dict[str, Any] = {
    "name": "compile-string-tendons",
    "rods": {"catheter": _ROD | {"radius": 0.005, "nodes": 8, "clamp": "frame",
                                 "terms": ["stretch", "bend_twist", "centerline"]},
             "shaft": _ROD | {"length": 0.08, "nodes": 9, "clamp": "first_segment",
                              "origin": [0.0, 0.05, 0.0],
                              "terms": ["stretch", "bend_twist", "centerline"]}},
    "tendons": {
        "pull": {"catheter": "catheter", "coupling": "string", "offset": 0.002,
                 "direction": [0.6, 0.8], "tendon_string": {"tension": 0.2, "end": 0.073}},
        "rough": {"catheter": "catheter", "coupling": "string", "offset": 0.002,
                  "direction": [-0.6, 0.8], "tendon_string": {"tension": 0.2, "friction": 0.1,
                                                              "static_friction": 0.15}},
        "profiled": {"catheter": "catheter", "coupling": "string", "offset": 0.002,
                     "direction": [0.0, -1.0],
                     "tendon_string": {"tension": 0.1, "friction_profile": [0.05, 0.1],
                                       "friction_profile_s": [0.0, 0.1]}},
        "helix": {"catheter": "catheter", "coupling": "string",
                  "tendon_string": {"tension": 0.1, "start": 0.01, "routing": "helix",
                                    "helix_radius": 0.008, "helix_pitch": 0.07,
                                    "spacers": True}},
        "pulled": {"catheter": "catheter", "coupling": "string", "offset": 0.003,
                   "direction": [-0.2, 1.0],
                   "tendon_string": {"control": "displacement", "displacement": 0.001,
                                     "stiffness": 40.0, "start": 0.02, "end": 0.09}},
        "table": {"catheter": "shaft", "coupling": "string",
                  "tendon_string": {"tension": 0.1, "routing": "table",
                                    "table_s": [0.0, 0.03, 0.06, 0.08],
                                    "table_y": [0.002, 0.001, -0.001, -0.002],
                                    "table_z": [0.0, 0.0015, 0.002, 0.001]}},
        "lone": {"catheter": "shaft", "coupling": "string", "offset": 0.002,
                 "direction": [0.0, 1.0], "tendon_string": {"tension": 0.1, "friction": 0.1}},
    },
}

_TENDON_ROD: dict[str, Any] = {
    "name": "compile-tendon-rods",
    "rods": {"catheter": _ROD | {"radius": 0.005, "nodes": 8, "clamp": "frame",
                                 "terms": ["stretch", "bend_twist", "centerline"]},
             "tendon": _ROD | {"radius": 0.0005, "youngs_modulus": 1e8, "stretch_modulus": 1e8,
                               "nodes": 6, "clamp": "orientation",
                               "terms": ["stretch", "bend_twist", "centerline"]},
             "second": _ROD | {"radius": 0.0005, "youngs_modulus": 1e8, "stretch_modulus": 1e8,
                               "nodes": 9, "clamp": "frame",
                               "terms": ["stretch", "bend_twist", "centerline"]}},
    "tendons": {
        "tendon": {"catheter": "catheter", "offset": 0.002, "direction": [0.6, 0.8],
                   "coupling": "conserving",
                   "terms": ["lumen", "endpoint_compliance", "endpoint_coupling",
                             "tendon_actuation"],
                   "tendon_actuation": {"force": 0.5, "point": "proximal"}},
        "second": {"catheter": "catheter", "offset": 0.002, "direction": [-0.6, 0.8],
                   "coupling": "paper",
                   "terms": ["lumen", "endpoint_compliance", "endpoint_coupling",
                             "tendon_actuation"],
                   "lumen": {"constrain": "d_t"},
                   "tendon_actuation": {"force": 0.5, "point": "distal"}},
    },
}

_JOINTS: dict[str, Any] = {
    "name": "compile-joints",
    "rods": {
        "proximal": _ROD | {"nodes": 6, "clamp": "frame",
                            "terms": ["stretch", "bend_twist", "centerline"],
                            "base": {"insertion": 0.01, "rotation": 0.3},
                            "supports": {"guide": {"s": 0.06, "orientation": True}}},
        "distal": _ROD | {"length": 0.06, "radius": 0.003, "nodes": 5, "clamp": "free",
                          "terms": ["stretch", "bend_twist", "centerline", "joint", "tip_load"],
                          "joint": {"rod": "proximal", "s": 0.1},
                          "tip_load": {"force": [0.0, -0.002, 0.003]}},
        "branch": _ROD | {"length": 0.04, "radius": 0.002, "nodes": 4, "clamp": "free",
                          "terms": ["stretch", "bend_twist", "centerline", "joint"],
                          "joint": {"rod": "distal", "s": 0.03, "orientation": False}},
        "sprung": _ROD | {"length": 0.05, "radius": 0.002, "nodes": 5, "clamp": "elastic",
                          "origin": [0.0, 0.08, 0.0],
                          "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
                          "base": {"translational_stiffness": 40.0,
                                   "rotational_stiffness": 2e-3,
                                   "torsional_stiffness": 7e-4},
                          "tip_load": {"force": [0.001, 0.002, -0.0015]}},
    },
}

def obstacle_example(kind: str, friction: float) -> dict[str, Any]:
    """A cantilever (0.1 m along +x, 1 mm thick, 10 mN toward -y at its tip) stopped by the
    ``example`` table of the registered obstacle type ``kind`` (rodsim/core/obstacles/), with
    friction ``friction``: a type added to the registry is compiled for with no edit here."""
    table = {"type": kind, "rods": ["catheter"], **registered_obstacles()[kind].example}
    if friction:
        table["friction"] = friction
    rod = _ROD | {"radius": 0.001, "nodes": 9, "youngs_modulus": 2e8,
                  "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
                  "tip_load": {"force": [0.0, -0.01, 0.0]}}
    return {"name": f"compile-obstacle-{kind}" + ("-friction" if friction else ""),
            "rods": {"catheter": rod}, "obstacles": {"obstacle": table}}


def coverage_scenes() -> dict[str, dict[str, Any]]:
    """The small scenes, by name (module docstring): the fixed ones and, for every obstacle
    type registered when called, its example with and without friction."""
    examples = [obstacle_example(kind, friction) for kind in sorted(registered_obstacles())
                for friction in (0.0, 0.3)]
    return {scene["name"]: scene for scene in (_LOADS, _CONTACT, _FRICTION, _STRINGS,
                                               _TENDON_ROD, _JOINTS, *examples)}


#: A model from ``rodsim.solvers.linear.COMPILED_FILL_SIZE`` unknowns on (table1-50g at 640
#: nodes: 4 473 unknowns), whose linear solves and stability verdict fill their band by
#: compiled passes (rodsim/core/kernels/_band.py) that smaller models do not use.
LARGE_SCENE = ("table1-50g", ("rods.catheter.nodes=640", "solver.integrator=static"))
