"""Equilibria along a path: the Table 3 catheter's tendon force ramped from 0 to 2 N in 21
steps, each warm-started from the last (``rodsim track`` on the command line).

Prints the tip's sideways deflection against the force; the archive (one ``step``
dimension) goes to ``runs/examples/track.nc``. Run: ``python examples/07_track.py``, or open
``examples/notebooks/07_track.ipynb``.
"""

# %%
from pathlib import Path

import numpy as np

import rodsim
from rodsim.io.archive import write_dataset

# %%
scene = rodsim.load_scene("table3-catheter1")
forces = np.linspace(0.0, 2.0, 21)
path = rodsim.track(scene, {"tendon_actuation.force": forces})
assert path.success, path.message
path  # noqa: B018 (a notebook shows the track's summary table)

# %%
tips = path.tips("catheter")
for force, tip in zip(forces[::5], tips[::5], strict=True):
    print(f"F_A = {force:4.2f} N   tip y = {tip[1] * 1e3:7.3f} mm")
folder = Path("runs") / "examples"
folder.mkdir(parents=True, exist_ok=True)
print("archive", write_dataset(path.to_xarray(), folder / "track.nc"))
