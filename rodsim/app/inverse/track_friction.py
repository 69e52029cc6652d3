"""What a track records of tendon friction, step by step (docs/tendon.md, "Friction"): the
steps inside the backlash dead zone, each tendon's actuator displacement, and the archive's
friction variables (chord tensions, displacement, actuator tension, stick/slip states)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from rodsim.core.model import Model
from rodsim.core.terms.base import TendonTerm
from rodsim.core.terms.tendon_string import TendonString
from rodsim.core.terms.tendon_string_displacement import TendonStringDisplacement
from rodsim.io.run_dataset import (
    actuator_variable,
    pulled_in_variables,
    slip_variables,
    tension_coordinates,
    tension_variable,
)

__all__ = ["dead_zone_steps", "friction_variables", "pulled_in"]


def dead_zone_steps(values: np.ndarray, tension: Sequence[np.ndarray],
                    chords: dict[str, np.ndarray], steps: int) -> list[int]:
    """The steps inside the backlash dead zone: the ramped values moved from the step
    before, but the termination tension of every tendon with friction held exactly (its
    last chord stuck)."""
    if not tension:
        return []
    ends = np.cumsum([len(s) for s in chords.values()]) - 1
    return [k for k in range(1, steps)
            if np.any(values[k] != values[k - 1])
            and np.array_equal(tension[k][ends], tension[k - 1][ends])]


def pulled_in(model: Model, chords: dict[str, np.ndarray], states: Sequence[np.ndarray],
              tension: Sequence[np.ndarray]) -> dict[str, np.ndarray]:
    """Each friction tendon's actuator displacement at every step since step 0 [m]: under
    tension control ℓ(step 0) − ℓ(step), ℓ its path's length (inextensible, held at its
    termination: what the actuator drew in); under displacement control
    d(step) − d(step 0), d = ℓ₀ − Σ_e ℓ_e / (1 + τ_e / E A) the free length the chords no
    longer hold (the ramped displacement, to the root's round-off)."""
    out = {}
    starts = dict(zip(chords, np.cumsum([0, *map(len, chords.values())]), strict=False))
    for term in model.terms:
        name = term.tendon.name if isinstance(term, TendonTerm) else ""
        if name not in chords or not states:
            continue
        if isinstance(term, TendonString):
            ell = np.array([term.length(full) for full in states])
            out[name] = ell[0] - ell
        elif isinstance(term, TendonStringDisplacement):
            span = slice(starts[name], starts[name] + len(chords[name]))
            drawn = np.array([term.drawn_in(full, step[span])
                              for full, step in zip(states, tension, strict=False)])
            out[name] = drawn - drawn[0]
    return out


def friction_variables(track: Any, steps: int) -> tuple[dict[str, Any], dict[str, Any]]:
    """(coordinates, data variables) of a ``Track``'s friction records along ``step``; both
    empty without tendon friction."""
    coords: dict[str, Any] = {}
    data: dict[str, Any] = {}
    if track.tension:
        coords.update(tension_coordinates(track.chords))
        data.update(tension_variable(np.array(track.tension), ("step",)))
    if track.tension and steps:
        pulled_coords, pulled_data = pulled_in_variables(track.pulled_in, ("step",))
        coords.update(pulled_coords)
        data.update(pulled_data)
        if len(track.actuator) == steps:
            data.update(actuator_variable(np.array(track.actuator), ("step",)))
    if track.slip:
        point_coords, slip_data = slip_variables(track.points, np.array(track.slip),
                                                 ("step",))
        coords.update(point_coords)
        data.update(slip_data)
    return coords, data
