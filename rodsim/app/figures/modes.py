"""The figure of a modes archive (``rodsim modes``; docs/dynamics.md): the first mode shapes
about the equilibrium, one panel each."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.figure import Figure

__all__ = ["modes_figure", "PANELS"]

#: Modes drawn (the lowest ones).
PANELS = 4
#: Largest displacement drawn, as a fraction of the largest extent of the equilibrium.
AMPLITUDE = 0.1
#: Share of the modal kinetic energy in rotation above which a mode is drawn as a torsion
#: mode (its nodes hardly move).
ROTATION = 0.5


def modes_figure(ds: xr.Dataset) -> Figure:
    """The lowest modes: the equilibrium (grey) and the equilibrium ± the mode's
    displacement scaled to ``AMPLITUDE`` of its extent, each in the world plane of the
    equilibrium's longest extent and the axis the mode moves most along of the other two."""
    count = min(PANELS, ds.sizes["mode"])
    figure, axes = plt.subplots(1, count, figsize=(3.6 * count + 0.8, 3.8),
                                constrained_layout=True, squeeze=False)
    positions = ds["position"].values
    spans = np.ptp(positions, axis=0)
    extent = float(np.max(spans)) or 1.0
    h = int(np.argmax(spans))
    rods = ds["rod"].values
    for k, panel in enumerate(axes[0]):
        shape = ds["mode_position"].values[k]
        largest = float(np.max(np.abs(shape)))
        scale = AMPLITUDE * extent / largest if largest > 0.0 else 0.0
        motion = np.sum(shape**2, axis=0)
        v = max((axis for axis in range(3) if axis != h), key=lambda axis: motion[axis])
        for rod in np.unique(rods):
            nodes = positions[rods == rod]
            moved = shape[rods == rod] * scale
            panel.plot(nodes[:, h], nodes[:, v], color="0.6", lw=1.0)
            for sign, style in ((1.0, "-"), (-1.0, "--")):
                panel.plot(nodes[:, h] + sign * moved[:, h], nodes[:, v] + sign * moved[:, v],
                           ls=style, lw=1.2, color=f"C{k}")
        frequency = float(ds["frequency"].values[k])
        torsion = float(ds["rotational_share"].values[k]) > ROTATION
        panel.set_title(f"mode {k + 1}: {frequency:.4g} Hz"
                        + (" (rotation)" if torsion else ""))
        panel.set_xlabel(f"{'xyz'[h]} [m]")
        panel.set_ylabel(f"{'xyz'[v]} [m]")
        panel.set_aspect("equal", adjustable="datalim")
    figure.suptitle(ds.attrs.get("title", ""))
    return figure
