"""A track's ramp read as legs (``rodsim track --ramp KEY=START:STOP:COUNT:STOP:COUNT``,
docs/inverse.md): the runs of steps over which the ramped value only rises or only falls,
and the hysteresis they show, the tip's distance between two steps at the same value (with
friction, docs/tendon.md, the release leg does not retrace the pull)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Leg", "ramp_legs", "Hysteresis", "hysteresis"]


@dataclass(frozen=True)
class Leg:
    """Steps ``steps`` (consecutive; a turning step ends one leg and starts the next) over
    which the ramped value ``rises`` (or falls)."""

    steps: np.ndarray
    rises: bool


def ramp_legs(values: np.ndarray) -> list[Leg]:
    """The legs of the ramped ``values`` (one per step); a repeated value stays in its leg;
    a ramp of one step, or of one value only, is one rising leg."""
    direction = np.sign(np.diff(values))
    legs: list[Leg] = []
    start, current = 0, 0.0
    for i, d in enumerate(direction):
        if d == 0.0 or d == current or current == 0.0:
            current = current or d
            continue
        legs.append(Leg(np.arange(start, i + 1), bool(current > 0)))
        start, current = i, d
    legs.append(Leg(np.arange(start, len(values)), bool(current >= 0)))
    return legs


@dataclass(frozen=True)
class Hysteresis:
    """The largest tip distance [m] between two steps ``first`` < ``second`` at the same
    ramped value."""

    distance: float
    first: int
    second: int


def hysteresis(values: np.ndarray, tips: np.ndarray) -> Hysteresis | None:
    """The largest distance between the tips (steps, 3) [m] of two steps whose ramped
    values agree to 1e-9 of the largest; None when no value repeats (a one-way ramp)."""
    scale = 1e-9 * max(float(np.max(np.abs(values), initial=0.0)), 1e-300)
    best: Hysteresis | None = None
    for i in range(len(values)):
        for j in range(i + 1, len(values)):
            if abs(values[i] - values[j]) <= scale:
                distance = float(np.linalg.norm(tips[i] - tips[j]))
                if best is None or distance > best.distance:
                    best = Hysteresis(distance, i, j)
    return best
