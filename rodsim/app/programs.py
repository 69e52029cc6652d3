"""Values that vary in time in physical time: a program maps a term's numeric value to a
piecewise-linear table (times, values), checked against the key's range before any work
(docs/dynamics.md, "Initial state and programs"); :class:`Programs` gives the model with
the values of a time."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey, numeric_key, scene_with
from rodsim.core.damping_options import ELASTIC_TERMS
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError, shown

__all__ = ["Program", "check_programs", "value_at", "Programs"]

Program = Mapping[str, tuple[Sequence[float], Sequence[float]]]


def check_programs(scene: Scene, program: Program | None
                   ) -> tuple[list[NumericKey], list[np.ndarray], list[np.ndarray]]:
    """The checked programs: keys, times, values (SceneError, one line, for a key that is not
    a term's number, times that do not increase, or a value outside the key's range)."""
    keys, times, values = [], [], []
    for name, table in (program or {}).items():
        key = numeric_key(scene, name)
        parts = key.path.split(".")
        if len(parts) != 4 or parts[2] in ("base", "supports") or (
                parts[0] == "rods" and parts[2] in ELASTIC_TERMS):
            raise SceneError(f"program {shown(name, bare=True)}: {key.path} cannot vary in "
                             "time; allowed: a load's or a tendon's value (a term parameter "
                             "other than the rod's own stiffness)")
        try:
            t, v = (np.asarray(part, dtype=float) for part in table)
        except (TypeError, ValueError):
            raise SceneError(f"program {shown(name, bare=True)}: expected (times, values), two "
                             "lists of numbers") from None
        if t.ndim != 1 or t.shape != v.shape or t.size == 0 or not (
                np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
            raise SceneError(f"program {shown(name, bare=True)}: expected times and values of "
                             "the same length, finite")
        if np.any(np.diff(t) < 0.0) or np.any(t[2:] == t[:-2]):
            raise SceneError(f"program {shown(name, bare=True)}: times must not decrease (one "
                             "repeated time is a step)")
        keys.append(key)
        times.append(t)
        values.append(v)
    for row in range(max((len(t) for t in times), default=0)):
        for k, key in enumerate(keys):  # every table value, against its key's range
            if row < len(times[k]):
                scene_with(scene, [key], [float(values[k][row])])
    return keys, times, values


def value_at(t: float, times: np.ndarray, values: np.ndarray, before: bool = False) -> float:
    """The piecewise-linear program at ``t`` (its end values outside; at a step, the value
    after it, or with ``before`` the value before it)."""
    right = int(np.searchsorted(times, t, side="left" if before else "right"))
    if right == 0:
        return float(values[0])
    if right == len(times):
        return float(values[-1])
    t0, t1 = times[right - 1], times[right]
    share = (t - t0) / (t1 - t0)
    return float(values[right - 1] + share * (values[right] - values[right - 1]))




class Programs:
    """The models of a scene's values in time: ``model`` with the checked programs
    (:func:`check_programs`) at each time, the same object while nothing changes."""

    def __init__(self, scene: Scene, model: Model, program: Program | None) -> None:
        self.scene, self.model = scene, model
        self.keys, self.times, self.values = check_programs(scene, program)
        self._models: dict[tuple[float, ...], Model] = {}

    @property
    def breaks(self) -> list[float]:
        """Every table time: where a value's slope changes or it jumps."""
        return sorted({float(t) for times in self.times for t in times})

    def model_at(self, t: float, before: bool = False) -> Model:
        """The model with the values at ``t`` (``before``: just before ``t``)."""
        if not self.keys:
            return self.model
        now = tuple(value_at(t, times, values, before)
                    for times, values in zip(self.times, self.values, strict=True))
        if now not in self._models:
            if len(self._models) > 64:
                self._models.clear()
            changed = self.model.with_values(scene_with(self.scene, self.keys, list(now)))
            assert changed is not None
            self._models[now] = changed
        return self._models[now]
