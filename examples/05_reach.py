"""Inverse kinematics: the tendon tension that puts the catheter's tip at a target.

The target is the tip of the Table 3 catheter pulled with 1.5 N (so it is reachable);
``rodsim.reach`` starts from the scene's 2 N and finds the tension back. Run:
``python examples/05_reach.py`` (a few seconds).
"""

import numpy as np

import rodsim

scene = rodsim.load_scene("table3-catheter1")
key = "tendons.tendon.tendon_actuation.force"
target = rodsim.solve(scene, "static", overrides=[f"{key}=1.5"]).tip("catheter")

found = rodsim.reach(scene, target, [key])
print(f"target [m]: {np.array2string(target, precision=5)}")
print(f"tension found: {found.values[0]:.6f} N (the target was made with 1.5 N)")
print(f"distance to the target: {found.distance:.1e} m in {found.evaluations} equilibria; "
      f"{found.message}")
assert found.success
