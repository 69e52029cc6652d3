"""The implicit midpoint rule under error control: a local error estimate, a step-size
controller and dense output (docs/dynamics.md, "The midpoint rule under error control").

**The estimate** (``estimate="embedded"``, the default). A step of h from (r₀, u₀) solves
for the midpoint velocities u_m (rodsim/solvers/physical/midpoint.py): its effective
generalised force is g_m = ((2/h) M_r (v_m − v₀), (2/h) I (ω_m − ω₀)). An explicit half
kick from the start would use g₀ = (F_r − (D_t u₀)_r, τ − ω₀ × I ω₀ − (D_t u₀)_ω) at
(x₀, t₀) instead (Störmer–Verlet's first half: ``MidpointStep.start_force``). The two
steps' ends differ by Δr = (h²/2) M_r⁻¹ (g₀ − g_m) in position and Δθ = h (h/2) I⁻¹
(g₀ − g_m)_ω in angle; on a smooth motion x'' = a(x, t) that difference is h³ ȧ/4, three
times the midpoint rule's own local error h³ ȧ/12, so the estimate is a third of it. The
masses are replaced by the step's own factored Newton matrix N = (2/h²) M_r − ∂f̄/∂r₁, … (a
back-solve, no new factorisation): z = N⁻¹ (g₀ − g_m), e = (z_r, h z_ω)/3. On a mode the
step resolves (ωh ≪ 1) N ≈ the masses and e is the estimate above; on a mode it steps over
(stretch, shear and twist at ωh ≫ 1, where the midpoint rule reverses the velocity every
step) N ≈ −K and e is filtered by (2/h²) M/K (Shampine's filter, as RADAU5's), so those
modes, which the run does not resolve and which their displacements barely show, do not
set the step. Its cost a step: one force evaluation (no Jacobian) and one back-solve.
Estimated on the configuration only (positions [m] and angles [rad]): the velocities'
local error is not estimated.

``estimate="doubling"``: one step of h (y₁) against two of h/2 (y₂), e = (y₂ − y₁)/3
(Richardson for a second-order rule) on the positions and the quaternions (2 δq is a turn
in rad; ``RATES``: the velocities and body rates too, atol × L ω₁ and atol × ω₁ as IDA's);
the run goes on from y₂. Three Newton solves an attempt: measured dearer than the embedded
estimate at equal tip error (docs/dynamics.md). Local extrapolation y₂ + (y₂ − y₁)/3 was
tried and dropped: on a mode the step does not resolve the one step reverses it and the two
half steps do not, so the extrapolation multiplies it by 5/3 a step (the released steel rod
at rtol 1e-3 ended with an energy error 30 times the vibration's).

**The norm**: err = RMS_i (e_i / (atol_i + rtol · max(|y₀,i|, |y₁,i|))) with ``atol`` × L
on positions (L the longest rod) and ``atol`` on angles (rad), as IDA's
(rodsim/solvers/physical/ida_run.py); the angles' relative part is rtol (a unit
quaternion's size). The step is accepted when err ≤ 1.

**The controller** (rodsim/solvers/physical/step_controller.py, ``ErrorControl.controller``):
the elementary one (Hairer, Nørsett & Wanner I, II.4), h_new = h · min(``FAC_MAX``,
max(``FAC_MIN``, ``SAFETY`` · err^(−1/3))), or the PI one (Gustafsson); after a rejection
the factor is at most 1. An accepted step whose proposed growth lies in [1, ``KEEP``] keeps
h, so that its factored Newton matrix (``KeptMatrix``) serves the next step too (a change
of h refactors); under the PI controller a proposed shrinking down to ``KEEP_PI`` keeps h
too (its small factors below 1 would otherwise all be taken and those above 1 not, and
the step would ratchet down on the estimate's step-to-step noise). A step whose Newton
fails is a rejection with the factor ``FAC_MIN``. Each accepted step's end and length and
each rejected attempt's start, length and err are kept (``ControlledRecord``: the
trajectory archive's ``step_end``, ``step_size``, ``rejected_*``). Newton solves each step
to the fixed steps' 1e-12 (``ErrorControl.newton`` = κ > 0 stops it at a change of
κ · min(rtol, atol) instead: measured and not taken, docs/dynamics.md: κ = 0.01 saved a
third of the CPU on tdcr-two-segment but let an undamped rod's energy drift). Steps end on
the programs' table times (where a value's slope changes or it jumps) and on t_end. The first step:
``first`` (the caller's: 1/100 of the lowest natural period at the start, or the longest
step allowed if shorter) — no clock, so the same scene gives the same steps bit for bit.

**Outputs** at the requested times come from the accepted step's cubic Hermite interpolant
(rodsim/solvers/physical/dense_output.py; rodsim/solvers/physical/step_events.py: positions
on (r, v), quaternions on (q, q̇), normalised), body rates linear: they force no step. The
energies at an output are those of the interpolated state; the dissipated energy and the
programs' work are interpolated linearly across the step, so an output's energy balance
includes the interpolant's error (local: it does not accumulate). Events are watched on
every accepted step as for fixed steps (rodsim/solvers/physical/step_events.py), each root
on one midpoint step from the accepted step's start. Friction (a path-dependent history)
is not offered under error control: a rejected step would have to undo its history.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from rodsim.core.model import Model
from rodsim.solvers.physical.dense_output import record_outputs
from rodsim.solvers.physical.events import EventFunctions
from rodsim.solvers.physical.fixed_step import KeptMatrix, Motion, StepFailure
from rodsim.solvers.physical.midpoint import MidpointStep
from rodsim.solvers.physical.step_controller import StepController
from rodsim.solvers.physical.step_events import watched
from rodsim.solvers.physical.trajectory import MAX_HALVINGS, advance, restep
from rodsim.solvers.physical.trajectory_record import Record, potential

__all__ = ["ErrorControl", "ControlledRecord", "integrate_controlled", "KEEP", "RATES",
           "MAX_STEPS"]

#: An accepted step whose proposed factor lies in [1, KEEP] keeps its length (and so its
#: two factored Newton matrices).
KEEP = 1.5
#: ... and, under the PI controller, in [KEEP_PI, 1] too (see the module docstring).
KEEP_PI = 0.8
#: Whether the velocities and body rates enter the error norm (module docstring).
RATES = False
#: Step attempts allowed before the run stops.
MAX_STEPS = 200_000


@dataclass(frozen=True)
class ErrorControl:
    """The error control's settings: ``rtol``, ``atol`` (module docstring), the longest
    rod's length [m], ω₁ [rad/s], the first step [s], the longest step [s] (0: none) and
    the estimate."""

    rtol: float
    atol: float
    length: float
    omega: float
    first: float
    longest: float = 0.0
    #: "embedded" or "doubling" (module docstring).
    estimate: str = "embedded"
    #: The step-size controller: "pi" or "elementary"
    #: (rodsim/solvers/physical/step_controller.py).
    controller: str = "pi"
    #: The Newton tolerance over min(rtol, atol) (0: the fixed steps' NEWTON_TOLERANCE,
    #: rodsim/solvers/physical/fixed_step.py).
    newton: float = 0.0


@dataclass
class ControlledRecord(Record):
    """A run's record (rodsim/solvers/physical/trajectory.py) with the error control's
    steps: each accepted step's end time and length [s], and each rejected attempt's start
    time, length [s] and err (inf where its Newton failed), in the order taken."""

    step_ends: list[float] = field(default_factory=list)
    step_sizes: list[float] = field(default_factory=list)
    rejections: list[tuple[float, float, float]] = field(default_factory=list)


def _scaled_error(stepper: MidpointStep, one: Motion, two: Motion,
                  options: ErrorControl) -> float:
    """err: the weighted RMS of (y₂ − y₁)/3 (module docstring)."""
    c = stepper.coordinates
    o = options
    parts = [((two.x[c.positions] - one.x[c.positions]) / 3.0,
              o.atol * o.length + o.rtol * np.maximum(np.abs(one.x[c.positions]),
                                                      np.abs(two.x[c.positions]))),
             (2.0 * (two.x[c.quaternions] - one.x[c.quaternions]).ravel() / 3.0,
              o.atol + o.rtol * np.maximum(np.abs(one.x[c.quaternions]),
                                           np.abs(two.x[c.quaternions])).ravel())]
    if RATES:
        parts += [((two.v - one.v) / 3.0, o.atol * o.length * o.omega
                   + o.rtol * np.maximum(np.abs(one.v), np.abs(two.v))),
                  ((two.w - one.w).ravel() / 3.0, o.atol * o.omega
                   + o.rtol * np.maximum(np.abs(one.w), np.abs(two.w)).ravel())]
    ratios = np.concatenate([e / s for e, s in parts])
    value = float(np.sqrt(np.mean(ratios * ratios)))
    return value if math.isfinite(value) else math.inf


@dataclass
class _Attempt:
    """An accepted (or rejected) step: the motion reached, the programs' work, the
    dissipated energy, its midpoint steps, Newton iterations and err."""

    motion: Motion
    work: float
    dissipated: float
    steps: int
    iterations: int
    error: float


class _Doubling:
    """One step of h against two of h/2 (module docstring), each length with its own kept
    Newton matrix."""

    def __init__(self, model_at: Callable[[float], Model], stepper: MidpointStep,
                 options: ErrorControl) -> None:
        self.model_at, self.stepper, self.options = model_at, stepper, options
        self.whole, self.halves = KeptMatrix(), KeptMatrix()

    def attempt(self, motion: Motion, t0: float, h: float) -> _Attempt:
        """The step from ``motion`` at ``t0`` of length ``h``; StepFailure from Newton."""
        s = self.stepper
        t1, middle = t0 + h, t0 + 0.5 * h
        s.kept = self.whole
        one = advance(self.model_at, s, motion, t0, t1, 0)
        s.kept = self.halves
        first = advance(self.model_at, s, motion, t0, middle, 0)
        second = advance(self.model_at, s, first[0], middle, t1, 0)
        error = _scaled_error(s, one[0], second[0], self.options)
        return _Attempt(second[0], first[1] + second[1], first[2] + second[2], 3,
                        one[3][1] + first[3][1] + second[3][1], error)


class _Embedded:
    """One midpoint step and its embedded estimate (module docstring): the explicit half
    kick's velocities against the step's, filtered by the step's own Newton matrix."""

    def __init__(self, model_at: Callable[[float], Model], stepper: MidpointStep,
                 options: ErrorControl) -> None:
        self.model_at, self.stepper, self.options = model_at, stepper, options
        self.kept = KeptMatrix()

    def attempt(self, motion: Motion, t0: float, h: float) -> _Attempt:
        """The step from ``motion`` at ``t0`` of length ``h``; StepFailure from Newton."""
        s, o = self.stepper, self.options
        c = s.coordinates
        s.kept = self.kept
        reached, work, dissipated, taken = advance(self.model_at, s, motion, t0, t0 + h, 0)
        assert reached.middle is not None and self.kept.solve is not None
        vm, wm = reached.middle
        p = len(c.positions)
        stepped = np.concatenate([(2.0 / h) * (c.mass @ (vm - motion.v)),
                                  ((2.0 / h) * c.inertia * (wm - motion.w)).ravel()])
        z = self.kept.solve(s.start_force(self.model_at(t0), motion) - stepped)
        r0, r1 = motion.x[c.positions], reached.x[c.positions]
        ratios = np.concatenate([
            z[:p] / 3.0 / (o.atol * o.length + o.rtol * np.maximum(np.abs(r0), np.abs(r1))),
            h * z[p:] / 3.0 / (o.atol + o.rtol)])
        error = float(np.sqrt(np.mean(ratios * ratios)))
        return _Attempt(reached, work, dissipated, 1, taken[1],
                        error if math.isfinite(error) else math.inf)


def integrate_controlled(model_at: Callable[[float], Model], stepper: MidpointStep,
                         start: Motion, output_times: Sequence[float], options: ErrorControl,
                         breaks: Sequence[float] = (),
                         progress: Callable[[float], None] | None = None,
                         record: ControlledRecord | None = None,
                         events: EventFunctions | None = None) -> ControlledRecord:
    """Integrate from ``start`` at ``output_times[0]`` through the last output time under
    error control (module docstring); ``breaks``: times no step crosses (the programs'
    table times). The record counts every midpoint step solved in ``steps`` (three an
    attempt), the rejected attempts in ``halvings``' place: ``rejected``; each accepted
    step's end and length and each rejected attempt's start, length and err go to the
    ``ControlledRecord``'s lists. A run that cannot
    go on (err > 1 at the smallest step, ``MAX_STEPS`` attempts) ends with ``success``
    False, what it computed kept, and advice; events as in trajectory.integrate."""
    record = ControlledRecord() if record is None else record
    t = float(output_times[0])
    t_end = float(output_times[-1])
    motion = start
    coordinates = stepper.coordinates
    watch, names, terminal = watched(events, model_at, coordinates, t, motion)
    record.add(t, motion, coordinates.kinetic_energy(motion.v, motion.w),
               potential(model_at(t), motion.x), 0.0, 0.0)
    pending = [float(time) for time in output_times[1:]]
    stops = sorted({float(b) for b in breaks if t < b < t_end} | {t_end})
    doubling = (_Doubling(model_at, stepper, options) if options.estimate == "doubling"
                else _Embedded(model_at, stepper, options))
    searching = KeptMatrix()  # the events' steps' Newton matrix
    h = options.first if options.longest <= 0.0 else min(options.first, options.longest)
    controller = StepController(options.controller)
    if options.newton > 0.0:
        stepper.tolerance = options.newton * min(options.rtol, options.atol)
    smallest = 1e-12 * max(t_end - t, abs(t_end))
    dissipated = work = 0.0
    attempts = 0
    rejected = False  # whether the last attempt was rejected: no growth right after
    known: tuple[float, float] | None = None  # (T, V) at the step's start, where computed
    while t < t_end:
        stop = next(b for b in stops if b > t)
        taken = min(h, stop - t)
        if stop - (t + taken) < 1e-9 * taken:  # no sliver before a stop
            taken = stop - t
        attempts += 1
        if attempts > MAX_STEPS or taken < smallest:
            record.success = False
            record.message = (f"step from t = {t:.6g} s failed: the error control needs "
                              f"steps below {taken:.2g} s ({attempts} attempts); try a "
                              "looser rtol/atol or fixed steps (the run's data up to there "
                              "is kept)")
            return record
        try:
            result = doubling.attempt(motion, t, taken)
        except StepFailure:
            record.rejected += 1
            record.rejections.append((t, taken, math.inf))
            h, rejected = taken * controller.rejected(math.inf), True
            continue
        record.steps += result.steps
        record.iterations += result.iterations
        if result.error > 1.0:
            record.rejected += 1
            record.rejections.append((t, taken, result.error))
            h, rejected = taken * controller.rejected(result.error), True
            continue
        t1 = stop if taken == stop - t else t + taken
        before, end = motion, result.motion
        found: list[tuple[float, int]] = []
        if watch is not None:
            searched = [0, 0, 0]
            stepper.kept = searching
            found = watch.step(t, before, t1, end, restep(model_at, stepper, before, t,
                                                           searched))
            record.steps += searched[0]
            record.iterations += searched[1]
        ended = next((when for when, i in found if terminal[i]), None)
        if ended is not None:
            found = [(when, i) for when, i in found if when <= ended]
            if ended < t1:
                again = advance(model_at, stepper, before, t, ended, MAX_HALVINGS)
                end, t1 = again[0], ended
                result.work, result.dissipated = again[1], again[2]
                record.steps += again[3][0]
                record.iterations += again[3][1]
        record.events.extend((when, names[i]) for when, i in found)
        energy = (dissipated, dissipated + result.dissipated, work, work + result.work)
        due = [time for time in pending if time <= t1]
        pending = pending[len(due):]
        if ended is not None:
            due = [time for time in due if time < ended] + [ended]
        known = record_outputs(record, stepper.coordinates, model_at, (t, before, t1, end),
                               due, energy, known)
        dissipated, work = energy[1], energy[3]
        record.largest_step = max(record.largest_step, t1 - t)
        record.accepted += 1
        record.step_ends.append(t1)
        record.step_sizes.append(t1 - t)
        t, motion = t1, end
        if progress is not None:
            progress(t)
        if ended is not None:
            which = ", ".join(names[i] for when, i in found if when == ended and terminal[i])
            record.message = f"stopped by the event ({which}) at t = {ended:.9g} s"
            return record
        grow = controller.accepted(result.error)
        grow, rejected = min(1.0, grow) if rejected else grow, False
        if taken < h:  # cut short by a stop: only shortened, where its error says so
            h = min(h, taken * grow)
        elif not (KEEP_PI if controller.kind == "pi" else 1.0) <= grow <= KEEP:
            h = taken * grow
        if options.longest > 0.0:
            h = min(h, options.longest)
    return record
