"""The tendon-driven catheter of the paper (Table 3, catheter 1): a catheter and one tendon
in a lumen, pulled with a force F_A.

Solves the shipped scene ``table3-catheter1`` at a few tendon forces (warm scene overrides,
the same syntax as the CLI's ``--set``) and prints the catheter's tip: the catheter bends
towards the tendon's side (+y) more as F_A grows. Run:
``python examples/02_tendon_catheter.py`` (a few seconds), or open
``examples/notebooks/02_tendon_catheter.ipynb``.
"""

# %%
import numpy as np

import rodsim

# %%
scene = rodsim.load_scene("table3-catheter1")
print("F_A [N]   tip x, y, z [m]               residual")
for force in (0.5, 1.0, 2.0):
    result = rodsim.solve(scene, "static",
                          overrides=[f"tendon_actuation.force={force}"])
    assert result.success, result.message
    tip = result.tip("catheter")
    print(f"{force:5.2f}     {np.array2string(tip, precision=5)}   "
          f"{result.residual:.1e}")
result  # noqa: B018 (a notebook shows the last result's summary table)
