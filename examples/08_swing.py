"""Motion in physical time: the Table 1 catheter (21 control points) held 10 mN below its
equilibrium at the tip, then let go, swings about its equilibrium for 1.2 s
(``rodsim.simulate``, the implicit midpoint rule; ``rodsim simulate`` on the command line).

The tip's swing is timed by its crossings of the equilibrium and compared with the
in-plane bending mode's natural frequency about that equilibrium (``rodsim.modes``); the
undamped run keeps its energy balance to round-off. Run: ``python examples/08_swing.py``
(a few seconds), or open ``examples/notebooks/08_swing.ipynb``.
"""

# %%
import numpy as np

import rodsim

# %%
scene = rodsim.load_scene("table1-50g").with_overrides(["nodes=21"])
modes = rodsim.modes(scene, 2)
in_plane = int(np.argmax(np.abs(modes.shapes[:, -1, 1])))  # the mode that moves the tip in y
frequency = modes.frequencies[in_plane]
modes  # noqa: B018 (a notebook shows the modes' summary table)

# %%
run = rodsim.simulate(scene, 1.2, output_dt=0.005,
                      initial={"tip_load.force": [0.0, -0.01, 0.0]})
assert run.success, run.message
run  # noqa: B018 (a notebook shows the run's summary table)

# %%
y = run.positions[:, -1, 1] - modes.result.tip()[1]  # the tip's distance from equilibrium
crossing = np.flatnonzero(np.sign(y[1:]) != np.sign(y[:-1]))
times = run.times[crossing] - y[crossing] * (
    run.times[crossing + 1] - run.times[crossing]) / (y[crossing + 1] - y[crossing])
swing = 1.0 / (2.0 * np.mean(np.diff(times)))  # two crossings a period
print(f"in-plane mode       {frequency:.4f} Hz")
print(f"swing of the tip    {swing:.4f} Hz  ({len(times)} crossings)")
print(f"energy balance      {np.max(np.abs(run.energy_error)):.1e} J"
      f"  (largest kinetic energy {np.max(run.kinetic_energy):.1e} J)")
assert abs(swing - frequency) < 0.01 * frequency  # the midpoint rule: (ω h)² / 24
