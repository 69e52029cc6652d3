"""Fit a scene value to measured points: the Young's modulus of the Table 1 catheter from the
positions of its control points.

The "measurement" is made here by solving the same scene with E = 5 MPa and adding 0.1 mm of
noise; the fit starts from the scene's E (the paper's value) and recovers E with its standard
error. With real data, read a CSV of x,y,z (optionally s) with
``rodsim.app.inverse.fit.read_points``. Run: ``python examples/04_fit_measured_points.py``.
"""

import numpy as np

import rodsim
from rodsim.app.inverse.fit import Points

scene = rodsim.load_scene("table1-50g", ["nodes=20"])
truth = rodsim.solve(scene, "static", overrides=["youngs_modulus=5e6"])
noise = np.random.default_rng(1).normal(0.0, 1e-4, size=(19, 3))
measured = Points(truth.positions("catheter")[1:] + noise, None)  # x, y, z [m], no s

found = rodsim.fit(scene, measured, ["youngs_modulus"])
value, error = found.values[0], found.errors[0]
print(f"start E = {found.initial[0]:.4g} Pa; fitted E = {value:.4g} ± {error:.2g} Pa "
      f"(true 5e6); residual RMS {found.residual_rms * 1e3:.3f} mm; "
      f"{found.evaluations} equilibria")
assert abs(value - 5e6) < 4 * error + 1e4
