"""What a run records, as a value (``SaveAt``), and the recorder that keeps it.

Every integrator reports each accepted step to its run (``RunState.record``: the time,
the state, the force residual) and, an integrator with dense output, each step's interval
with its interpolant (``Recorder.dense``). The ``Recorder`` behind those calls
keeps what the run's ``SaveAt`` asks for (as diffrax's ``SaveAt`` says what
``diffeqsolve`` saves, apart from the solver):

- the per-step history of time, residual and the first rod's tip (Fig. 8; ``steps``);
- the trajectory: the state at every accepted step (``states``) or at requested output
  times (``times``), the latter interpolated from the step that spans them, so that output
  times do not force steps (scipy's ``OdeSolver.dense_output``, SUNDIALS' CV_NORMAL).

A run's trajectory becomes ``Result.trajectory``
(``rodsim.solvers.trajectory.Trajectory``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.model import Model
from rodsim.solvers.trajectory import Trajectory

__all__ = ["SaveAt", "Recorder", "History", "increasing_times"]


def increasing_times(times: Any, what: str) -> tuple[float, ...]:
    """``times`` as a tuple of finite floats ≥ 0, strictly increasing; ValueError (one line,
    naming ``what``) otherwise."""
    values = np.atleast_1d(np.asarray(times, dtype=float))
    if values.ndim != 1:
        raise ValueError(f"{what} must be a list of times, got an array of shape "
                         f"{values.shape}")
    if not np.all(np.isfinite(values)) or np.any(values < 0.0):
        raise ValueError(f"{what} must be finite and ≥ 0, got {values.tolist()}")
    if np.any(np.diff(values) <= 0.0):
        raise ValueError(f"{what} must increase strictly, got {values.tolist()}")
    return tuple(float(t) for t in values)


@dataclass(frozen=True)
class SaveAt:
    """What a run records.

    Attributes
    ----------
    steps
        Keep the per-step history (time, force residual, the first rod's tip): the
        ``history`` of ``rodsim.solvers.result.Result`` and its archive.
    states
        Keep the state at every accepted step in the trajectory.
    times
        Keep the state at these times (strictly increasing, s of the integrator's time), by
        dense output: only an integrator that has it (``Integrator.dense_output``) and a
        stop at a time (``rodsim.solvers.stops.Until``) take them.
    """

    steps: bool = True
    states: bool = False
    times: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "times", increasing_times(self.times, "SaveAt.times")
                           if len(self.times) else ())


class History:
    """Per-step record of time, residual and the first rod's tip (for Fig. 8)."""

    def __init__(self, model: Model) -> None:
        first = next(iter(model.rods.values()))
        # The tip's free indices, -1 where fixed (the model's map holds n there: made once
        # per model, where a map of every coordinate was made here for each run).
        tip = model._free_of[first.layout.position_index[-1]]
        self._tip_free = np.where(tip < model.n, tip, -1)
        # The free coordinates are offsets from the rest state (Model.x0): the tip's rest place.
        self._tip_rest = model.reference[first.layout.position_index[-1]]
        self.data: dict[str, list[Any]] = {"time": [], "residual": [], "tip": []}

    def record(self, time: float, x: np.ndarray, residual: float) -> None:
        self.data["time"].append(float(time))
        self.data["residual"].append(float(residual))
        self.data["tip"].append((self._tip_rest + x[self._tip_free]).tolist())


class Recorder:
    """Keeps what ``save`` asks for of a run on ``model`` (module docstring)."""

    def __init__(self, model: Model, save: SaveAt) -> None:
        self.save = save
        self.history = History(model)
        self._times: list[float] = []
        self._states: list[np.ndarray] = []
        self._pending = list(save.times)  # output times not reached yet, in order

    def record(self, time: float, x: np.ndarray, residual: float) -> None:
        """An accepted step ended at ``time`` in the state ``x`` with force residual
        ``residual``."""
        if self.save.steps:
            self.history.record(time, x, residual)
        if self.save.states:
            self._keep(time, x)

    def dense(self, low: float, high: float,
              interpolate: Callable[[float], np.ndarray]) -> None:
        """A step spanned [``low``, ``high``]; ``interpolate(t)`` is its dense output (the
        state at t in that span): keeps the state at every requested output time up to
        ``high`` not kept yet (an output time at the start, t = 0, with the first step)."""
        pending = self._pending  # the earlier ones were kept by earlier steps
        while pending and pending[0] <= high:
            t = pending.pop(0)
            self._keep(t, interpolate(max(t, low)))

    @property
    def pending(self) -> tuple[float, ...]:
        """The requested output times not reached yet."""
        return tuple(self._pending)

    def _keep(self, time: float, x: np.ndarray) -> None:
        self._times.append(float(time))
        self._states.append(np.array(x, dtype=float))

    def trajectory(self, model: Model, time: tuple[str, str]) -> Trajectory | None:
        """The kept states as a trajectory (None when nothing asked for one); ``time``: the
        units and meaning of the integrator's time."""
        if not (self.save.states or self.save.times):
            return None
        states = (np.array(self._states) if self._states
                  else np.empty((0, model.n)))
        return Trajectory.of(model, np.array(self._times, dtype=float), states, time)
