"""What a track records of each step (rodsim/app/inverse/track.py): the contact forces, the
tension profiles of tendons with friction and their points' stick/slip states, the
stability verdict, and the step's values as text for its messages."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey
from rodsim.core import stability
from rodsim.core.friction_record import friction_record
from rodsim.core.model import Model
from rodsim.core.stability import Stability
from rodsim.core.terms.contact import contact_forces

__all__ = ["TrackRecord", "estimate_variables", "no_verdict", "record_contact", "record_stability",
           "stability_assess", "values_text"]


class TrackRecord(Protocol):
    """The fields of a track that the step recorders read and write: track.py's ``Track``
    is one, and this module does not import track.py, which imports it (no import cycle,
    type-only ones included: tests/test_layers.py)."""

    keys: list[NumericKey]
    values: np.ndarray
    states: list[np.ndarray]
    stable: list[bool]
    min_eigenvalues: list[float]
    contact: list[np.ndarray]
    success: bool
    message: str
    unstable_step: int | None
    tension: list[np.ndarray]
    chords: dict[str, np.ndarray]
    slip: list[np.ndarray]
    points: dict[str, np.ndarray]
    actuator: list[np.ndarray]


def record_contact(out: TrackRecord, model: Model) -> None:
    """The step's contact forces and, with tendon friction, its tension profiles and the
    stick/slip states of the routing points (from the step's own model: its friction
    anchors)."""
    force = contact_forces(model, out.states[-1])
    if force is not None:
        out.contact.append(force)
    friction = friction_record(model, out.states[-1])
    if friction is not None:
        out.chords, out.points = friction.chords, friction.points
        out.tension.append(friction.tension)
        out.slip.append(friction.slip)
        out.actuator.append(friction.actuator)


def record_stability(out: TrackRecord, step: int, stability: Stability,
                     allow_unstable: bool) -> bool:
    """Append the verdict of ``step``; False (and the track stopped) when it is unstable
    and unstable steps are not allowed (a neutral step, rodsim/core/stability.py, is not
    unstable: it is recorded as stable)."""
    out.stable.append(not stability.unstable)
    out.min_eigenvalues.append(float("nan") if not stability.unstable
                               else float(stability.min_eigenvalue))
    if not stability.unstable or allow_unstable:
        return True
    out.success, out.unstable_step = False, step
    out.message = (f"step {step} ({values_text(out.keys, out.values[step])}) is an unstable "
                   f"equilibrium (stiffness {stability.eigenvalue_text}"
                   "): the path crossed a stability limit (e.g. buckling) and the track "
                   "stopped there (allow unstable steps to go on, flagged)")
    return False


def values_text(keys: Sequence[NumericKey], row: np.ndarray) -> str:
    return ", ".join(f"{k.name} = {v:.6g}" for k, v in zip(keys, row, strict=True))


def stability_assess(model: Model, x: np.ndarray, *args: object) -> Stability:
    """The step's stability verdict, ``rodsim.core.stability.assess``, looked up when called
    (so one replacement of that function, a benchmark's timer or a test's probe, reaches
    every track step as it reaches every solve)."""
    return stability.assess(model, x, *args)  # type: ignore[arg-type]


def no_verdict(model: Model, x: np.ndarray, *_: object) -> Stability:
    """No stability verdict (a step recorded "stable"): a companion path's steps, which only
    measure an error estimate (rodsim/app/inverse/track_estimates.py), skip the verdict's
    cost (a dense eigenvalue problem where the band factorisation does not certify)."""
    return Stability(True)


def estimate_variables(discretisation: Sequence[float], penalty: Sequence[float],
                       steps: int) -> dict[str, tuple[str, np.ndarray, dict[str, str]]]:
    """The track archive's variables ``discretisation_error`` and ``penalty_error`` along
    ``step`` (rodsim/app/inverse/track_estimates.py), when estimated for every stored step."""
    out = {}
    for name, values in (("discretisation_error", discretisation), ("penalty_error", penalty)):
        if steps and len(values) == steps:
            out[name] = ("step", np.asarray(values, dtype=float), {
                "units": "1",
                "long_name": f"{name.replace('_', ' ')} estimate of the step / L (NaN: none)"})
    return out
