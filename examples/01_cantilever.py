"""The paper's cantilever (Table 1): a catheter clamped at one end under a 50 g hanging mass.

Solves the shipped scene ``table1-50g`` with the direct Newton solver and with CVODE, and
compares both tips with the exact elastica (the continuum answer rodsim converges to).
Run: ``python examples/01_cantilever.py`` (a few seconds; the first run on a machine also
compiles the kernels, once), or open ``examples/notebooks/01_cantilever.ipynb``.
"""

# %%
import numpy as np

import rodsim
from rodsim.core.analytic.reference import cantilever_reference

# %%
scene = rodsim.load_scene("table1-50g")
catheter = scene.rods["catheter"]
static = rodsim.solve(scene, "static")
cvode = rodsim.solve(scene, "cvode")
for result in (static, cvode):
    assert result.success, result.message
static  # noqa: B018 (a notebook shows the result's summary table)

# %%
reference = cantilever_reference(scene)  # the exact elastica of this rod and load
exact = np.array([reference.exact.x[-1], reference.exact.y[-1], 0.0])
print(f"N = {catheter.nodes} control points, L = {catheter.length} m")
print(f"tip, static   [m]: {np.round(static.tip(), 6)}")
print(f"tip, cvode    [m]: {np.round(cvode.tip(), 6)}")
print(f"tip, elastica [m]: {np.round(exact, 6)}")
print(f"static vs elastica: {reference.tip_error(static.positions('catheter')):.2e} L"
      "  (the discretisation error at this N)")
print(f"cvode vs static:    {np.linalg.norm(cvode.tip() - static.tip()) / catheter.length:.2e} L")
