"""A run's states over time: one time axis, the states on it, each rod's shape at each time.

The value a run returns beside its final state (``Result.trajectory``) when its
``rodsim.solvers.recorder.SaveAt`` asks for one: times (the integrator's time: the
pseudo-time of the pseudo-dynamics today), the free coordinates at each (the paper's state
vector, Eq. (18) per rod, Eq. (30) stacked) and, per rod, positions and quaternions laid out
as ``rodsim.solvers.result.RodShape`` with a leading time axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rodsim.core.model import Model

__all__ = ["Trajectory", "RodTrajectory"]


@dataclass(frozen=True)
class RodTrajectory:
    """One rod over time: control points (T, N, 3) [m], quaternions (T, N − 1, 4)."""

    positions: np.ndarray
    quaternions: np.ndarray


@dataclass(frozen=True)
class Trajectory:
    """States at increasing times (module docstring).

    Attributes
    ----------
    times
        (T,), increasing, in ``time_units``.
    states
        (T, n): the free coordinates at each time.
    rods
        Each rod's ``RodTrajectory``.
    time_units, time_meaning
        What ``times`` count (the integrator's ``history_time``: "s", "pseudo-time").
    """

    times: np.ndarray
    states: np.ndarray
    rods: dict[str, RodTrajectory]
    time_units: str = "s"
    time_meaning: str = "pseudo-time"

    @classmethod
    def of(cls, model: Model, times: np.ndarray, states: np.ndarray,
           time: tuple[str, str] = ("s", "pseudo-time")) -> Trajectory:
        """The trajectory of ``states`` (T, n) of ``model``'s free coordinates at ``times``."""
        if states.shape != (len(times), model.n):
            raise ValueError(f"a trajectory of {len(times)} times needs states of shape "
                             f"({len(times)}, {model.n}), got {states.shape}")
        full = np.array([model.full(x) for x in states]).reshape(len(times), model.full_size)
        rods = {name: RodTrajectory(full[:, rod.layout.position_index],
                                    full[:, rod.layout.quaternion_index])
                for name, rod in model.rods.items()}
        return cls(np.asarray(times, dtype=float), states, rods, time[0], time[1])

    def __len__(self) -> int:
        return len(self.times)

    def positions(self, rod: str | None = None) -> np.ndarray:
        """Control points of ``rod`` (default: the first rod) at each time, (T, N, 3) [m]."""
        return self.rods[rod or next(iter(self.rods))].positions

    def tip(self, rod: str | None = None) -> np.ndarray:
        """The tip of ``rod`` (default: the first rod) at each time, (T, 3) [m]."""
        return self.positions(rod)[:, -1]
