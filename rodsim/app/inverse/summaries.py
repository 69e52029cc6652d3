"""The notebook summaries of a track, a fit and a reach (``repr``: at most ten lines;
``_repr_html_``: the same rows as a table; ``rodsim.solvers.summary``). The objects are
typed loosely here: this module is imported by theirs and must not import them back."""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey
from rodsim.solvers.summary import millimetres, sketch_svg, summary_html, summary_text

__all__ = ["track_rows", "fit_rows", "reach_rows", "summary"]


def _key(key: NumericKey) -> str:
    """The key's last two parts (``tendon_actuation.force``), its component if any."""
    return ".".join(key.name.split(".")[-2:])


def _values(keys: list[NumericKey], values: np.ndarray, errors: np.ndarray | None = None
            ) -> str:
    return ", ".join(f"{_key(k)} = {float(v):.5g}"
                     + (f" ± {float(errors[i]):.2g}" if errors is not None else "")
                     for i, (k, v) in enumerate(zip(keys, values, strict=True)))


def track_rows(track: Any) -> list[tuple[str, str]]:
    """Outcome, steps, the ramp, the last tip, stability, residuals and time."""
    planned = len(track.values)
    rows = [("outcome", track.message if track.success else f"FAILED: {track.message}"),
            ("steps", f"{track.steps} of {planned} completed")]
    if planned:
        rows.append(("ramp", ", ".join(
            f"{_key(k)}: {float(track.values[0, i]):.4g} → {float(track.values[-1, i]):.4g}"
            for i, k in enumerate(track.keys))))
    if track.steps:
        first = next(iter(track.model.rods))
        rows.append((f"last tip of {first}", millimetres(track.tips(first)[-1])))
        rows.append(("largest residual", f"{max(track.residuals):.3g}"))
    unstable = track.unstable_steps
    rows.append(("stability", "every step stable" if not unstable
                 else f"UNSTABLE at steps {', '.join(map(str, unstable[:8]))}"))
    rows.append(("wall time", f"{sum(track.times):.3g} s"))
    last = [f"{label} {value:.2g} L" for label, value in
            (("discretisation", track.discretisation_error), ("penalty", track.penalty_error))
            if value is not None]
    if last:
        rows.append(("error, last step", ", ".join(last)))
    largest = []
    for label, values in (("discretisation", track.step_discretisation_error),
                          ("penalty", track.step_penalty_error)):
        errors = np.asarray(values, dtype=float)
        if errors.size and np.any(np.isfinite(errors)):
            step = int(np.nanargmax(errors))
            largest.append(f"{label} {errors[step]:.2g} L at step {step}")
    if largest:
        rows.append(("largest per step", ", ".join(largest)))
    return rows


def fit_rows(fit: Any) -> list[tuple[str, str]]:
    """Fitted values with standard errors, residual RMS, work, stability."""
    return [("outcome", fit.message),
            ("fitted", _values(fit.keys, fit.values, fit.errors)),
            ("initial", _values(fit.keys, fit.initial)),
            ("residual RMS", f"{fit.residual_rms:.3g} m ({fit.residual_rms_relative:.2g} L) "
                             f"over {len(fit.matched)} points"),
            ("work", f"{fit.evaluations} evaluations, {fit.jacobians} Jacobians, "
                     f"{fit.wall_time:.3g} s"),
            ("stability", "stable" if fit.stable else "UNSTABLE fitted equilibrium")]


def reach_rows(reach: Any) -> list[tuple[str, str]]:
    """Outcome, values found, target, tip and distance, work."""
    rows = [("outcome", reach.message if reach.success else f"FAILED: {reach.message}"),
            ("values", _values(reach.keys, reach.values)),
            ("target", millimetres(reach.target)),
            (f"tip of {reach.rod}", millimetres(reach.tip)),
            ("distance", f"{reach.distance:.3g} m (tolerance {reach.tolerance:.3g} m)")]
    if reach.angle is not None:
        rows.append(("tip angle", f"{reach.angle:.3g} rad from the target frame"))
    rows.append(("work", f"{reach.evaluations} evaluations, {reach.jacobians} Jacobians, "
                         f"{reach.wall_time:.3g} s"))
    if reach.unstable:
        rows.append(("stability", "UNSTABLE equilibrium"))
    return rows


def summary(result: Any, html: bool) -> str:
    """The text (``repr``) or the HTML table of a Track, Fit or Reach."""
    kind = type(result).__name__
    if kind == "Track":
        title = f"rodsim Track: scene {result.scene.name!r}, integrator {result.integrator}"
        rows = track_rows(result)
    else:
        title = f"rodsim {kind}: scene {result.result.scene.name!r}, rod {result.rod}"
        rows = fit_rows(result) if kind == "Fit" else reach_rows(result)
    return summary_html(title, rows, sketch(result)) if html else summary_text(title, rows)


def sketch(result: Any) -> str:
    """The HTML summary's sketch: a track's rods at its last completed step and the first
    rod's tip path through the steps (faint); a fit's fitted shape and the measured points;
    a reach's shape and the target."""
    kind = type(result).__name__
    if kind == "Track":
        if not result.steps:
            return ""
        counts = [rod.nodes for rod in result.model.rods.values()]
        ends = np.cumsum(counts)
        last = result.positions[-1]
        return sketch_svg([last[end - count:end] for end, count in zip(ends, counts,
                                                                        strict=True)],
                          [result.tips()])
    shapes = [rod.positions for rod in result.result.rods.values()]
    return sketch_svg(shapes, marks=[result.points.xyz if kind == "Fit" else result.target])
