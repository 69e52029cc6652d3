"""A run in physical time: implicit midpoint steps to ``t_end``, the states at the output
times and the energy balance (docs/dynamics.md, "Energy").

The energy at each output time: kinetic T (rodsim/solvers/physical/coordinates.py),
potential V(x, t) — the model's energy, elastic, penalty, gravity and the loads' potentials
at the values they have at t —, dissipated D (the damping's ∫ ẋᵀ D ẋ dt, summed step by
step exactly as the step applies it) and the work W that programs do by changing the
values in time. A step from t₀ to t₁ uses the model at its midpoint time t_m; V's change
splits exactly into the part the motion does at t_m's values, V(x₁, t_m) − V(x₀, t_m), and
the program's work [V(x₁, t₁) − V(x₁, t_m)] + [V(x₀, t_m) − V(x₀, t₀)] (for a moving
support, its elastic reaction's work), to which a step adds a moving support's work
through the damping (``StepOutcome.support_work``,
rodsim/solvers/physical/moving_supports.py). The balance

    error = T + V + D − W − (T₀ + V₀)

is then the integrator's own error (the midpoint rule's) alone, reported per output time;
a scene with a non-conservative term (the paper's lumen coupling, friction) has no V, and
the potential, the work and the balance are NaN.

Where the output spacing is a whole number of steps (the default: one output a step), and
always with friction (whose history is read at the outputs, rodsim/app/friction_trace.py), the
steps are of equal length between consecutive output times, each at most the step asked
for, so that the outputs are states the integrator reached (not interpolated). Otherwise
the steps are of equal length from the start to the end, each at most the step asked for,
and an output between step ends is read off the step's cubic Hermite interpolant
(rodsim/solvers/physical/dense_output.py): outputs force no step (before, 20 outputs a
period at 25 steps a period took 40 steps a period). ``step_plan`` lays the steps out.

A step whose Newton iteration fails (a start too far from the solution for a step that long:
measured on a stiff steel wire released from a large deflection at 50 steps a period) is
taken as two half steps instead, up to ``MAX_HALVINGS`` times; the run counts them.

Public besides the loop (the error-controlled loop, rodsim/solvers/physical/error_control.py,
steps with them too): ``advance`` (one step, halved where its Newton fails, its work and
dissipation) and ``restep`` (the state one step from a start reaches at any time, for an
event's root). What a run records and V(x): rodsim/solvers/physical/trajectory_record.py.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from typing import Protocol

import numpy as np

from rodsim.core.model import Model
from rodsim.solvers.physical import restick
from rodsim.solvers.physical.breakaway import locate, margins, sticky
from rodsim.solvers.physical.coordinates import model_state
from rodsim.solvers.physical.dense_output import record_outputs
from rodsim.solvers.physical.events import EventFunctions
from rodsim.solvers.physical.fixed_step import FixedStep, Motion, StepFailure, StepOutcome
from rodsim.solvers.physical.step_events import hermite, watched
from rodsim.solvers.physical.trajectory_record import Record, potential


class AfterStep(Protocol):
    """What a run is told at the end of every step: ``after_step(t, x, held)``, x the
    model's free coordinates (offsets from the rest state); a step in which a point of a
    string tendon breaks loose (rodsim/solvers/physical/breakaway.py) or sticks again
    (rodsim/solvers/physical/restick.py) is split there, and told at the split, ``held``
    the points that stuck again there (``restick.Held``; none at other ends)."""

    def __call__(self, t: float, x: np.ndarray, held: Sequence[restick.Held] = ()) -> None:
        ...

__all__ = ["integrate", "step_plan", "advance", "restep", "MAX_HALVINGS"]

#: How many times a step whose Newton fails may be halved before the run stops (down to
#: 1/256 of the step). A user's three-segment nitinol TDCR (N = 61) pulled by a 3 N ramp
#: over 10 ms needs more than 4 halvings at the default step (the tip segment's small
#: rotary inertia makes the rotation's equations nearly algebraic there); a run whose
#: steps need fewer is unchanged, and a hopeless step fails after 9 Newton solves.
MAX_HALVINGS = 8
#: Most repeats of one step for points of a string tendon that broke loose (stiction).
MAX_BREAKAWAYS = 1000


def _solve(model_at: Callable[[float], Model], stepper: FixedStep, motion: Motion,
           t0: float, t1: float) -> tuple[Model, StepOutcome]:
    """One midpoint step from ``t0`` to ``t1`` with the model of its midpoint time
    (re-registered at the start where a tendon registers): (that model, the outcome);
    StepFailure when its Newton fails."""
    t_middle = 0.5 * (t0 + t1)
    middle = model_at(t_middle)
    if middle.has_registration:
        registered = middle.reregistered(model_state(middle, motion.x))
        middle = middle if registered is None else registered
    return middle, stepper.step(middle, motion, t1 - t0, t_middle)


def _part(model_at: Callable[[float], Model], stepper: FixedStep, motion: Motion,
          t0: float, t1: float, watch: bool
          ) -> tuple[float, Model, StepOutcome | None, tuple[int, int], list[restick.Held]]:
    """The first part of the step from ``t0`` to ``t1`` (all of it unless, with stiction,
    a routing point breaks loose, rodsim/solvers/physical/breakaway.py, or sticks again,
    rodsim/solvers/physical/restick.py, in it): (its end τ, the model that solved it, the
    outcome, (steps, Newton iterations) spent, the points that stuck again at τ); τ =
    ``t0`` and no outcome when a point is already on its bound at t0, or a sliding one's
    bound moves away there (its history is to be carried there first)."""
    start = margins(model_at(t0), motion.x) if watch else None
    if start is not None and np.any(start <= 0.0):
        return t0, model_at(t0), None, (0, 0), []
    held = restick.turned(model_at, stepper.coordinates, t0, motion, t1) if watch else []
    if held:
        return t0, model_at(t0), None, (0, 0), held
    middle, outcome = _solve(model_at, stepper, motion, t0, t1)
    if start is None:
        return t1, middle, outcome, (1, outcome.iterations), []
    spent = [1, outcome.iterations]
    models: dict[float, Model] = {}

    def solve(t: float) -> StepOutcome:
        models[t], found = _solve(model_at, stepper, motion, t0, t)
        spent[0] += 1
        spent[1] += found.iterations
        return found

    curve = hermite(stepper.coordinates, t0, motion, t1, outcome.motion)
    when, first = locate(model_at, t0, start, t1, outcome.motion, solve,
                         lambda t: curve(t)[0])
    if first is None:
        when, solved, first = t1, middle, outcome
    else:
        solved = models[when]
    again, stuck, held = restick.locate(model_at, stepper.coordinates, t0, motion, when,
                                        first.motion, solve)
    if stuck is not None:
        return again, models[again], stuck, (spent[0], spent[1]), held
    return when, solved, first, (spent[0], spent[1]), []


def advance(model_at: Callable[[float], Model], stepper: FixedStep, motion: Motion,
            t0: float, t1: float, halvings: int, after_step: AfterStep | None = None
            ) -> tuple[Motion, float, float, tuple[int, int, int]]:
    """One step from ``t0`` to ``t1``, or, if its Newton fails, two half steps (each halved
    again, ``halvings`` times at most): (the motion reached, the programs' work, the
    dissipated energy, (steps, Newton iterations, halvings)). ``after_step(t, x)`` is told
    the end of every step taken (x the model's free coordinates). With stiction (and
    ``after_step``, which carries friction's history) the step is split where a routing
    point breaks loose, the rest taken with it freed (rodsim/solvers/physical/breakaway.py),
    as often as points break loose in it."""
    work = dissipated = 0.0
    counts = [0, 0, 0]
    watch = after_step is not None and sticky(model_at(t0))
    for _ in range(MAX_BREAKAWAYS):
        try:
            when, middle, outcome, spent, held = _part(model_at, stepper, motion, t0, t1,
                                                       watch)
        except StepFailure:
            if halvings == 0:
                raise
            half = 0.5 * (t0 + t1)
            first = advance(model_at, stepper, motion, t0, half, halvings - 1, after_step)
            second = advance(model_at, stepper, first[0], half, t1, halvings - 1,
                             after_step)
            return (second[0], work + first[1] + second[1],
                    dissipated + first[2] + second[2],
                    (counts[0] + first[3][0] + second[3][0],
                     counts[1] + first[3][1] + second[3][1],
                     counts[2] + first[3][2] + second[3][2] + 1))
        counts[0] += spent[0]
        counts[1] += spent[1]
        if outcome is not None:
            work += outcome.support_work  # a moving support's, through the damping
            start_model, end_model = model_at(t0), model_at(when)
            if start_model is not middle or end_model is not middle:
                work += (potential(end_model, outcome.motion.x)
                         - potential(middle, outcome.motion.x)
                         + potential(middle, motion.x) - potential(start_model, motion.x))
            dissipated += outcome.dissipated
            motion = outcome.motion
        if after_step is not None:
            after_step(when, model_state(middle, motion.x), held)
        if when >= t1:
            return motion, work, dissipated, (counts[0], counts[1], counts[2])
        t0 = when
    raise StepFailure(f"routing points broke loose more than {MAX_BREAKAWAYS} times in one "
                      "step")


def restep(model_at: Callable[[float], Model], stepper: FixedStep, start: Motion,
           t0: float, counts: list[int], after_step: AfterStep | None = None,
           restore: Callable[[], None] | None = None) -> Callable[[float], Motion]:
    """The state one step from ``start`` at ``t0`` to t reaches (halved as a step is), for
    an event's root; its steps, Newton iterations and halvings added to ``counts``. With
    ``restore`` (what puts friction's history back as it was at ``t0``) each trial step is
    taken from that history and carries it (``after_step``), a routing point that breaks
    loose in it located as in any step; without, the history is left alone."""
    def trial(t: float) -> Motion:
        if t <= t0:
            return start
        if restore is not None:
            restore()
        motion, _, _, taken = advance(model_at, stepper, start, t0, t, MAX_HALVINGS,
                                      after_step if restore is not None else None)
        for k in range(3):
            counts[k] += taken[k]
        return motion
    return trial


def integrate(model_at: Callable[[float], Model], stepper: FixedStep, start: Motion,
              output_times: Sequence[float], step: float,
              progress: Callable[[float], None] | None = None,
              record: Record | None = None, after_step: AfterStep | None = None,
              events: EventFunctions | None = None,
              history: Callable[[], Callable[[], None]] | None = None,
              between: bool = False) -> Record:
    """Integrate from ``start`` at ``output_times[0]`` through every output time with steps
    of at most ``step`` [s], laid out by ``step_plan`` (``between``: outputs between step
    ends, from the step's interpolant); ``model_at(t)`` is the model with the values at
    time t (the same object while nothing changes). A step that fails ends the run: the
    record holds what was computed, ``success`` False and a message with the time and
    advice. ``record``: an empty record to fill (the caller keeps what it holds if the run
    is interrupted).
    ``after_step(t, x)``: told the end of every step (friction's history,
    ``rodsim.app.programs.Programs.carry_history``). ``events``: watched after every step
    (rodsim/solvers/physical/step_events.py): each root's time and name go to
    ``record.events`` and a terminal one ends the run there, the step taken again to its
    time, with an output at it. ``history()``: what restores friction's history as it is
    now (``rodsim.app.friction_trace.FrictionTrace.mark``); with it and ``events``, the
    trial steps that locate a root and a terminal event's last step start from the
    history at the step's start (and locate the routing points that break loose in them),
    the history at the step's end restored after the search."""
    record = Record() if record is None else record
    t = float(output_times[0])
    motion = start
    model = model_at(t)
    coordinates = stepper.coordinates
    watch, names, terminal = watched(events, model_at, coordinates, t, motion)
    dissipated = work = 0.0
    record.add(t, motion, coordinates.kinetic_energy(motion.v, motion.w),
               potential(model, motion.x), 0.0, 0.0)
    stop: float | None = None
    known: tuple[float, float] | None = None  # (T, V) at the step's start, where computed
    for t0, t1, due in step_plan(output_times, step, between):
        before = motion
        saved = history() if history is not None and watch is not None else None
        try:
            motion, gained, lost, taken = advance(model_at, stepper, motion, t0, t1,
                                                  MAX_HALVINGS, after_step)
            found, searched = [], [0, 0, 0]
            if watch is not None:
                reached = (history() if history is not None and saved is not None
                           else None)
                found = watch.step(t0, before, t1, motion,
                                   restep(model_at, stepper, before, t0, searched,
                                          after_step, saved))
                if reached is not None:
                    reached()
            stop = next((when for when, i in found if terminal[i]), None)
            if stop is not None:
                found = [(when, i) for when, i in found if when <= stop]
                if stop < t1:  # the step again, to the terminal event's time exactly
                    if saved is not None:
                        saved()
                    motion, gained, lost, again = advance(
                        model_at, stepper, before, t0, stop, MAX_HALVINGS, after_step)
                    searched = [a + b for a, b in zip(searched, again, strict=True)]
            taken = (taken[0] + searched[0], taken[1] + searched[1],
                     taken[2] + searched[2])
        except StepFailure as exc:
            record.success = False
            record.message = (f"step from t = {t0:.6g} s failed: {exc}; try a smaller "
                              "step (the run's data up to there is kept)")
            return record
        record.events.extend((when, names[i]) for when, i in found)
        energy = (dissipated, dissipated + lost, work, work + gained)
        dissipated, work = energy[1], energy[3]
        record.steps += taken[0]
        record.iterations += taken[1]
        record.halvings += taken[2]
        record.largest_step = max(record.largest_step, t1 - t0)
        if stop is not None:
            due = [time for time in due if time < stop] + [stop]
            record_outputs(record, coordinates, model_at, (t0, before, stop, motion), due,
                           energy)
            ended = ", ".join(names[i] for when, i in found if when == stop and terminal[i])
            record.message = f"stopped by the event ({ended}) at t = {stop:.9g} s"
            return record
        if progress is not None:
            progress(t1)
        known = record_outputs(record, coordinates, model_at, (t0, before, t1, motion), due,
                               energy, known)
    return record


def step_plan(output_times: Sequence[float], step: float, between: bool = False
              ) -> Iterator[tuple[float, float, list[float]]]:
    """The steps of a fixed-step run through ``output_times`` with steps of at most
    ``step`` [s], each as (t₀, t₁, the output times it makes: those in (t₀, t₁]).
    ``between`` False: steps of equal length between consecutive output times, each output
    a step's end. ``between`` True: steps of equal length from the first output time to the
    last, the outputs between step ends read off the step's interpolant
    (rodsim/solvers/physical/dense_output.py): outputs force no step."""
    times = [float(time) for time in output_times]
    if between:
        t_start, t_end = times[0], times[-1]
        count = max(1, math.ceil((t_end - t_start) / step * (1.0 - 1e-12)))
        index = 1
        for k in range(count):
            t0 = t_start + (t_end - t_start) * k / count
            t1 = t_end if k == count - 1 else t_start + (t_end - t_start) * (k + 1) / count
            due = []
            while index < len(times) and (times[index] <= t1 or k == count - 1):
                due.append(times[index])
                index += 1
            yield t0, t1, due
        return
    for index in range(1, len(times)):
        t_first, t_next = times[index - 1], times[index]
        count = max(1, math.ceil((t_next - t_first) / step * (1.0 - 1e-12)))
        for k in range(count):
            t0 = t_first + (t_next - t_first) * k / count
            t1 = t_next if k == count - 1 else t_first + (t_next - t_first) * (k + 1) / count
            yield t0, t1, [t_next] if k == count - 1 else []
