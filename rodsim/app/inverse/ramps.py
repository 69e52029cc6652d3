"""The ramps of ``rodsim track`` (rodsim/app/inverse/track.py): ``--ramp`` text to values,
values checked (``ramp_values``, ``check_rules_across_tables``) before any work.

``KEY=START:STOP:COUNT`` gives COUNT equally spaced values from START to STOP; further
``:STOP:COUNT`` legs go on from the last stop, each COUNT more values ending at its STOP
(``tension=0.5:3:11:0.5:10`` pulls up in 11 values and back down in 10 more: a pull–release
cycle, which a tendon with friction answers with its hysteresis loop, docs/tendon.md).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey, scene_with
from rodsim.app.inverse.track_steps import values_text
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError

__all__ = ["MAX_STEPS", "check_rules_across_tables", "parse_ramp", "ramp_values"]

#: Most steps a track may have (a ramp's values): beyond, the values alone fill memory and
#: the run takes days.
MAX_STEPS = 100_000


def parse_ramp(text: str) -> tuple[str, np.ndarray]:
    """``KEY=START:STOP:COUNT[:STOP:COUNT …]`` → (key, the values); SceneError."""
    key, sep, spec = text.partition("=")
    parts = spec.split(":")
    if not sep or not key.strip() or len(parts) < 3 or len(parts) % 2 == 0:
        raise SceneError(f"--ramp {text[:60]!r}: expected KEY=START:STOP:COUNT, optionally "
                         "followed by :STOP:COUNT legs")
    try:
        stops = [float(v) for v in parts[:1] + parts[1::2]]
        counts = [int(v) for v in parts[2::2]]
    except ValueError:
        raise SceneError(f"--ramp {text[:60]!r}: START and STOP must be numbers, COUNT a "
                         "whole number") from None
    if (not all(np.isfinite(stops)) or counts[0] < 2 or min(counts) < 1
            or sum(counts) > MAX_STEPS):
        raise SceneError(f"--ramp {text[:60]!r}: finite START and STOP, a first COUNT from 2 "
                         f"and {MAX_STEPS} values at most expected")
    values = [np.linspace(stops[0], stops[1], counts[0])]
    for start, stop, count in zip(stops[1:-1], stops[2:], counts[1:], strict=True):
        values.append(np.linspace(start, stop, count + 1)[1:])
    return key.strip(), np.concatenate(values)


def ramp_values(ramps: Mapping[str, Sequence[float] | np.ndarray]) -> np.ndarray:
    """The ramps as a (steps, keys) array of finite numbers; SceneError otherwise (a text, a
    scalar, ramps of different lengths)."""
    if not isinstance(ramps, Mapping) or not ramps:
        raise SceneError("ramps must map scene keys to lists of values (e.g. {'force': "
                         "[0, 1, 2]})")
    columns = []
    for key, ramp in ramps.items():
        if isinstance(ramp, (str, bytes)) or not isinstance(ramp, (Sequence, np.ndarray)):
            raise SceneError(f"ramp {str(key)[:60]!r}: expected a list of numbers, got "
                             f"{type(ramp).__name__} (parse_ramp reads KEY=START:STOP:COUNT)")
        try:
            column = np.asarray(ramp, dtype=float)
        except (TypeError, ValueError):
            raise SceneError(f"ramp {str(key)[:60]!r}: expected a list of numbers") from None
        if column.ndim != 1:
            raise SceneError(f"ramp {str(key)[:60]!r}: expected a flat list of numbers")
        columns.append(column)
    lengths = {len(c) for c in columns}
    if len(lengths) != 1 or not 2 <= lengths.pop() <= MAX_STEPS:
        raise SceneError(f"every ramp needs the same number of values (2 to {MAX_STEPS})")
    values = np.column_stack(columns)
    if not np.all(np.isfinite(values)):
        raise SceneError("ramp values must be finite numbers")
    return values


def check_rules_across_tables(scene: Scene, keys: Sequence[NumericKey],
                               values: np.ndarray) -> None:
    """The rules across tables (radius < length, a tendon's length its catheter's, a lumen
    offset inside the radii) checked before any work, at the first and last steps and at each
    ramped value's smallest and largest (each rule compares values monotonically, so a ramp
    that breaks one breaks it at one of these; a string tendon's routing, whose spline can
    overshoot its knots, at every distinct step); a break is blamed on the ramp that caused it,
    not on the scene's value it made invalid (issue 23: found only at that step, after the
    earlier steps' work, and blamed on a value the user never gave)."""
    from rodsim.app.inverse.parameter_keys import _local
    from rodsim.core.scene import cross_table_culprit

    if all(_local(key) for key in keys):
        return
    rows = sorted({0, len(values) - 1, *np.argmin(values, axis=0).tolist(),
                   *np.argmax(values, axis=0).tolist()})
    if any(key.routing for key in keys):  # a spline's overshoot is not monotone: every step
        rows = np.unique(values, axis=0, return_index=True)[1].tolist()
    for row in sorted(rows):
        try:
            scene_with(scene, keys, values[row])
        except SceneError as exc:
            found = cross_table_culprit(exc, [key.path for key in keys if key.index is None])
            if found is None and any(key.routing for key in keys):
                raise SceneError(f"--ramp at step {row} ({values_text(keys, values[row])}): "
                                 f"{exc}") from None
            if found is None:
                raise
            column = next(k for k, key in enumerate(keys) if key.path == found[0])
            raise SceneError(f"--ramp {keys[column].name} reaches {values[row, column]:g} at "
                             f"step {row}, which {found[1]}", key=found[0],
                             value=float(values[row, column]), reason=found[1]) from None
