"""An event of tendon friction inside a part of a midpoint step, located on the step
re-solved to the trial time: the machinery a routing point breaking loose
(rodsim/solvers/physical/breakaway.py) and one sticking again
(rodsim/solvers/physical/restick.py) share (docs/dynamics.md, "Friction in physical
time").

Each event is a vector of margins g_e(t), one per routing point, positive while the point
keeps its stick/slip state and ≤ 0 once it changed. A part from t₀ to t₁ has been solved
with the points as they are at t₀ (all margins watched > 0 there). Where some g_e is ≤ 0
at t₁, the first of them to change is located as an event's root is
(rodsim/solvers/physical/step_events.py): the root τ of min_e g_e(τ, Φ_τ) over those
points, Φ_τ the state one midpoint step from (t₀, x₀) to τ reaches, by the Illinois variant
of regula falsi to ``TIME_TOLERANCE`` × the part, the bracket's end past the crossing.

A dip inside a part. A margin > 0 at both ends of a part may have gone ≤ 0 inside it and
back: no sign change shows it. Each part is therefore screened on its cubic Hermite
interpolant (``hermite``; no Newton solve) at its quarter points (``SCREENS``); at the
first where some margin is ≤ 0 the part is solved to that time, and if a margin is ≤ 0
there on the scheme's own state it brackets the root, located as above. A dip narrower
than a quarter of the part, or one the interpolant misses, is still missed.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rodsim.solvers.physical.fixed_step import StepOutcome
from rodsim.solvers.physical.step_events import root

__all__ = ["SCREENS", "Measure", "Screen", "screen", "locate"]

#: A part is screened for a dip of a margin at its interior points t0 + k (t1 − t0)/SCREENS
#: (module docstring, "A dip inside a part").
SCREENS = 4

#: The margins at time t on the scheme's state the part solved to t reached.
Measure = Callable[[float, StepOutcome], np.ndarray]
#: The margins at time t on the part's interpolant.
Screen = Callable[[float], np.ndarray]


def screen(screened: Screen, t0: float, t1: float) -> float | None:
    """The first of the part's quarter points at which some margin is ≤ 0 on the part's
    interpolant (``screened``; module docstring, "A dip inside a part"), None if none
    is."""
    for k in range(1, SCREENS):
        t = t0 + (t1 - t0) * k / SCREENS
        if np.any(screened(t) <= 0.0):
            return t
    return None


def locate(measure: Measure, t0: float, start: np.ndarray, t1: float, after: np.ndarray,
           solve: Callable[[float], StepOutcome], screened: Screen | None = None
           ) -> tuple[float, StepOutcome | None]:
    """When in the part from ``t0`` to ``t1`` the first point changes its state: (τ, the
    outcome of the part solved from t0 to τ, None for τ = t1), ``start`` the margins at
    t0 (> 0 where watched), ``after`` those at t1, ``measure(t, outcome)`` the margins on
    a solved state, ``solve(τ)`` the part from t0 to τ; (t1, None) when no point changes
    in it. ``screened(t)``: the margins on the part's interpolant, where a margin that is
    > 0 at both ends is screened for a dip inside (module docstring)."""
    crossed = after <= 0.0
    reached: dict[float, StepOutcome] = {}
    whole = True  # the bracket is the whole part (not a dip's)
    if not np.any(crossed):
        dip = None if screened is None else screen(screened, t0, t1)
        if dip is None:
            return t1, None
        reached[dip] = solve(dip)  # the dip on the scheme's own state, or nothing
        found = measure(dip, reached[dip])
        if not np.any(found <= 0.0):
            return t1, None
        t1, after, crossed, whole = dip, found, found <= 0.0, False

    def g(t: float) -> float:
        if t not in reached:
            reached[t] = solve(t)
        return float(np.min(measure(t, reached[t])[crossed]))

    when = float(root(g, t0, float(np.min(start[crossed])), t1,
                       float(np.min(after[crossed]))))
    if when >= t1 and whole:
        return t1, None
    return when, reached[when]
