"""Events of a run in physical time: contact onset and a tendon going slack (issue 33 item
3; docs/dynamics.md, "Events"), found by SUNDIALS' root finding (IDA and CVODE).

An event is a value on the run, as diffrax's are: ``ContactOnset`` and
``TendonSlack``, each optionally ``terminal`` (the run stops at the first time it
happens). Each resolves, on the scene's model, into event functions g(t, x) whose zero
crossing *downward* is the event (SUNDIALS' root direction −1):

- contact onset, one function per (obstacle, rod) contact term: the smallest gap of the
  rod's node spheres to the obstacle, g = min_i (φ(r_i) − r) [m] (rodsim/core/terms/
  contact.py: the penetration p_i = r − φ(r_i) is −g): the first node that touches;
- a tendon going slack, one function per string tendon: its tension [N] — for a
  tension-controlled string the value of its ``tension`` at time t (a program) less
  ``SLACK``, for a
  displacement-controlled one the elastic string's (E A/ℓ*) (ℓ(x) − ℓ*) without the
  clipping at zero (so that it crosses zero instead of touching it).

The run records each event's time and name (``Simulation.events``, the archive's
``event_time`` and ``event_name``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from rodsim.core.model import Model
from rodsim.core.schema import SceneError
from rodsim.core.terms.contact import Contact
from rodsim.core.terms.tendon_string import TendonString
from rodsim.core.terms.tendon_string_displacement import TendonStringDisplacement
from rodsim.solvers.physical.coordinates import model_state

__all__ = ["ContactOnset", "TendonSlack", "EventFunctions", "resolve_events", "EventLike"]


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

EventLike = ContactOnset | TendonSlack | str

#: The short names an event may be given by.
NAMES: dict[str, type[ContactOnset] | type[TendonSlack]] = {"contact": ContactOnset,
                                                          "slack": TendonSlack}


def _event(value: EventLike) -> ContactOnset | TendonSlack:
    if isinstance(value, (ContactOnset, TendonSlack)):
        return value
    if isinstance(value, str):
        name, _, option = value.partition(":")
        kind = NAMES.get(name.strip())
        if kind is not None and option.strip() in ("", "stop"):
            return kind(terminal=option.strip() == "stop")
    raise SceneError(f"event {str(value)[:40]!r}: allowed ContactOnset(...), TendonSlack(...) "
                     "or 'contact', 'slack' (':stop' for a terminal event)")


@dataclass
class EventFunctions:
    """The resolved event functions of one scene: their names, which are terminal, and
    ``values(model, x)`` [one value per function] at the free coordinates ``x`` of the
    model of time t."""

    names: list[str]
    terminal: list[bool]
    functions: list[Callable[[Model, np.ndarray], float]]

    def __len__(self) -> int:
        return len(self.names)

    def values(self, model: Model, x: np.ndarray) -> np.ndarray:
        full = model.full(model_state(model, x))
        return np.array([g(model, full) for g in self.functions])


def _term_at(index: int, kind: type) -> Callable[[Model], object]:
    """The ``index``-th term of the model of time t (the same place in every model)."""
    def term(model: Model) -> object:
        found = model.terms[index]
        assert isinstance(found, kind)
        return found
    return term


def resolve_events(model: Model, events: Sequence[EventLike]) -> EventFunctions:
    """The event functions of ``events`` on ``model`` (module docstring); a one-line
    SceneError for an event the scene cannot have (no obstacle, no string tendon, an
    unknown name)."""
    out = EventFunctions([], [], [])
    for value in events:
        event = _event(value)
        found = 0
        for index, term in enumerate(model.terms):
            if isinstance(event, ContactOnset) and isinstance(term, Contact):
                obstacle = term.obstacle.name
                if event.obstacle not in (None, obstacle):
                    continue
                get = _term_at(index, Contact)

                def gap(m: Model, full: np.ndarray, get=get) -> float:
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

                    def tension(m: Model, full: np.ndarray, get=get) -> float:
                        t = get(m)
                        return float(t.spring * (t.path_length(full)
                                                 - t.free_length))
                else:
                    get = _term_at(index, TendonString)

                    def tension(m: Model, full: np.ndarray, get=get) -> float:
                        return float(get(m).tension) - SLACK
                out.functions.append(tension)
                out.names.append(f"tendon slack: {tendon}")
            else:
                continue
            out.terminal.append(event.terminal)
            found += 1
        if not found:
            what = ("obstacle" + (f" named {event.obstacle!r}" if event.obstacle else "")
                    if isinstance(event, ContactOnset)
                    else "string tendon" + (f" named {event.tendon!r}" if event.tendon
                                              else ""))
            raise SceneError(f"event {type(event).__name__}: the scene has no {what}")
    return out
