"""Events under the implicit midpoint rule: the event functions of
rodsim/solvers/physical/events.py watched after every step, each root located on the step
re-solved to the trial time (docs/dynamics.md, "Events").

After a step from (t₀, x₀, u₀) to (t₁, x₁, u₁) the event functions are evaluated at its
end; a function whose sign changes in its direction (−1: from > 0 to ≤ 0; +1: from < 0 to
≥ 0; 0: either) has a root in the step. Its time is the root of τ ↦ g(τ, Φ_τ), Φ_τ the
state one midpoint step from (t₀, x₀, u₀) to τ reaches, found by the Illinois variant of
regula falsi in [t₀, t₁] to ``TIME_TOLERANCE`` × the step (or round-off); the time recorded
is the bracket's end past the crossing, as SUNDIALS reports it. Φ_τ is the scheme's own
state, O(h²) off the exact motion, so the located time is too (the scheme's order; measured
in tests/test_simulate_events_midpoint.py).

The first trial point is the root on the step's cubic Hermite interpolant — positions on
(r₀, v₀, r₁, v₁), quaternions on (q₀, q̇₀, q₁, q̇₁) with q̇ = ½ Σ_k ω_k B_k q (Eq. 13),
normalised —, which costs no Newton solve. The interpolant alone is not the answer: a step
that crosses a contact carries the stiff penalty force over its part past the onset, so its
end state, and the interpolant through it, is no longer the free flight's (on a rod falling
onto a plane at 5 ms steps it put the onset 5 µs late, 1.1e-4 relative, and later at 2.5 ms
steps); the shortened steps up to the root feel no contact force.

A terminal event ends the run at its time: the step is taken again from t₀ to the event
time (rodsim/solvers/physical/trajectory.py), so that the last state is the integrator's
own at the event, not an interpolated one.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rodsim.core.model import Model
from rodsim.solvers.physical.coordinates import PhysicalCoordinates, velocity_rows
from rodsim.solvers.physical.events import EventFunctions
from rodsim.solvers.physical.fixed_step import Motion

__all__ = ["StepEvents", "watched", "hermite", "quaternion_rate", "TIME_TOLERANCE",
           "MAX_ITERATIONS", "root"]

#: A root's bracket is narrowed to this fraction of the step (or to round-off).
TIME_TOLERANCE = 1e-10
#: Illinois iterations allowed per root (each halves the bracket at worst every third).
MAX_ITERATIONS = 200


def quaternion_rate(coordinates: PhysicalCoordinates, x: np.ndarray, w: np.ndarray) -> np.ndarray:
    """q̇ = ½ Σ_k ω_k B_k q at ``x`` (s, 4)."""
    return 0.5 * np.einsum("ska,sk->sa", velocity_rows(x[coordinates.quaternions]), w)


def hermite(coordinates: PhysicalCoordinates, t0: float, start: Motion, t1: float,
            end: Motion) -> Callable[[float], tuple[np.ndarray, np.ndarray]]:
    """The free coordinates x(t) and node velocities v(t) on [t0, t1] of a step from
    ``start`` to ``end``: the cubic Hermite interpolant — positions on (r₀, v₀, r₁, v₁),
    quaternions on (q₀, q̇₀, q₁, q̇₁) with q̇ = ½ Σ_k ω_k B_k q (Eq. 13), normalised — and
    the positions' derivative (module docstring)."""
    c, h = coordinates, t1 - t0
    r0, r1 = start.x[c.positions], end.x[c.positions]
    q0, q1 = start.x[c.quaternions], end.x[c.quaternions]
    dq0, dq1 = quaternion_rate(c, start.x, start.w), quaternion_rate(c, end.x, end.w)

    def x(t: float) -> tuple[np.ndarray, np.ndarray]:
        s = (t - t0) / h
        h00, h10 = (1 + 2 * s) * (1 - s) ** 2, s * (1 - s) ** 2
        h01, h11 = s * s * (3 - 2 * s), s * s * (s - 1)
        out = start.x.copy()
        out[c.positions] = h00 * r0 + h10 * h * start.v + h01 * r1 + h11 * h * end.v
        q = h00 * q0 + h10 * h * dq0 + h01 * q1 + h11 * h * dq1
        out[c.quaternions] = q / np.linalg.norm(q, axis=1)[:, None]
        # d/dt of the position's Hermite basis: (6s² − 6s, 3s² − 4s + 1, −, 3s² − 2s)/h
        v = ((6 * s * s - 6 * s) * (r0 - r1) / h + (3 * s * s - 4 * s + 1) * start.v
             + (3 * s * s - 2 * s) * end.v)
        return out, v
    return x


def _crossed(before: float, after: float, direction: int) -> bool:
    """Whether g went from ``before`` to ``after`` across zero in ``direction``."""
    down = before > 0.0 >= after
    up = before < 0.0 <= after
    return down if direction < 0 else up if direction > 0 else down or up


class StepEvents:
    """The event functions ``events`` watched over the midpoint rule's steps (module
    docstring); ``model_at(t)`` the model of time t."""

    def __init__(self, events: EventFunctions, model_at: Callable[[float], Model],
                 coordinates: PhysicalCoordinates) -> None:
        self.events, self.model_at, self.coordinates = events, model_at, coordinates
        self._last: np.ndarray | None = None

    def values(self, t: float, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The functions' values at (t, x) with node velocities ``v``."""
        return self.events.values(t, self.model_at(t), x, v)

    def start(self, t: float, motion: Motion) -> None:
        """The functions' values at the run's start."""
        self._last = self.values(t, motion.x, motion.v)

    def interpolant(self, t0: float, start: Motion, t1: float, end: Motion
                    ) -> Callable[[float], tuple[np.ndarray, np.ndarray]]:
        """The free coordinates x(t) and node velocities v(t) on [t0, t1]: the cubic
        Hermite interpolant and its derivative (``hermite``)."""
        return hermite(self.coordinates, t0, start, t1, end)

    def step(self, t0: float, start: Motion, t1: float, end: Motion,
             restep: Callable[[float], Motion]) -> list[tuple[float, int]]:
        """The roots in the step from ``t0`` to ``t1``: (time, function index), in time
        order; ``restep(t)`` the state one midpoint step from ``start`` to t reaches. The
        end's values are kept for the next step."""
        assert self._last is not None
        before, after = self._last, self.values(t1, end.x, end.v)
        self._last = after
        crossed = [i for i in range(len(self.events))
                   if _crossed(before[i], after[i], self.events.directions[i])]
        if not crossed:
            return []
        x = self.interpolant(t0, start, t1, end)
        reached: dict[float, Motion] = {t1: end}

        def state(t: float) -> Motion:
            if t not in reached:
                reached[t] = restep(t)
            return reached[t]

        found = []
        for i in crossed:
            def interpolated(t: float, i: int = i) -> float:
                return float(self.values(t, *x(t))[i])

            def stepped(t: float, i: int = i) -> float:
                motion = state(t)
                return float(self.values(t, motion.x, motion.v)[i])

            guess = root(interpolated, t0, before[i], t1, after[i])
            when = root(stepped, t0, before[i], t1, after[i], guess)
            found.append((float(when), i))
        return sorted(found)


def watched(events: EventFunctions | None, model_at: Callable[[float], Model],
            coordinates: PhysicalCoordinates, t: float, motion: Motion
            ) -> tuple[StepEvents | None, list[str], list[bool]]:
    """The watch over a run's steps started at (t, motion) (None without events), and the
    events' names and which of them are terminal."""
    if events is None:
        return None, [], []
    watch = None
    if len(events):
        watch = StepEvents(events, model_at, coordinates)
        watch.start(t, motion)
    return watch, events.names, events.terminal


def root(g: Callable[[float], float], a: float, ga: float, b: float, gb: float,
          guess: float | None = None) -> float:
    """The root of ``g`` in [a, b] (g(a) = ``ga`` and g(b) = ``gb`` across zero, ``ga``
    ≠ 0) to ``TIME_TOLERANCE`` × (b − a) or round-off: Illinois, its first point ``guess``
    if given; the bracket's end past the crossing."""
    tolerance = TIME_TOLERANCE * (b - a) + 4.0 * np.finfo(float).eps * max(abs(a), abs(b))
    side = 0
    for _ in range(MAX_ITERATIONS):
        if b - a <= tolerance or gb == 0.0:
            break
        t = guess if guess is not None else (b - gb * (b - a) / (gb - ga) if gb != ga
                                             else 0.5 * (a + b))
        guess = None
        t = min(max(t, a + 0.25 * tolerance), b - 0.25 * tolerance)
        value = g(t)
        if (value > 0.0) == (ga > 0.0) and value != 0.0:  # the crossing is in [t, b]
            a, ga = t, value
            if side == -1:
                gb *= 0.5
            side = -1
        else:  # in [a, t]
            b, gb = t, value
            if side == 1:
                ga *= 0.5
            side = 1
    return b
