"""Events of a run in physical time: contact onset, a tendon going slack and a user's
function of time and positions (issue 33 item 3; docs/dynamics.md, "Events"), found by
SUNDIALS' root finding (IDA and CVODE) or after each step of the midpoint rule
(rodsim/solvers/physical/step_events.py).

An event is a value on the run, as diffrax's are: ``ContactOnset``, ``TendonSlack`` and
``Event``, each optionally ``terminal`` (the run stops at the first time it happens).
Each resolves, on the scene's model, into event functions g(t, x) whose zero crossing
*downward* is the event (SUNDIALS' root direction −1; an ``Event`` chooses its
direction):

- contact onset, one function per (obstacle, rod) contact term: the smallest gap of the
  rod's node spheres to the obstacle, g = min_i (φ(r_i) − r) [m] (rodsim/core/terms/
  contact.py: the penetration p_i = r − φ(r_i) is −g): the first node that touches;
- a tendon going slack, one function per string tendon: its tension [N] — for a
  tension-controlled string the value of its ``tension`` at time t (a program) less
  ``SLACK``, for a
  displacement-controlled one the elastic string's (E A/ℓ*) (ℓ(x) − ℓ*) without the
  clipping at zero (so that it crosses zero instead of touching it);
- a user's ``Event(function)``: g = function(t, positions), positions every control
  point (nodes, 3) [m], the rods concatenated in the scene's order as in a run archive;
  with ``velocities=True`` g = function(t, positions, velocities), their velocities
  (nodes, 3) [m/s] (0 at a held node).

The run records each event's time and name (``Simulation.events``, the archive's
``event_time`` and ``event_name``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from rodsim.core.model import Model
from rodsim.core.schema import SceneError, shown
from rodsim.core.terms.contact import Contact
from rodsim.core.terms.tendon_string import TendonString
from rodsim.core.terms.tendon_string_displacement import TendonStringDisplacement
from rodsim.solvers.physical.coordinates import (
    PhysicalCoordinates,
    model_state,
    physical_state,
)

__all__ = ["ContactOnset", "TendonSlack", "Event", "EventError", "EventFunctions",
           "resolve_events", "EventLike"]


class EventError(SceneError):
    """A user's event function failed or returned no finite number (one line)."""


@dataclass(frozen=True)
class ContactOnset:
    """A node of a rod touches an obstacle (any obstacle, or the one named ``obstacle``);
    ``terminal``: the run stops there."""

    obstacle: str | None = None
    terminal: bool = False


@dataclass(frozen=True)
class TendonSlack:
    """A string tendon's tension reaches zero (any string tendon, or the one named
    ``tendon``); ``terminal``: the run stops there."""

    tendon: str | None = None
    terminal: bool = False


#: A tension-controlled string is slack below this tension [N]: its event function is
#: T(t) − SLACK, so that a tension programmed to 0 and held there is not a function that
#: vanishes on an interval (SUNDIALS' root finding refuses one: "roots found at and very
#: near t").
SLACK = 1e-9

@dataclass(frozen=True)
class Event:
    """A user's event: ``function(t, positions)`` → a number whose zero crossing in
    ``direction`` (−1 downward, +1 upward, 0 either) is the event; ``positions`` every
    control point (nodes, 3) [m], the rods concatenated as in a run archive; with
    ``velocities`` True, ``function(t, positions, velocities)``, the control points'
    velocities (nodes, 3) [m/s]; ``name`` (the function's name by default) is what the run
    records; ``terminal``: the run stops there."""

    function: Callable[..., float]
    name: str | None = None
    terminal: bool = False
    direction: int = -1
    velocities: bool = False

    def __post_init__(self) -> None:
        if not callable(self.function):
            raise SceneError(f"Event({shown(self.function)}): allowed a function "
                             "f(t, positions) -> float")
        if self.name is not None and (not isinstance(self.name, str) or not self.name.strip()):
            raise SceneError(f"Event name = {shown(self.name)}: allowed a non-empty string")
        for flag in ("terminal", "velocities"):
            if not isinstance(getattr(self, flag), bool):
                raise SceneError(f"Event {flag} = {shown(getattr(self, flag))}: allowed True "
                                 "or False")
        if isinstance(self.direction, bool) or self.direction not in (-1, 0, 1):
            raise SceneError(f"Event direction = {shown(self.direction)}: allowed -1 "
                             "(downward), 1 (upward) or 0 (either)")

    @property
    def label(self) -> str:
        """The name the run records."""
        return self.name or str(getattr(self.function, "__name__", "event"))


EventLike = ContactOnset | TendonSlack | Event | str

#: The short names an event may be given by.
NAMES: dict[str, type[ContactOnset] | type[TendonSlack]] = {"contact": ContactOnset,
                                                          "slack": TendonSlack}


def _event(value: EventLike) -> ContactOnset | TendonSlack | Event:
    if isinstance(value, (ContactOnset, TendonSlack, Event)):
        return value
    if isinstance(value, str):
        name, _, option = value.partition(":")
        kind = NAMES.get(name.strip())
        if kind is not None and option.strip() in ("", "stop"):
            return kind(terminal=option.strip() == "stop")
    raise SceneError(f"event {str(value)[:40]!r}: allowed ContactOnset(...), TendonSlack(...), "
                     "Event(function) or 'contact', 'slack' (':stop' for a terminal event)")


#: An event function: g(t, the model of time t, the full state, the physical velocities
#: u = (ṙ, ω) of rodsim/solvers/physical/coordinates.py; their node velocities first).
Function = Callable[[float, Model, np.ndarray, np.ndarray], float]


@dataclass
class EventFunctions:
    """The resolved event functions of one scene: their names, which are terminal, their
    root directions (−1, +1, 0) and ``values(t, model, x)`` [one value per function] at
    the free coordinates ``x`` of ``model``, the model of time t."""

    names: list[str]
    terminal: list[bool]
    functions: list[Function]
    directions: list[int] = field(default_factory=list)
    #: The first failure of a user's function inside SUNDIALS' callback (ida_run.py).
    failure: EventError | None = None

    def __len__(self) -> int:
        return len(self.names)

    def values(self, t: float, model: Model, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """g at (t, x) with the node velocities ``v`` (p,) [m/s] (each free position
        coordinate's, in ``rodsim.solvers.physical.coordinates.PhysicalCoordinates``'
        order); EventError for a user's function that fails or returns no finite number."""
        full = model.full(model_state(model, x))
        return np.array([g(t, model, full, v) for g in self.functions])


def _user(event: Event, index: np.ndarray, pick: np.ndarray) -> Function:
    """``event``'s function as an event function (checked: a finite number or EventError,
    one line): the positions ``full[index]``, the velocities the node velocities at
    ``pick`` (−1: a held coordinate, 0)."""
    name = event.label
    signature = "(t, positions, velocities)" if event.velocities else "(t, positions)"

    def g(t: float, model: Model, full: np.ndarray, v: np.ndarray) -> float:
        try:
            if event.velocities:
                value = event.function(t, full[index], np.append(v, 0.0)[pick])
            else:
                value = event.function(t, full[index])
            number = float(value)
        except Exception as exc:  # the user's code: any failure is one line
            text = " ".join(str(exc).split())[:200]
            raise EventError(f"event {name!r}: function{signature} at t = {t:.6g} s failed "
                             f"({type(exc).__name__}: {text}); allowed a function of "
                             f"{signature} returning a number") from None
        if not math.isfinite(number):
            raise EventError(f"event {name!r}: function{signature} returned {number} at "
                             f"t = {t:.6g} s; allowed a finite number")
        return number
    return g


def _term_at(index: int, kind: type) -> Callable[[Model], object]:
    """The ``index``-th term of the model of time t (the same place in every model)."""
    def term(model: Model) -> object:
        found = model.terms[index]
        assert isinstance(found, kind)
        return found
    return term


def _velocity_slots(model: Model, index: np.ndarray) -> np.ndarray:
    """Where each full-state position coordinate ``index`` sits in the node velocities (the
    free position coordinates in ``PhysicalCoordinates``' order), −1 where it is held."""
    coordinates = PhysicalCoordinates.of(model, physical_state(model, model.x0))
    free_of = np.full(model.full_size, -1)
    free_of[model.free] = np.arange(model.n)
    slot = np.full(model.n + 1, -1)  # the last: a held coordinate's free index −1
    slot[coordinates.positions] = np.arange(len(coordinates.positions))
    return slot[free_of[index]]


def resolve_events(model: Model, events: Sequence[EventLike]) -> EventFunctions:
    """The event functions of ``events`` on ``model`` (module docstring); a one-line
    SceneError for an event the scene cannot have (no obstacle, no string tendon, an
    unknown name)."""
    out = EventFunctions([], [], [], [])
    for value in events:
        event = _event(value)
        if isinstance(event, Event):
            positions = np.concatenate([rod.layout.position_index
                                        for rod in model.rods.values()])
            out.functions.append(_user(event, positions, _velocity_slots(model, positions)))
            out.names.append(event.label)
            out.terminal.append(event.terminal)
            out.directions.append(event.direction)
            continue
        found = 0
        for index, term in enumerate(model.terms):
            if isinstance(event, ContactOnset) and isinstance(term, Contact):
                obstacle = term.obstacle.name
                if event.obstacle not in (None, obstacle):
                    continue
                get = _term_at(index, Contact)

                def gap(t: float, m: Model, full: np.ndarray, v: np.ndarray,
                        get=get) -> float:
                    return float(-np.max(get(m).penetration(full)))
                out.functions.append(gap)
                out.names.append(f"contact onset: {term.rod.name} on {obstacle}")
            elif isinstance(event, TendonSlack) and isinstance(term, (TendonString,
                                                                      TendonStringDisplacement)):
                tendon = term.tendon.name
                if event.tendon not in (None, tendon):
                    continue
                if isinstance(term, TendonStringDisplacement):
                    get = _term_at(index, TendonStringDisplacement)

                    def tension(t: float, m: Model, full: np.ndarray, v: np.ndarray,
                                get=get) -> float:
                        string = get(m)
                        return float(string.spring * (string.path_length(full)
                                                      - string.free_length))
                else:
                    get = _term_at(index, TendonString)

                    def tension(t: float, m: Model, full: np.ndarray,
                                v: np.ndarray, get=get) -> float:
                        return float(get(m).tension) - SLACK
                out.functions.append(tension)
                out.names.append(f"tendon slack: {tendon}")
            else:
                continue
            out.terminal.append(event.terminal)
            out.directions.append(-1)
            found += 1
        if not found:
            what = ("obstacle" + (f" named {event.obstacle!r}" if event.obstacle else "")
                    if isinstance(event, ContactOnset)
                    else "string tendon" + (f" named {event.tendon!r}" if event.tendon
                                              else ""))
            raise SceneError(f"event {type(event).__name__}: the scene has no {what}")
    return out
