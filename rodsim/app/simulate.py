"""``rodsim.simulate``: how a scene moves in physical time (issue 33; docs/dynamics.md).

    >>> import rodsim
    >>> run = rodsim.simulate(scene, 0.5, output_dt=1e-3,
    ...                       initial={"tip_load.force": [0.0, -0.01, 0.0]})
    >>> run.times, run.positions[:, -1]      # s; the tip [m] at every output time

The rods move under their physical inertia (rodsim/core/inertia.py), the scene's forces,
their damping (``[rods.<rod>.damping]``, rodsim/core/damping.py) and values that change in
time (``program``), integrated by the implicit midpoint rule
(rodsim/solvers/physical/midpoint.py) or the paper's semi-implicit Euler
(rodsim/solvers/physical/semi_implicit_euler.py), with fixed steps, or SUNDIALS IDA or CVODE
(rodsim/solvers/physical/ida_run.py), adaptive. The run starts at rest, from the scene's rest state
or from the equilibrium of the scene with the ``initial`` values (a release: hold the tip
with a force, let go at t = 0), or from a solved Result's state.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from rodsim.app.api import SceneLike, load_scene, solve
from rodsim.app.contact_report import failure_note
from rodsim.app.friction_trace import FrictionTrace
from rodsim.app.initial_velocity import VelocityLike, initial_rates, velocity_text
from rodsim.app.interrupted import Interrupted
from rodsim.app.programs import Program, Programs, check_programs
from rodsim.app.simulation import FIXED_STEP, INTEGRATORS, Simulation, StepLog
from rodsim.app.support_programs import check_support_programs
from rodsim.core.damping import Damping
from rodsim.core.inertia import mass_factor
from rodsim.core.model import Model
from rodsim.core.program import ProgramEntry
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError, shown
from rodsim.core.vibration import ModesError, natural_modes
from rodsim.solvers.physical.composition import ComposedStep
from rodsim.solvers.physical.coordinates import (
    PhysicalCoordinates,
    model_state,
    physical_state,
)
from rodsim.solvers.physical.dae import PhysicalDae
from rodsim.solvers.physical.error_control import (
    ControlledRecord,
    ErrorControl,
    integrate_controlled,
)
from rodsim.solvers.physical.events import EventError, EventLike, resolve_events
from rodsim.solvers.physical.fixed_step import FixedStep, Motion
from rodsim.solvers.physical.ida_run import PhysicalTimeOptions, integrate_ida
from rodsim.solvers.physical.midpoint import MidpointStep
from rodsim.solvers.physical.semi_implicit_euler import SemiImplicitEulerStep
from rodsim.solvers.physical.trajectory import integrate
from rodsim.solvers.physical.trajectory_record import Record
from rodsim.solvers.result import Result

__all__ = ["Simulation", "simulate", "check_programs", "ida_options", "INTEGRATORS",
           "FIXED_STEP", "IDA_DEFAULTS", "STEPS_PER_PERIOD"]

#: IDA's defaults: relative tolerance, absolute tolerance (× L on positions, radians on
#: angles; docs/dynamics.md, "IDA") and BDF order cap.
IDA_DEFAULTS = {"rtol": 1e-5, "atol": 1e-5, "max_order": 2}
#: Default steps per period of the lowest natural mode, when no step is given.
STEPS_PER_PERIOD = 100


def _start_state(scene: Scene, model: Model, initial: Mapping[str, Any] | Result | None
                 ) -> np.ndarray:
    """The free state the run starts from (at rest): the rest state, the equilibrium of the
    scene with ``initial``'s values, or a solved Result's state."""
    if initial is None:
        return physical_state(model, model.x0)
    if isinstance(initial, Result):
        result = initial
    else:
        result = solve(scene.with_values(dict(initial)), "static")
    if not result.success:
        raise SceneError(f"initial: no equilibrium to start from ({result.message})")
    other = Model(result.scene)
    if other.full_size != model.full_size:
        raise SceneError("initial: the Result's rods differ from the scene's")
    x = other.full(result.state)[model.free]
    coordinates = PhysicalCoordinates.of(model, x)
    q = x[coordinates.quaternions]
    x[coordinates.quaternions] = q / np.linalg.norm(q, axis=1)[:, None]
    return x


def _initial_text(initial: Mapping[str, Any] | Result | None) -> str:
    """How the run started, for its archive."""
    if initial is None:
        return "rest state"
    if isinstance(initial, Result):
        return f"a solved Result of scene {initial.scene.name!r}"
    return "equilibrium with " + json.dumps(dict(initial), sort_keys=True, default=str)


def _lowest_frequency(model: Model, x: np.ndarray, what: str) -> float:
    """ω₁ [rad/s], the lowest natural angular frequency at ``x``; SceneError saying that
    ``what`` (the default step, or IDA's velocity scale) needs it."""
    try:
        state = model_state(model, x)
        vibration = natural_modes(-model.jacobian(state), mass_factor(model, state), 1)
    except ModesError as exc:
        raise SceneError(f"no {what} ({exc}); give step=") from None
    omega2 = float(np.real(vibration.eigenvalues[0]))
    if not omega2 > 0.0:
        raise SceneError(f"no {what} (the start is not a stable equilibrium); give step=")
    return math.sqrt(omega2)


def ida_options(integrator: str, rtol: float | None, atol: float | None,
                 max_order: int | None) -> dict[str, float]:
    """IDA's checked settings (SceneError, one line, for a bad value, or for one given to
    a fixed-step integrator, which has none)."""
    given = {"rtol": rtol, "atol": atol, "max_order": max_order}
    if integrator == "midpoint" and rtol is not None:  # error control: rtol, atol
        if max_order is not None:
            raise SceneError("max_order: only for integrators 'ida' and 'cvode' (the "
                             "midpoint rule is of order 2)")
        checked = ida_options("ida", rtol, rtol if atol is None else atol, None)
        return {"rtol": checked["rtol"], "atol": checked["atol"]}
    if integrator == "midpoint" and atol is not None:
        raise SceneError("atol: give rtol too (the midpoint rule's error control); without "
                         "it the midpoint rule has fixed steps")
    if integrator in FIXED_STEP:
        named = [name for name, value in given.items() if value is not None]
        if named:
            raise SceneError(f"{named[0]}: only for integrators 'ida' and 'cvode' (the "
                             f"integrator {integrator!r} has fixed steps)")
        return {}
    out: dict[str, float] = {}
    for name, value in given.items():
        value = IDA_DEFAULTS[name] if value is None else value
        if name == "max_order":
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 5:
                raise SceneError(f"max_order = {shown(value)}: allowed an integer 1 to 5 (the "
                                 "BDF order cap)")
        elif (isinstance(value, bool) or not isinstance(value, (int, float))
              or not 1e-14 <= value <= 1e-2):
            raise SceneError(f"{name} = {shown(value)}: allowed a number from 1e-14 to 1e-2")
        out[name] = value
    return out


def simulate(scene: SceneLike | None, t_end: float, *, output_dt: float | None = None,
             integrator: str = "midpoint", initial: Mapping[str, Any] | Result | None = None,
             program: Program | None = None, step: float | None = None,
             overrides: Sequence[str] = (),
             progress: Callable[[float], None] | None = None, rtol: float | None = None,
             atol: float | None = None, max_order: int | None = None,
             initial_velocity: VelocityLike | None = None,
             events: Sequence[EventLike] = ()) -> Simulation:
    """Integrate ``scene`` in physical time from t = 0 to ``t_end`` [s].

    ``integrator``: ``"midpoint"`` (the implicit midpoint rule, fixed steps; with ``rtol``
    (and ``atol``, default ``rtol``) its steps are chosen under error control and ``step``
    is the longest: rodsim/solvers/physical/error_control.py), ``"midpoint4"`` (fixed
    steps of order four, each five midpoint steps: rodsim/solvers/physical/composition.py;
    without friction or error control), ``"paper"``
    (the paper's semi-implicit Euler, Eqs. 14–17, with the physical masses: fixed steps,
    first order, numerically damped), ``"ida"``
    (SUNDIALS IDA, adaptive BDF under error control: ``rtol``, ``atol`` — × the longest
    rod's length on positions, radians on angles, and × ω₁ on their rates — and the order
    cap ``max_order``; docs/dynamics.md) or ``"cvode"`` (SUNDIALS CVODE on the explicit
    form, the same options; a dense Jacobian up to 400 unknowns, above it the banded Newton
    matrix with GMRES). ``output_dt``: the spacing of the output times [s] (default: every
    step of the midpoint rule; 1/100 of the lowest natural period for IDA and CVODE; outputs
    between step ends are read off the step's cubic Hermite interpolant and force no step,
    except with friction, whose fixed steps end on every output);
    ``step``: the longest time step [s] (midpoint and paper default: 1/100 of the lowest
    natural period at the start; IDA and CVODE: none);
    ``initial``: a mapping of ``--set`` keys to values whose equilibrium the run starts
    from, or a solved Result (default: the rest state); ``program``: key → (times, values)
    (piecewise linear) or a ``rodsim.core.program.Sinusoid`` per numeric term value,
    added to the scene file's ``[program]`` (replacing its entry for the same value);
    ``overrides``: ``key=value`` changes
    of the scene; ``initial_velocity``: the velocity at t = 0 (default: at rest) — a
    3-vector [m/s] that every free node moves with, or the physical velocities (each free
    position coordinate's rate, then each free segment's body rates; p + 3 s numbers), or
    the rates of the model's n free coordinates (rodsim/app/initial_velocity.py);
    ``events``: ``rodsim.ContactOnset``, ``rodsim.TendonSlack`` and ``rodsim.Event`` (a
    user's function of (t, positions)) values (or ``"contact"``, ``"slack"``, ``":stop"``
    appended for a terminal one), found by SUNDIALS' root finding (``ida`` and ``cvode``)
    or after each midpoint step on its cubic Hermite interpolant: each one's time and name
    in ``Simulation.events``, a terminal one ends the run there. Bad input raises
    ``rodsim.core.schema.SceneError`` (one line) before any work; a run that fails
    part-way returns ``success`` False with what it computed.
    """
    if integrator not in INTEGRATORS:
        raise SceneError(f"integrator {shown(integrator)}: allowed: {', '.join(INTEGRATORS)}")
    for name, value, allow_none in (("t_end", t_end, False), ("output_dt", output_dt, True),
                                    ("step", step, True)):
        if value is None and allow_none:
            continue
        if (isinstance(value, bool) or not isinstance(value, (int, float))
                or not math.isfinite(value) or value <= 0.0):
            raise SceneError(f"{name} = {shown(value)}: allowed a number > 0 [s]")
    settings = ida_options(integrator, rtol, atol, max_order)
    controlled = integrator == "midpoint" and bool(settings)
    control_text = (f"rtol = {settings['rtol']:g}, atol = {settings['atol']:g}"
                    if controlled else "")
    loaded = load_scene(scene, overrides)
    model = Model(loaded)
    programs = Programs(loaded, model, program)
    check_support_programs(loaded, programs.keys, integrator, programs.path_dependent)
    if programs.path_dependent and integrator != "midpoint":  # before any work
        raise SceneError(f"integrator {integrator!r}: the scene has friction (a string "
                         "tendon's or a contact's), whose history each step carries to the "
                         "next; allowed: integrator 'midpoint' (IDA's and CVODE's adaptive "
                         "steps would each need a restart; the paper's Euler is not validated "
                         "with friction)")
    if programs.path_dependent and controlled:
        raise SceneError("rtol: the scene has friction (a string tendon's or a contact's), "
                         "whose history each step carries to the next, and a rejected step "
                         "would have to undo it; allowed: the midpoint rule with fixed steps "
                         "(give step= instead of rtol)")
    if events and integrator == "paper":
        raise SceneError("events: allowed with integrator 'midpoint', 'ida' or 'cvode'; "
                         "the paper's Euler does not locate them")
    watched = resolve_events(model, events) if events else None
    rest = physical_state(model, model.x0)  # the velocity's length checked before any work
    initial_rates(model, PhysicalCoordinates.of(model, rest), rest, initial_velocity)
    x = _start_state(loaded, model, initial)
    omega = math.nan
    if integrator not in FIXED_STEP or controlled:
        try:
            omega = _lowest_frequency(model, x, "velocity scale of the tolerances")
        except SceneError:  # no stable equilibrium at the start (a falling rod): the run's
            omega = 2.0 * math.pi / float(t_end)  # own time scale (docs/dynamics.md, "IDA")
    elif step is None or output_dt is None:
        omega = _lowest_frequency(model, x, "default step")
    h = float(step) if step is not None else 2.0 * math.pi / omega / STEPS_PER_PERIOD
    spacing = float(output_dt) if output_dt is not None else h
    count = max(1, math.ceil(float(t_end) / spacing * (1.0 - 1e-12)))
    outputs = np.minimum(np.arange(count + 1) * spacing, float(t_end))
    friction = FrictionTrace(programs, outputs)
    if programs.path_dependent:
        # The start: at rest in the equilibrium it was left in (x holds the coordinates
        # themselves, the history is taken at the model's offsets from its rest state).
        friction.start(model_state(model, x))
    coordinates = PhysicalCoordinates.of(model, x)
    length = max(rod.options.length for rod in model.rods.values())
    stepper: SemiImplicitEulerStep | MidpointStep = (
        SemiImplicitEulerStep(coordinates, Damping(model), length) if integrator == "paper"
        else MidpointStep(coordinates, Damping(model), length,
                          supports=programs.supports.at if programs.supports.active
                          else None))
    start = Motion(x, *initial_rates(model, coordinates, x, initial_velocity))
    stepping: FixedStep = (ComposedStep(stepper, programs.model_at)
                           if integrator == "midpoint4" and isinstance(stepper, MidpointStep)
                           else stepper)
    if watched is not None:  # a user's function checked at the start (EventError, one line)
        watched.values(0.0, programs.model_at(0.0), x, start.v)
    record = ControlledRecord() if controlled else Record()
    # where a support moves, the held coordinates at each output are the model's of its time
    moved = programs.model_at if programs.supports.active else None
    try:
        if controlled:
            first = 2.0 * math.pi / omega / STEPS_PER_PERIOD
            control = ErrorControl(settings["rtol"], settings["atol"], length, omega,
                                   first if step is None else min(first, float(step)),
                                   0.0 if step is None else float(step))
            assert isinstance(stepper, MidpointStep) and isinstance(record, ControlledRecord)
            integrate_controlled(programs.model_at, stepper, start, outputs, control,
                                 programs.breaks, progress, record, watched)
        elif integrator not in FIXED_STEP:
            options = PhysicalTimeOptions(settings["rtol"], settings["atol"],
                                          int(settings["max_order"]),
                                          0.0 if step is None else float(step), length, omega)
            dae = PhysicalDae(coordinates, stepper.damping, programs.model_at, model.n)
            integrate_ida(dae, programs.model_at, start, outputs, programs.breaks, options,
                          progress, record, integrator, watched, varies=bool(programs.keys),
                          difference=programs.difference)
        else:
            integrate(programs.model_at, stepping, start, outputs, h, progress, record,
                      friction.after_step if programs.path_dependent else None, watched,
                      friction.mark if programs.path_dependent else None,
                      between=not programs.path_dependent and _between_steps(spacing, h))
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM: what was computed, marked incomplete
        done = min(len(record.times), len(record.states), len(record.kinetic),
                   len(record.potential), len(record.dissipated), len(record.work))
        del record.states[done:]
        for column in (record.times, record.kinetic, record.potential, record.dissipated,
                       record.work):
            del column[done:]
        if not record.times:
            raise
        record.success = False
        record.message = (f"interrupted after t = {record.times[-1]:.6g} s (the outputs up to "
                          "it are kept)")
        partial = _simulation(loaded, model, record, _step_of(record, h, integrator),
                              integrator, float(t_end), programs.by_name, initial,
                              initial_velocity, friction, moved, control_text)
        raise Interrupted(partial, record.message) from None
    except EventError as exc:  # a user's event function failed part-way
        if not record.times:
            raise
        record.success = False
        record.message = (f"stopped after the output at t = {record.times[-1]:.6g} s: {exc}; "
                          "the outputs up to it are kept")
    except SceneError as exc:  # a rule across two programmed values, broken at some time
        if not record.times:
            raise
        record.success = False
        record.message = (f"stopped after the output at t = {record.times[-1]:.6g} s: the "
                          f"programs' values break a rule before the next ({exc}); the "
                          "outputs up to it are kept")
    return _simulation(loaded, model, record, _step_of(record, h, integrator), integrator,
                       float(t_end), programs.by_name, initial, initial_velocity, friction,
                       moved, control_text)


def _between_steps(spacing: float, h: float) -> bool:
    """Whether a fixed-step run's outputs fall between its steps (read off the steps'
    interpolants, rodsim/solvers/physical/dense_output.py): the output spacing is not a
    whole number of steps of ``h`` (to 1e-9 relative)."""
    steps = round(spacing / h)
    return steps < 1 or abs(spacing - steps * h) > 1e-9 * spacing


def _step_of(record: Record, h: float, integrator: str) -> float:
    """The step a Simulation reports: a fixed-step integrator's ``h``, IDA's or CVODE's
    (or the error-controlled midpoint rule's) longest step."""
    return h if integrator in FIXED_STEP and not record.accepted else record.largest_step


def _simulation(loaded: Scene, model: Model, record: Record, h: float, integrator: str,
                t_end: float, programs: dict[str, ProgramEntry],
                initial: Mapping[str, Any] | Result | None,
                initial_velocity: VelocityLike | None = None,
                friction: FrictionTrace | None = None,
                model_at: Callable[[float], Model] | None = None,
                control: str = "") -> Simulation:
    """The ``Simulation`` of what ``record`` holds (with ``friction``'s tensions and
    stick/slip states at its times; ``model_at``: the model of a time, whose held
    coordinates a moving support sets; ``control``: the error control's tolerances, as
    text)."""
    states = np.array(record.states)
    models = ([model_at(t) for t in record.times[:len(states)]] if model_at is not None
              else [model] * len(states))
    full = np.array([at.full(model_state(at, state))
                     for at, state in zip(models, states, strict=True)])
    positions = np.concatenate([full[:, model.rods[name].layout.position_index]
                                for name in model.rods], axis=1)
    quaternions = np.concatenate([full[:, model.rods[name].layout.quaternion_index]
                                  for name in model.rods], axis=1)
    message = record.message
    if not record.success:  # a start through an obstacle's wall is the likely cause
        message += failure_note(loaded, message)
    if record.success and not model.conservative:  # "ok", or a terminal event's message
        message += ("; a non-conservative term (the paper's lumen coupling, friction): no "
                    "potential energy, no energy balance")
    return Simulation(record.success, message, loaded, np.array(record.times), positions,
                      quaternions, np.array(record.kinetic), np.array(record.potential),
                      np.array(record.dissipated), np.array(record.work), h,
                      integrator, record.steps, record.iterations, record.halvings,
                      tuple(model.rods), states, t_end, programs,
                      _initial_text(initial) + velocity_text(initial_velocity),
                      tuple(record.events),
                      friction.at(record.times) if friction is not None else None,
                      control, record.rejected,
                      tuple(b for b in friction.breakaways if b.time <= record.times[-1])
                      if friction is not None and record.times else (),
                      _step_log(record),
                      resticks=tuple(r for r in friction.resticks if r.time <= record.times[-1])
                      if friction is not None and record.times else (),
                      interpolated=np.array(record.interpolated, dtype=bool))


def _step_log(record: Record) -> StepLog | None:
    """Under error control, the steps accepted and the attempts rejected (``StepLog``)."""
    if not isinstance(record, ControlledRecord):
        return None
    rejections = np.array(record.rejections, dtype=float).reshape(-1, 3)
    return StepLog(np.array(record.step_ends, dtype=float),
                   np.array(record.step_sizes, dtype=float), rejections[:, 0],
                   rejections[:, 1], rejections[:, 2])
