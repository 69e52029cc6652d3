"""What an archive records of tendon friction at one state: each tendon's chord tensions
and the stick/slip states of its routing points (rodsim/core/tendon_friction.py;
docs/tendon.md, "Friction"), as a track records them per step and ``simulate`` per output
time; and a routing point breaking loose during ``simulate`` (``Breakaway``), or sticking
again (``Restick``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rodsim.core.model import Model
from rodsim.core.terms.base import TendonTerm
from rodsim.core.terms.tendon_string import TendonString

__all__ = ["Breakaway", "FrictionRecord", "Restick", "breakaways", "friction_record",
           "resticks"]


@dataclass(frozen=True)
class FrictionRecord:
    """The friction state of every tendon with friction, tendon by tendon, actuator first."""

    #: Each tendon's chords: the rest arc lengths of their midpoints [m].
    chords: dict[str, np.ndarray]
    #: The tension of every chord [N], the tendons concatenated.
    tension: np.ndarray
    #: Each tendon's routing points at the chords' starts: their rest arc lengths [m].
    points: dict[str, np.ndarray]
    #: The stick/slip state of each of those points (−1 sliding in, 0 stuck, +1 sliding
    #: out), concatenated as ``tension``.
    slip: np.ndarray
    #: Each tendon's actuator tension [N], in the order of ``chords``: the scene's under
    #: tension control, the outcome under displacement control (empty where not recorded).
    actuator: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))


def friction_record(model: Model, full: np.ndarray) -> FrictionRecord | None:
    """The friction state at the full state ``full`` with ``model``'s history (its
    friction anchors: the last equilibrium's, or a step's after a breakaway); None when no
    tendon has friction."""
    profiles, states, actuator = {}, {}, []
    for term in model.terms:
        if isinstance(term, TendonTerm):
            profile = term.tension_profile(full)
            slip = term.point_states(full)
            if profile is not None and slip is not None:
                profiles[term.tendon.name], states[term.tendon.name] = profile, slip
                outcome = term.tension_outcome(full)
                actuator.append(float(term.options.tension) if outcome is None else outcome)
    if not profiles:
        return None
    return FrictionRecord({name: s for name, (s, _) in profiles.items()},
                          np.concatenate([t for _, t in profiles.values()]),
                          {name: s for name, (s, _) in states.items()},
                          np.concatenate([state for _, state in states.values()]),
                          np.array(actuator))


@dataclass(frozen=True)
class Breakaway:
    """A routing point of a string tendon with stiction breaking loose during a run in
    physical time (docs/dynamics.md, "Friction in physical time"): held by its static μ_s
    (stuck, or sliding the other way) until ``time``, the root located inside the midpoint
    step (rodsim/solvers/physical/breakaway.py), sliding at its kinetic μ_k from then on."""

    #: The located time [s].
    time: float
    #: The tendon's name.
    tendon: str
    #: The routing point's index along the tendon (0 the entry; the point at the start of
    #: chord ``point``, as the archive's ``slip_state`` is indexed).
    point: int
    #: Its rest arc length on the catheter [m].
    s: float
    #: The way it slides from then on: −1 in (toward the actuator), +1 out.
    direction: int


def breakaways(before: Model, after: Model, t: float) -> list[Breakaway]:
    """The points of every string tendon with stiction that broke loose between the
    history of ``before`` and that of ``after`` (the same model, its history carried once
    at time ``t``): those whose stick/slip state went to sliding (−1 or +1) from any other
    (stuck, or sliding the other way), in the tendons' order and along each."""
    found = []
    for old, new in zip(before.terms, after.terms, strict=True):
        if not (isinstance(old, TendonString) and isinstance(new, TendonString)
                and new.sticky):
            continue
        for e in np.flatnonzero((new.state != 0.0) & (new.state != old.state)):
            found.append(Breakaway(float(t), new.tendon.name, int(e),
                                   float(new.points.s[e]), int(new.state[e])))
    return found


@dataclass(frozen=True)
class Restick:
    """A sliding routing point of a string tendon with stiction sticking again during a run
    in physical time (docs/dynamics.md, "Friction in physical time"): its sliding bound
    turned back at ``time``, the root located inside the midpoint step
    (rodsim/solvers/physical/restick.py); held by its static μ_s from then on."""

    #: The located time [s].
    time: float
    #: The tendon's name.
    tendon: str
    #: The routing point's index along the tendon (as ``Breakaway.point``).
    point: int
    #: Its rest arc length on the catheter [m].
    s: float
    #: The way it slid until then: −1 in (toward the actuator), +1 out.
    direction: int


def resticks(model: Model, held: Sequence[tuple[int, int, int]], t: float) -> list[Restick]:
    """The points ``held`` — (the term's index in ``model``, the point's index, the way it
    slid) — that stuck again at time ``t``, in the order given."""
    found = []
    for index, e, direction in held:
        term = model.terms[index]
        assert isinstance(term, TendonString)
        found.append(Restick(float(t), term.tendon.name, int(e), float(term.points.s[e]),
                             int(direction)))
    return found
