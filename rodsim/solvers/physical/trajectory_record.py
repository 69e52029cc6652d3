"""What a run in physical time computed at its output times (``Record``), and the potential
energy V(x) each output carries (docs/dynamics.md, "Energy"): filled by the fixed-step loop
(rodsim/solvers/physical/trajectory.py), the error-controlled one
(rodsim/solvers/physical/error_control.py) and SUNDIALS' (rodsim/solvers/physical/ida_run.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rodsim.core.model import Model
from rodsim.solvers.physical.coordinates import model_state
from rodsim.solvers.physical.fixed_step import Motion

__all__ = ["Record", "potential"]


@dataclass
class Record:
    """What a run computed at its output times (all arrays lengthen together)."""

    times: list[float] = field(default_factory=list)
    states: list[np.ndarray] = field(default_factory=list)
    kinetic: list[float] = field(default_factory=list)
    potential: list[float] = field(default_factory=list)
    dissipated: list[float] = field(default_factory=list)
    work: list[float] = field(default_factory=list)
    #: Whether each output was read off the interpolant of the step that covers it (an
    #: output between step ends, rodsim/solvers/physical/dense_output.py; SUNDIALS' own
    #: interpolation under IDA and CVODE) rather than being a step's end state.
    interpolated: list[bool] = field(default_factory=list)
    steps: int = 0
    iterations: int = 0
    #: Steps whose Newton failed and that were taken as two half steps instead.
    halvings: int = 0
    #: The longest step taken [s].
    largest_step: float = 0.0
    #: Under error control (rodsim/solvers/physical/error_control.py): the steps accepted
    #: and the attempts rejected.
    accepted: int = 0
    rejected: int = 0
    success: bool = True
    message: str = "ok"
    #: (time [s], name) of every event found (rodsim/solvers/physical/events.py).
    events: list[tuple[float, str]] = field(default_factory=list)

    def add(self, t: float, motion: Motion, kinetic: float, potential: float,
            dissipated: float, work: float, interpolated: bool = False) -> None:
        self.times.append(t)
        self.interpolated.append(interpolated)
        self.states.append(motion.x.copy())
        self.kinetic.append(kinetic)
        self.potential.append(potential)
        self.dissipated.append(dissipated)
        self.work.append(work)


def potential(model: Model, x: np.ndarray) -> float:
    """V(x) [J] of ``model`` at the free coordinates ``x`` (its energy: elastic, penalty,
    gravity and the loads' potentials), NaN for a non-conservative model."""
    if not model.conservative:
        return math.nan
    return model.energy(model_state(model, x))
