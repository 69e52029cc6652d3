"""The analytic reference curves a study figure draws (the continuum models of
``rodsim.core.analytic``), recomputed from the archive's spec alone."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from rodsim.app.figures import labels

__all__ = ["OVERLAYS", "reference_centerlines", "draw_references"]

#: Every how many σ samples the AM markers are drawn (101 samples: 11 markers).
MARKER_EVERY = 10

#: Analytic curves drawn for a study's reference kind: (kind, label, style) — the first is
#: the reference the errors are measured against; the style is keyword arguments of
#: ``Axes.plot``.
OVERLAYS: dict[str, tuple[tuple[str, str, dict[str, Any]], ...]] = {
    "exact": (("exact", "exact elastica", {"color": "k", "lw": 0.9, "ls": "-"}),
              ("paper", "analytical model (AM), Eqs. (21)–(23) corrected",
               {"color": "k", "ls": "none", "marker": "o", "mfc": "none", "ms": 4})),
    "paper": (("paper", "analytical model (AM), Eqs. (21)–(23) corrected",
               {"color": "k", "lw": 0.9, "ls": "-"}),),
    "extensible": (("extensible", "extensible elastica", {"color": "k", "lw": 0.9, "ls": "-"}),),
    "arc": (("arc", "constant-curvature arc", {"color": "k", "lw": 0.9, "ls": "-"}),),
}
def reference_centerlines(ds: xr.Dataset, kinds: Sequence[str] | None = None
                          ) -> dict[str, dict[tuple[int, ...], np.ndarray]]:
    """Analytic references (σ, 3) [m] of the first rod at every grid point that has one.

    Returns ``{kind: {grid index: curve}}`` for each of ``kinds`` (default: the study's
    reference). Recomputed from the archive's ``spec_json`` (the base scene and the sweeps,
    ``rodsim.app.study.point_scene``), so it needs nothing but the Dataset; the curves
    of each point are ``rodsim.app.scoring.reference_curves``. Points whose scene does
    not qualify, or is invalid, are left out.
    """
    from rodsim.app.scoring import reference_curves
    from rodsim.app.study_spec import StudySpec, point_scene
    from rodsim.core.analytic.reference import REFERENCE_KINDS

    spec_json = ds.attrs.get("spec_json")
    spec = StudySpec.from_json(spec_json) if spec_json else None
    wanted = kinds or ([spec.reference] if spec is not None and spec.reference else [])
    kinds = [k for k in wanted if k in REFERENCE_KINDS]
    out: dict[str, dict[tuple[int, ...], np.ndarray]] = {k: {} for k in kinds}
    if spec is None or not kinds:
        return out
    sigma = ds["sigma"].values
    for index in labels.grid_indices(ds, labels.sweep_dims(ds)):
        try:
            curves = reference_curves(point_scene(spec, index), kinds, sigma)
        except Exception:  # an invalid point (recorded as such): nothing to draw
            continue
        for kind, curve in curves.items():
            if curve is not None:
                out[kind][index] = curve
    return out


def draw_references(ds: xr.Dataset, axes: plt.Axes) -> dict[tuple[int, ...], np.ndarray]:
    """Draw each distinct analytic reference curve once; returns the study's reference."""
    overlays = OVERLAYS.get(ds.attrs.get("reference", ""), ())
    if not overlays:
        return {}
    curves = reference_centerlines(ds, [kind for kind, _, _ in overlays])
    for kind, label, style in overlays:
        drawn: list[np.ndarray] = []
        for curve in curves[kind].values():
            if any(np.allclose(curve, other, rtol=0.0, atol=1e-12) for other in drawn):
                continue
            every = MARKER_EVERY if style.get("marker") else None
            axes.plot(curve[:, 0], curve[:, 1], markevery=every, zorder=3,
                      label=None if drawn else label, **style)
            drawn.append(curve)
    return curves[overlays[0][0]]
