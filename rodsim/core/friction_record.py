"""What an archive records of tendon friction at one state: each tendon's chord tensions
and the stick/slip states of its routing points (rodsim/core/tendon_friction.py;
docs/tendon.md, "Friction"), as a track records them per step and ``simulate`` per output
time."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rodsim.core.model import Model
from rodsim.core.terms.base import TendonTerm

__all__ = ["FrictionRecord", "friction_record"]


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


def friction_record(model: Model, full: np.ndarray) -> FrictionRecord | None:
    """The friction state at the full state ``full`` with ``model``'s history (its
    friction anchors: the last equilibrium's, or a step's after a breakaway); None when no
    tendon has friction."""
    profiles, states = {}, {}
    for term in model.terms:
        if isinstance(term, TendonTerm):
            profile = term.tension_profile(full)
            slip = term.point_states(full)
            if profile is not None and slip is not None:
                profiles[term.tendon.name], states[term.tendon.name] = profile, slip
    if not profiles:
        return None
    return FrictionRecord({name: s for name, (s, _) in profiles.items()},
                          np.concatenate([t for _, t in profiles.values()]),
                          {name: s for name, (s, _) in states.items()},
                          np.concatenate([state for _, state in states.values()]))
