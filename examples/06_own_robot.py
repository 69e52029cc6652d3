"""A user's own robot written as a Python dict: a 0.2 m catheter of radius 4 mm with one
tendon in a lumen 2.5 mm off its axis, pulled at the distal end with 1 N.

Every key is documented in docs/scenes.md (``rodsim run --help`` lists them with units and
defaults); a wrong key or value raises a one-line ``SceneError``. The robot is solved with
the direct Newton solver and with CVODE, and the two equilibria must agree. Run:
``python examples/06_own_robot.py`` (a few seconds).
"""

import numpy as np

import rodsim

robot = {
    "name": "my-robot",
    "description": "a 0.2 m catheter with one tendon",
    "rods": {
        "catheter": {"length": 0.2, "radius": 0.004, "youngs_modulus": 4e6,
                     "stretch_modulus": 4e6, "density": 1100.0, "nodes": 25,
                     "clamp": "frame", "terms": ["stretch", "bend_twist", "centerline"]},
        "tendon": {"length": 0.2, "radius": 0.0001, "youngs_modulus": 4e6,
                   "stretch_modulus": 4e6, "density": 1100.0, "nodes": 25, "clamp": "frame",
                   "terms": ["stretch", "bend_twist", "centerline"],
                   "bend_twist": {"twist_stiffness": 1e-3}},
    },
    "tendons": {
        "tendon": {"catheter": "catheter", "offset": 0.0025, "direction": [0.0, 1.0],
                   "coupling": "paper",
                   "lumen": {"K_L": 1000.0},
                   "endpoint_compliance": {"K_E": 950.0},
                   "endpoint_coupling": {"K_C": 2e5},
                   "tendon_actuation": {"force": 1.0, "point": "distal"}},
    },
}

scene = rodsim.load_scene(robot)
static = rodsim.solve(scene, "static")
cvode = rodsim.solve(scene, "cvode")
for result in (static, cvode):
    assert result.success, result.message
length = scene.rods["catheter"].length
apart = np.abs(static.positions("catheter") - cvode.positions("catheter")).max() / length
print(f"tip (static) [m]: {np.array2string(static.tip('catheter'), precision=5)}")
print(f"static and CVODE agree to {apart:.1e} L; stable: {static.stability.stable}")
assert apart < 1e-5
