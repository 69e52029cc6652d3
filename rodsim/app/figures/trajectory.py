"""The figure of a trajectory archive (``rodsim simulate``; docs/dynamics.md): the first
rod's tip coordinates against time, and the energies against time with the balance
T + V + D − W − (T₀ + V₀), the integrator's own error (docs/dynamics.md, "Energy")."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.figure import Figure

__all__ = ["trajectory_figure"]


def trajectory_figure(ds: xr.Dataset) -> Figure:
    """Two panels: the tip's x, y, z [m] against t [s]; the kinetic energy T, the potential
    energy's change V − V₀, the dissipated energy D, the work W and the balance error [J]
    (the last two and V only where the scene is conservative: NaN is not drawn)."""
    figure, (motion, energy) = plt.subplots(1, 2, figsize=(11.0, 4.2),
                                            constrained_layout=True)
    times = ds["time"].values
    rods = ds["rod"].values.astype(str)
    first = rods[0]
    tip = int(np.flatnonzero(rods == first)[-1])
    for axis, name in enumerate("xyz"):
        motion.plot(times, ds["position"].values[:, tip, axis], label=name, color=f"C{axis}")
    motion.set_xlabel("t [s]")
    motion.set_ylabel(f"tip of {first} [m]")
    motion.legend(loc="best")
    kinetic = ds["kinetic_energy"].values
    potential = ds["potential_energy"].values - ds["potential_energy"].values[0]
    dissipated = ds["dissipated_energy"].values
    work = ds["work"].values
    balance = kinetic + potential + dissipated - work
    for values, label, style in ((kinetic, "kinetic T", "-"),
                                 (potential, "potential V - V0", "-"),
                                 (dissipated, "dissipated D", "--"),
                                 (work, "work W", ":"),
                                 (balance, "balance T + V + D - W - (T0 + V0)", "-")):
        if np.any(np.isfinite(values)):
            energy.plot(times, values, ls=style, label=label)
    energy.set_xlabel("t [s]")
    energy.set_ylabel("energy [J]")
    energy.legend(loc="best", fontsize="small")
    title = ds.attrs.get("title", "")
    if not int(ds.attrs.get("complete", 1)):
        title += f" (incomplete: {str(ds.attrs.get('message', ''))[:80]})"
    figure.suptitle(title)
    return figure
