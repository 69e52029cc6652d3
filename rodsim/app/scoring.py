"""Scoring against a reference, one home: the analytic reference curves of a scene, a
point's tip and area errors (Fig. 21's area between centerlines), a convergence sweep scored
against its last point, and the reference lines of ``rodsim run``'s summary. The continuum
models themselves are ``rodsim.core.analytic``'s."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.core.analytic.reference import (
    REFERENCE_KINDS,
    cantilever_reference,
    reference_centerline,
)
from rodsim.core.scene import Scene

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["resample", "ribbon_area", "point_errors", "score_against_last",
           "reference_curves", "reference_lines"]


def resample(s: np.ndarray, positions: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Positions at normalised rest arc length σ (linear along the discrete centerline)."""
    t = s / s[-1]
    return np.stack([np.interp(sigma, t, positions[:, k]) for k in range(3)], axis=1)


def ribbon_area(a: np.ndarray, b: np.ndarray) -> float:
    """Area between two centerlines sampled at the same σ, in the x–y plane (Fig. 21).

    The sum of the quadrilaterals (a_i, a_{i+1}, b_{i+1}, b_i): the area of the polygon the
    two curves enclose when they do not cross, and never cancelling when they do.
    """
    ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    quads = np.stack([np.stack([ax[:-1], ay[:-1]], 1), np.stack([ax[1:], ay[1:]], 1),
                      np.stack([bx[1:], by[1:]], 1), np.stack([bx[:-1], by[:-1]], 1)], 1)
    x, y = quads[..., 0], quads[..., 1]
    signed = 0.5 * np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1)
    return float(np.sum(np.abs(signed)))


def point_errors(scene: Scene, kind: str | None, centerline: np.ndarray, sigma: np.ndarray,
                 length: float, history_tips: Any = None) -> dict[str, Any]:
    """A study point's errors against the analytic reference ``kind`` (nothing when ``kind``
    is not an analytic one or the scene does not qualify): ``tip_error`` and
    ``area_error`` of the first rod's ``centerline`` (σ samples) / L, and with
    ``history_tips`` (a flat list of the tip after each step) ``history_error``."""
    if kind not in REFERENCE_KINDS:
        return {}
    reference = reference_centerline(scene, kind, sigma * length)
    if reference is None:
        return {}
    out: dict[str, Any] = {
        "tip_error": float(np.linalg.norm(centerline[-1] - reference[-1]) / length),
        "area_error": ribbon_area(centerline, reference) / length}
    if history_tips is not None:
        tips = np.asarray(history_tips, dtype=float).reshape(-1, 3)
        out["history_error"] = (np.linalg.norm(tips - reference[-1], axis=1)
                                / length).tolist()
    return out


def score_against_last(ds: xr.Dataset, dim: str, length: float) -> None:
    """Tip and area errors of the first rod against the last point along ``dim`` (which a
    convergence sweep orders from coarse to fine)."""
    import xarray as xr

    first = ds["centerline"].isel(rod=0)
    reference = first.isel({dim: -1})
    gap = first.isel(sigma=-1) - reference.isel(sigma=-1)
    distance = xr.apply_ufunc(np.sqrt, (gap**2).sum("axis"))
    ds["tip_error"] = (distance / length).transpose(*ds["status"].dims)
    areas = xr.apply_ufunc(ribbon_area, first, reference,
                           input_core_dims=[["sigma", "axis"]] * 2, vectorize=True)
    ds["area_error"] = (areas / length).transpose(*ds["status"].dims)
    ds["tip_error"].attrs = {"units": "1",
                             "long_name": f"tip distance to the last {dim} point / L"}
    ds["area_error"].attrs = {"units": "m", "long_name": f"area between the centerline and "
                              f"the last {dim} point's / L (Fig. 21)"}


def reference_curves(scene: Scene, kinds: Sequence[str], sigma: np.ndarray
                     ) -> dict[str, np.ndarray | None]:
    """The analytic references (σ, 3) [m] of ``scene``'s first rod for each of ``kinds``
    (``None`` where the scene does not qualify), as a figure draws them: the hanging-mass
    kinds (``exact``, ``paper``, ``extensible``) from one
    ``rodsim.core.analytic.reference.cantilever_reference``, interpolated at σ L (the
    paper's model is sampled in φ); ``arc`` from
    ``rodsim.core.analytic.reference.reference_centerline``."""
    s = sigma * next(iter(scene.rods.values())).length
    cantilever = (cantilever_reference(scene) if set(kinds) - {"arc"} else None)
    out: dict[str, np.ndarray | None] = {}
    for kind in kinds:
        if kind == "arc":
            curve = reference_centerline(scene, kind, s)
        elif cantilever is None:
            curve = None
        else:
            shape = getattr(cantilever, kind)
            curve = np.zeros((len(s), 3))
            curve[:, 0] = np.interp(s, shape.s, shape.x)
            curve[:, 1] = np.interp(s, shape.s, shape.y)
        out[kind] = curve
    return out


def reference_lines(scene: Scene, positions: np.ndarray) -> list[str]:
    """The lines of ``rodsim run``'s summary that score a run against the analytic models
    of a hanging-mass cantilever (the load α and the tip errors), or say why there are
    none."""
    try:
        reference = cantilever_reference(scene)
    except (ValueError, ArithmeticError) as exc:  # beyond the analytic models' reach
        return [f"load        analytic references n/a ({exc})"]
    if reference is None:
        return []
    extensible = (f"{100 * reference.tip_error(positions, 'extensible'):.4f} % of L"
                  if reference.extensible is not None else "n/a (tip force ≥ E_s A)")
    return [f"load        α = F L²/(2EI) = {reference.alpha:.4g}  (F = {reference.force:.4g} N)",
            f"tip error   vs analytical model (Eqs. 21–23, corrected): "
            f"{100 * reference.tip_error(positions, 'paper'):.4f} % of L",
            f"            vs exact elastica: "
            f"{100 * reference.tip_error(positions, 'exact'):.4f} % of L;  "
            f"vs extensible elastica (E_s A): {extensible}"]
