"""The result of ``rodsim.simulate`` (rodsim/app/simulate.py; docs/dynamics.md): a
``Simulation`` holds the trajectory at the output times (positions, quaternions, the energy
account), the run's outcome and work, and writes the trajectory archive
(rodsim/io/trajectory_dataset.py) with ``to_xarray``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rodsim.core.friction_record import Breakaway, FrictionRecord, Restick
from rodsim.core.model import Model
from rodsim.core.program import ProgramEntry
from rodsim.core.scene import Scene
from rodsim.io.trajectory_dataset import StepLog
from rodsim.solvers.summary import millimetres, sketch_svg, summary_html, summary_text

__all__ = ["Simulation", "StepLog", "INTEGRATORS", "FIXED_STEP"]

#: The integrators of physical time.
INTEGRATORS = ("midpoint", "midpoint4", "paper", "ida", "cvode")
#: Those with fixed steps (``step``), no tolerances: the implicit midpoint rule, its
#: fourth-order composition (rodsim/solvers/physical/composition.py) and the paper's
#: semi-implicit Euler (Eqs. 14–17 with the physical masses). The midpoint rule
#: takes ``rtol`` (and ``atol``) too: then its steps are error-controlled
#: (rodsim/solvers/physical/error_control.py) and ``step`` is the longest.
FIXED_STEP = ("midpoint", "midpoint4", "paper")

@dataclass
class Simulation:
    """A run in physical time. ``repr`` is a summary of at most ten lines, and Jupyter
    shows it as a table (``_repr_html_``).

    Attributes
    ----------
    success, message
        Whether the run reached ``t_end``; what happened (a failure's time and advice: the
        outputs up to it are kept).
    times
        The output times [s], shape (T,).
    positions
        Every control point at each output time [m], shape (T, nodes, 3), the rods
        concatenated as in a run archive (the scene's order).
    quaternions
        Every segment's quaternion, shape (T, segments, 4).
    kinetic_energy, potential_energy, dissipated_energy, work
        At each output time [J] (docs/dynamics.md, "Energy"); the potential and the work are
        NaN for a non-conservative scene.
    energy_error
        The balance T + V + D − W − (T₀ + V₀) at each output time [J].
    step_size
        The step size [s]: the fixed step asked for (midpoint, paper: the steps taken are
        at most this); IDA's and CVODE's, and the error-controlled midpoint rule's, longest
        step taken. (Not ``step``: in rodsim that name steps — ``Model.step``, a tracker's
        ``step`` — and ``simulate(step=)`` is only the step asked for.)
        ``steps`` counts the steps (under error control every midpoint step solved, three
        an attempt; ``rejected`` the attempts rejected).
    iterations
        The fixed-step integrators' Newton iterations; IDA's residual evaluations (one per
        iteration of its corrector).
    """

    success: bool
    message: str
    scene: Scene
    times: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    kinetic_energy: np.ndarray
    potential_energy: np.ndarray
    dissipated_energy: np.ndarray
    work: np.ndarray
    step_size: float
    integrator: str = "midpoint"
    steps: int = 0
    iterations: int = 0
    #: Steps whose Newton failed, taken as two half steps instead.
    halvings: int = 0
    rods: tuple[str, ...] = ()
    #: The free-coordinate states at the output times (T, n), for checks.
    states: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False)
    #: The end time asked for [s].
    t_end: float = math.nan
    #: The checked programs (full key → Table or Sinusoid, the scene file's and the
    #: call's), and the starting values (text).
    program: dict[str, ProgramEntry] = field(default_factory=dict)
    initial: str = "rest state"
    #: (time [s], name) of every event found, in time order (docs/dynamics.md, "Events").
    events: tuple[tuple[float, str], ...] = ()
    #: With tendon friction: each tendon's chord tensions and the stick/slip states of its
    #: routing points at the output times (``FrictionRecord`` fields with a leading time
    #: axis; docs/dynamics.md, "Friction in physical time"); None without.
    friction: FrictionRecord | None = None
    #: The error-controlled midpoint rule's tolerances ("rtol = …, atol = …"; "" for
    #: fixed steps and the other integrators) and its rejected attempts.
    error_control: str = ""
    rejected: int = 0
    #: With stiction (a string tendon's static_friction above its friction): every
    #: routing point that broke loose, in time order — the located time, the tendon, the
    #: point's index and rest arc length, the way it slides from then on
    #: (``rodsim.core.friction_record.Breakaway``; docs/dynamics.md, "Friction in physical
    #: time"). Empty without stiction (a point starts sliding continuously there).
    breakaways: tuple[Breakaway, ...] = ()
    #: Under error control: each accepted step's end and length, each rejected attempt's
    #: start, length and err (``rodsim.io.trajectory_dataset.StepLog``); None otherwise.
    step_log: StepLog | None = field(default=None, repr=False)
    #: With stiction: every sliding routing point that stuck again, in time order — the
    #: located time, the tendon, the point's index and rest arc length, the way it slid
    #: until then (``rodsim.core.friction_record.Restick``; docs/dynamics.md, "Friction in
    #: physical time"). Empty without stiction.
    resticks: tuple[Restick, ...] = ()
    #: Whether each output was read off the interpolant of the step that covers it (an
    #: output between step ends, docs/dynamics.md, "Outputs between steps"; IDA's and
    #: CVODE's own interpolation) rather than being a step's end state, shape (T,).
    interpolated: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool),
                                     repr=False)

    @property
    def energy_error(self) -> np.ndarray:
        total = self.kinetic_energy + self.potential_energy + self.dissipated_energy - self.work
        return total - total[0]

    def summary_rows(self) -> list[tuple[str, str]]:
        """The summary's rows: outcome, times, work, start, programs and events when there
        are any, the first rod's tip at the last output, the energy balance."""
        reached = float(self.times[-1]) if len(self.times) else 0.0
        step = ("step" if self.integrator in FIXED_STEP and not self.error_control
                else "longest step")
        rows = [("outcome", self.message if self.success else f"FAILED: {self.message}"),
                ("time", f"{len(self.times)} outputs, t = 0 to {reached:.4g} s"
                 f" (t_end {self.t_end:.4g} s)"),
                ("work", f"{self.steps} steps ({step} {self.step_size:.3g} s), "
                 f"{self.iterations} iterations"
                 + (f", {self.halvings} halved steps" if self.halvings else "")
                 + (f", error control {self.error_control}, {self.rejected} rejected"
                    if self.error_control else "")),
                ("start", self.initial)]
        if self.program:
            rows.append(("programs", ", ".join(self.program)))
        if self.events:
            rows.append(("events", ", ".join(f"{name} at {time:.4g} s"
                                             for time, name in self.events)))
        if self.breakaways:
            earliest = self.breakaways[0]
            rows.append(("breakaways", f"{len(self.breakaways)} routing points broke loose "
                         f"(stiction), the first at {earliest.time:.6g} s "
                         f"({earliest.tendon}, point {earliest.point})"))
        if self.resticks:
            stuck = self.resticks[0]
            rows.append(("re-sticks", f"{len(self.resticks)} sliding routing points stuck "
                         f"again (stiction), the first at {stuck.time:.6g} s "
                         f"({stuck.tendon}, point {stuck.point})"))
        first = self.rods[0] if self.rods else None
        if first in self.scene.rods and len(self.times):
            nodes = self.scene.rods[first].nodes
            rows.append((f"tip of {first} at the end",
                         millimetres(self.positions[-1, nodes - 1])))
        if len(self.times):
            largest = float(np.max(self.kinetic_energy))
            if np.all(np.isfinite(self.energy_error)):
                error = float(np.max(np.abs(self.energy_error)))
                rows.append(("energy", f"balance within {error:.2g} J (largest kinetic "
                             f"energy {largest:.3g} J, dissipated "
                             f"{float(self.dissipated_energy[-1]):.3g} J)"))
            else:
                rows.append(("energy", f"no balance (a non-conservative term); largest "
                             f"kinetic energy {largest:.3g} J"))
        return rows

    def _title(self) -> str:
        return (f"rodsim Simulation: scene {self.scene.name!r}, integrator "
                f"{self.integrator}")

    def __repr__(self) -> str:
        return summary_text(self._title(), self.summary_rows())

    def _repr_html_(self) -> str:
        return summary_html(self._title(), self.summary_rows(), self.sketch())

    def sketch(self) -> str:
        """The summary's sketch: the rods at the last output time, the first rod's tip path
        (faint)."""
        if not len(self.times):
            return ""
        counts = [self.scene.rods[name].nodes for name in self.rods]
        ends = np.cumsum(counts)
        shapes = [self.positions[-1, end - count:end]
                  for end, count in zip(ends, counts, strict=True)]
        return sketch_svg(shapes, [self.positions[:, int(ends[0]) - 1]])

    def to_xarray(self) -> Any:
        """The trajectory archive (rodsim/io/trajectory_dataset.py, docs/archive.md): a run
        that stopped part-way gives the times it reached, ``complete`` = 0 and its
        message."""
        from rodsim.io.trajectory_dataset import TrajectoryRecord, trajectory_dataset

        model = Model(self.scene, "numpy")
        rods = {name: (rod.geometry.node_s, rod.geometry.segment_s)
                for name, rod in model.rods.items()}
        energies = {"kinetic_energy": self.kinetic_energy,
                    "potential_energy": self.potential_energy,
                    "dissipated_energy": self.dissipated_energy, "work": self.work}
        stats = {"steps": self.steps, "iterations": self.iterations,
                 "halvings": self.halvings}
        if self.step_log is not None:
            stats.update(accepted=len(self.step_log.ends), rejected=self.rejected)
        return trajectory_dataset(TrajectoryRecord(
            self.scene, rods, self.times, self.positions, self.quaternions, energies,
            self.success, self.message, self.t_end, self.integrator, self.step_size, stats,
            {key: entry.archived() for key, entry in self.program.items()}, self.initial,
            self.events, self.friction, self.breakaways, self.step_log,
            self.error_control, self.resticks, self.interpolated))
