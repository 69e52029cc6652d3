"""Stiction under the implicit midpoint rule: when in a step a routing point of a string
tendon breaks loose (docs/dynamics.md, "Friction in physical time"; docs/tendon.md,
"Stiction").

A point held by its static friction μ_s (stuck, or sliding the other way) breaks loose when
the tension over it reaches its static bound; from then on it slides at its kinetic μ_k.
Each point has an event function, its margin to that bound g_e(t, x)
(``rodsim.core.tendon_friction.breakaway_margins``: at the model of time t — the actuator's
tension T(t) — and the state x, with the history carried to the step's start), positive
while it holds and ≤ 0 exactly where the stick/slip state read at x says it broke loose.

A step from (t₀, x₀) to t₁ is solved with the points as they are at t₀. Where some g_e
goes from > 0 at t₀ to ≤ 0 at t₁, the first of them to break is located as an event's root
is (rodsim/solvers/physical/step_events.py): the root τ of min_e g_e(τ, Φ_τ) over those
points, Φ_τ the state one midpoint step from (t₀, x₀) to τ reaches, by the Illinois variant
of regula falsi to ``TIME_TOLERANCE`` × the step, the bracket's end past the crossing. The
step is split there: its part up to τ is accepted (the point still held), friction's
history is carried at τ (the point reads as sliding from then on) and the rest of the step,
τ to t₁, is a new step with the point freed (rodsim/solvers/physical/trajectory.py), in
which the next point may break loose. A point already on its bound at a part's start (the
points past one that broke loose, whose freed tension reaches them at once: a cascade)
breaks loose there: the history is carried again at that time before the part is solved,
as a track's step is solved again after each breakaway.

A dip inside a part (a margin > 0 at both ends, ≤ 0 inside: the tension let out and pulled
back within one step, or the catheter swinging) is screened for on the part's interpolant
at its quarter points; the location and the screen are the machinery a point sticking
again shares (rodsim/solvers/physical/part_events.py).

A point that stops sliding — re-sticks — inside a part is located by its own event
(rodsim/solvers/physical/restick.py), the earlier of the two splitting the part. After each
split the rest of the step is checked again from the history carried at τ.

Re-solving the whole step with the point freed instead (what a run did before round 16)
gives friction's kinetic force over the part of the step before the breakaway: an O(h)
error in each step where a point breaks, which made the run converge erratically (orders
between −0.6 and 3.5 on a release, docs/dynamics.md).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rodsim.core.model import Model
from rodsim.core.tendon_friction import bound_coefficients, breakaway_margins
from rodsim.core.terms.tendon_string import TendonString
from rodsim.solvers.physical import part_events
from rodsim.solvers.physical.coordinates import model_state
from rodsim.solvers.physical.fixed_step import Motion, StepOutcome
from rodsim.solvers.physical.part_events import SCREENS

__all__ = ["sticky", "margins", "locate", "SCREENS"]


def sticky(model: Model) -> bool:
    """Whether a string tendon of ``model`` has stiction (μ_s above μ_k somewhere)."""
    return any(isinstance(term, TendonString) and term.sticky for term in model.terms)


def margins(model: Model, x: np.ndarray) -> np.ndarray | None:
    """g_e of every routing point of every string tendon with stiction in ``model`` at the
    state ``x`` (module docstring), concatenated in the terms' order; None when
    no tendon has stiction (μ_s = μ_k: nothing to locate, the kinetic run bitwise). ``x``
    is a motion's (``Motion.x``), as the steps hold it."""
    full = None
    out = []
    for term in model.terms:
        if not isinstance(term, TendonString) or not term.sticky:
            continue
        if full is None:
            full = model.full(model_state(model, x))
        mu_in, mu_out = bound_coefficients(term.kinetic, term.static, term.state)
        out.append(breakaway_margins(term.tension, mu_in, mu_out, term.turning_angles(full),
                                     term.profile, term.state))
    return np.concatenate(out) if out else None


def _margins(model: Model, x: np.ndarray) -> np.ndarray:
    """``margins``, of a model with stiction."""
    found = margins(model, x)
    assert found is not None
    return found


def locate(model_at: Callable[[float], Model], t0: float, start: np.ndarray, t1: float,
           end: Motion, solve: Callable[[float], StepOutcome],
           along: Callable[[float], np.ndarray] | None = None
           ) -> tuple[float, StepOutcome | None]:
    """When in the step from ``t0`` to ``t1`` the first point breaks loose: (τ, the outcome
    of the step from t0 to τ, None for τ = t1), ``start`` the margins at t0 (all > 0),
    ``end`` the step's end, ``solve(τ)`` the step from t0 to τ; (t1, None) when no point
    breaks loose in the step. ``along(t)``: the part's interpolant (free coordinates), on
    which a margin that is > 0 at both ends is screened for a dip inside
    (rodsim/solvers/physical/part_events.py)."""
    return part_events.locate(
        lambda t, outcome: _margins(model_at(t), outcome.motion.x), t0, start, t1,
        _margins(model_at(t1), end.x), solve,
        None if along is None else (lambda t: _margins(model_at(t), along(t))))
