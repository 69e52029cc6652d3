"""Stiction under the implicit midpoint rule: when in a step a sliding routing point of a
string tendon sticks again (docs/dynamics.md, "Friction in physical time"; docs/tendon.md,
"Stiction").

A point sliding out (in) carries the chord after it on its sliding bound
b_e(t, x) = T(t) e^{+W_out,e(x)} (T(t) e^{−W_in,e(x)}; rodsim/core/tendon_friction.py), the
tension falling (rising) with the tendon's slip. It sticks again where the bound turns
back — its rate db_e/dt along the motion reaches zero, the tendon's slip over the point
stops — and from then on the chord holds the extremum's tension until the point breaks
loose again at its static μ_s (rodsim/solvers/physical/breakaway.py). Each sliding point's
margin is its bound's relative rate, signed positive while it slides:

    r_e(t, x, ẋ) = −σ_e (d/dt b_e)/b_e,    σ_e = +1 sliding out, −1 in,

the rate by a central difference in time along the motion, b_e at (t ± δ, x ± δ ẋ)
(through the model of each time: the programmed tension, a moving support), δ =
``RATE_STEP`` × the part, ẋ the motion's (the positions' velocities, q̇ = ½ Σ_k ω_k B_k q;
on the part's interpolant its own x(t ± δ)).

A part from (t₀, x₀) to t₁ is solved with the history carried at t₀ (τ_old, each point's
stick/slip state). Inside it the rule τ_e = clip(τ_old_e, lo_e, hi_e) lets a sliding
chord follow its bound back toward τ_old_e past the extremum, instead of holding the
extremum's value: an error as large as the bound's move from the extremum to the part's end
(O(h²) for a smooth turn-back, O(h) at a kink of the program), and a breakaway from the held
value is then measured against the stored one. The points watched in a part are those
sliding at t₀ (their state ±1, the chord on that bound at x₀) whose margin is > 0 there;
where some margin is ≤ 0 at t₁, or at a quarter point of the part's interpolant (a turn and
back inside one part), the first to stick is located as a breakaway is
(rodsim/solvers/physical/part_events.py: Illinois on the part re-solved to the trial
time). The part is split there, friction's history is carried at τ with the points whose
margin is ≤ 0 there held: stuck (``hold``; their coefficient toward both sides μ_s, their
chord at the extremum's tension), and the rest of the step is a new part. A point sliding
at a part's start whose bound already moves away there (its margin below the difference's
round-off, −``RATE_NOISE``/δ: a turn at a step's end, the start of a release from a pull, or
a point whose rate jumps at a program's knot where another was located, its own difference
straddling the knot) is held at that time (``turned``), before the part is solved; one
whose margin is within round-off of 0 (a bound at rest) is neither watched nor held.

The rate of a piecewise-linear program jumps at a knot: the root is there, to δ. Without
stiction (μ_s = μ_k) a point's state is not history and re-sticks are not located (the run
is the kinetic one bitwise): the rule's error there is O(h²) for a smooth turn-back, the
midpoint rule's order.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rodsim.core.model import Model
from rodsim.core.tendon_friction import STUCK, bound_coefficients, slip_states
from rodsim.core.terms.tendon_string import TendonString
from rodsim.solvers.physical import part_events
from rodsim.solvers.physical.coordinates import PhysicalCoordinates, model_state
from rodsim.solvers.physical.fixed_step import Motion, StepOutcome
from rodsim.solvers.physical.step_events import hermite, quaternion_rate

__all__ = ["RATE_NOISE", "RATE_STEP", "Held", "sliding", "margins", "turned", "locate",
           "hold"]

#: The central difference's half step δ of a bound's rate, relative to the part: the root
#: at a knot of a piecewise-linear program is within δ of it (a tension error ≤ |Ṫ| δ).
RATE_STEP = 1e-8

#: A relative difference of two bounds that is round-off (the bounds' own, a few ulps, with
#: margin): a margin below −RATE_NOISE/δ at a part's start is a bound moving away, not
#: noise (``turned``).
RATE_NOISE = 1e-12

#: A point held where it stuck again: (the term's index in the model, the point's index
#: along the tendon, the way it slid until then: −1 in, +1 out).
Held = tuple[int, int, int]


def _terms(model: Model) -> list[tuple[int, TendonString]]:
    """The string tendons with stiction of ``model``, with their indices."""
    return [(i, term) for i, term in enumerate(model.terms)
            if isinstance(term, TendonString) and term.sticky]


def _bounds(model: Model, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lo, hi, the state each point had) of every point of every string tendon with
    stiction at the free coordinates ``x``, concatenated in the terms' order."""
    full = model.full(model_state(model, x))
    low, high, state = [], [], []
    for _, term in _terms(model):
        mu_in, mu_out = bound_coefficients(term.kinetic, term.static, term.state)
        theta = term.turning_angles(full)
        low.append(term.tension * np.exp(-np.cumsum(mu_in * theta)))
        high.append(term.tension * np.exp(np.cumsum(mu_out * theta)))
        state.append(term.state)
    return np.concatenate(low), np.concatenate(high), np.concatenate(state)


def sliding(model: Model, x: np.ndarray) -> np.ndarray | None:
    """σ_e of every point of every string tendon with stiction at a part's start ``x``:
    its state (−1 in, +1 out) where it slides — the chord on that bound, as
    ``slip_states`` reads it, with some wrap up to it —, 0 where it is stuck; None when no
    tendon has stiction."""
    if not _terms(model):
        return None
    full = model.full(model_state(model, x))
    out = []
    for _, term in _terms(model):
        mu_in, mu_out = bound_coefficients(term.kinetic, term.static, term.state)
        theta = term.turning_angles(full)
        read = slip_states(term.tension, mu_in, mu_out, theta, term.profile, term.state)
        wrapped = (np.cumsum(mu_in * theta) > 0.0) | (np.cumsum(mu_out * theta) > 0.0)
        out.append(np.where((read == term.state) & wrapped, term.state, STUCK))
    return np.concatenate(out)


def margins(model_at: Callable[[float], Model], t: float,
            path: Callable[[float], np.ndarray], delta: float, sides: np.ndarray
            ) -> np.ndarray:
    """r_e (module docstring) of every point with ``sides`` σ_e ≠ 0 at time ``t``, +inf
    of the others; ``path(ε)`` the free coordinates at t + ε along the motion, ``delta``
    the difference's half step δ [s]."""
    low, high, _ = _bounds(model_at(t + delta), path(delta))
    before_low, before_high, _ = _bounds(model_at(t - delta), path(-delta))
    after = np.where(sides > 0, high, low)
    before = np.where(sides > 0, before_high, before_low)
    scale = delta * (np.abs(after) + np.abs(before))
    rate = np.divide(after - before, scale, out=np.zeros_like(after), where=scale > 0.0)
    return np.where(sides != 0, -sides * rate, np.inf)


def _along(coordinates: PhysicalCoordinates, motion: Motion) -> Callable[[float], np.ndarray]:
    """ε ↦ x + ε ẋ of ``motion`` (ẋ: the positions' velocities, the quaternions' rates)."""
    rate = np.zeros_like(motion.x)
    rate[coordinates.positions] = motion.v
    rate[coordinates.quaternions] = quaternion_rate(coordinates, motion.x, motion.w)
    return lambda e: motion.x + e * rate


def _held(model: Model, stuck: np.ndarray, sides: np.ndarray) -> list[Held]:
    """The points where ``stuck`` is true, as ``Held``."""
    where = [(i, e) for i, term in _terms(model) for e in range(len(term.state))]
    return [(where[k][0], where[k][1], int(sides[k])) for k in np.flatnonzero(stuck)]


def _start(model_at: Callable[[float], Model], coordinates: PhysicalCoordinates,
           t0: float, start: Motion, t1: float
           ) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(σ_e of the sliding points, their margins at the part's start, δ), None without
    sliding points."""
    sides = sliding(model_at(t0), start.x)
    if sides is None or not np.any(sides):
        return None
    delta = RATE_STEP * (t1 - t0)
    return sides, margins(model_at, t0, _along(coordinates, start), delta, sides), delta


def turned(model_at: Callable[[float], Model], coordinates: PhysicalCoordinates,
           t0: float, start: Motion, t1: float) -> list[Held]:
    """The sliding points whose bound already moves away at the start of the part from
    (``t0``, ``start``) to ``t1`` (margin below −``RATE_NOISE``/δ: the turn at a part's
    end, or a located one whose rate jumps, as at a program's knot, and whose own
    difference there straddled the jump): they stuck at t0 (module docstring)."""
    begun = _start(model_at, coordinates, t0, start, t1)
    if begun is None:
        return []
    sides, first, delta = begun
    return _held(model_at(t0), (sides != 0) & (first < -RATE_NOISE / delta), sides)


def locate(model_at: Callable[[float], Model], coordinates: PhysicalCoordinates,
           t0: float, start: Motion, t1: float, end: Motion,
           solve: Callable[[float], StepOutcome]
           ) -> tuple[float, StepOutcome | None, list[Held]]:
    """When in the part from (``t0``, ``start``) to (``t1``, ``end``) the first sliding
    point sticks again (module docstring): (τ, the outcome of the part solved from t0 to
    τ by ``solve(τ)``, the points held there); (t1, None, []) when none does."""
    begun = _start(model_at, coordinates, t0, start, t1)
    if begun is None:
        return t1, None, []
    sides, first, delta = begun
    sides = np.where(first > 0.0, sides, STUCK)
    if not np.any(sides):
        return t1, None, []
    first = np.where(sides != 0, first, np.inf)

    def measure(t: float, motion: Motion) -> np.ndarray:
        return margins(model_at, t, _along(coordinates, motion), delta, sides)

    curve = hermite(coordinates, t0, start, t1, end)
    when, outcome = part_events.locate(
        lambda t, found: measure(t, found.motion), t0, first, t1, measure(t1, end), solve,
        lambda t: margins(model_at, t, lambda e: curve(t + e)[0], delta, sides))
    if outcome is None:
        return t1, None, []
    return when, outcome, _held(model_at(t0), measure(when, outcome.motion) <= 0.0, sides)


def hold(model: Model, held: list[Held]) -> Model:
    """``model`` with the points ``held`` stuck (their stick/slip state 0, the stored
    chord tensions kept): where they stuck again (module docstring)."""
    if not held:
        return model
    terms = list(model.terms)
    for index in sorted({i for i, _, _ in held}):
        term = terms[index]
        assert isinstance(term, TendonString) and term.sticky
        state = term.state.copy()
        state[[e for i, e, _ in held if i == index]] = STUCK
        terms[index] = term.anchored(np.concatenate([term.profile, state]))
    return model.with_terms(terms)
