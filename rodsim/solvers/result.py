"""What one run of one integrator returns: the state of each rod where it stopped (the
equilibrium, or the state at the end time), the statistics, the per-step history, the
trajectory when one was recorded, and the stability verdict of an equilibrium. Its archive
Dataset is ``rodsim.io.run_dataset.run_dataset``, also ``Result.to_xarray()``: the archive is
the io layer's, above the solvers (docs/architecture.md), so the entry points
(``rodsim.app.api``, which ``rodsim.solve``, ``solve_many``, ``modes``, ``track`` and
``simulate`` import) hand the maker in with ``use_archive_maker``."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.core.scene import Scene
from rodsim.core.terms.base import TendonTerm
from rodsim.solvers.summary import millimetres, sketch_svg, summary_html, summary_text
from rodsim.version import __version__

if TYPE_CHECKING:
    from rodsim.core.model import Model
    from rodsim.core.stability import Stability
    from rodsim.solvers.trajectory import Trajectory

__all__ = ["Result", "RodShape", "STAT_DOCS", "count_text", "use_archive_maker"]

#: The function that makes a Result's archive Dataset (``Result.to_xarray``), handed in by
#: the layer that writes archives (``use_archive_maker``); empty until then.
_ARCHIVE_MAKER: list[Callable[[Result], Any]] = []


def use_archive_maker(make: Callable[[Result], Any]) -> None:
    """Make ``Result.to_xarray`` return ``make(result)`` (``rodsim.app.api`` hands in
    ``rodsim.io.run_dataset.run_dataset``, imported on first use)."""
    _ARCHIVE_MAKER[:] = [make]

#: Statistics every run reports (missing ones are 0; NaN where an integrator cannot count
#: them: CVODE's and IDA's own Newton iterations and linear solves happen inside SUNDIALS,
#: and scikit-sundae does not report them), with their meaning.
STAT_DOCS = {
    "steps": "integrator steps (time steps or load steps)",
    "newton_iters": "Newton iterations (nonlinear solver iterations)",
    "force_evals": "evaluations of F(x) (RHS / residual evaluations)",
    "jacobian_evals": "evaluations of the analytic Jacobian",
    "linear_solves": "sparse or band linear solves",
    "wall_time": "wall time to equilibrium [s]",
    "effective_tolerance": "residual tolerance used: the requested one, or the model's "
                           "round-off floor if higher",
}


def count_text(value: float) -> str:
    """A statistic for display: the integer, or ``n/a`` when it was not counted (NaN)."""
    return "n/a" if np.isnan(value) else str(int(value))


@dataclass(frozen=True)
class RodShape:
    """Equilibrium of one rod: control points (N, 3) [m], quaternions (N − 1, 4), rest s [m]."""

    positions: np.ndarray
    quaternions: np.ndarray
    s: np.ndarray
    segment_s: np.ndarray

    @property
    def tip(self) -> np.ndarray:
        return self.positions[-1]


@dataclass
class Result:
    """One run of one integrator on one scene.

    ``positions`` gives a rod's centerline; ``rodsim.io.run_dataset.run_dataset``
    the archive Dataset. ``repr`` is a summary of at most ten lines, and Jupyter shows it as
    a table (``_repr_html_``).
    """

    scene: Scene
    integrator: str
    options: dict[str, Any]
    success: bool
    message: str
    residual: float
    stats: dict[str, float]
    rods: dict[str, RodShape]
    #: The model's free coordinates at the result: offsets from the rest state
    #: (:meth:`rodsim.core.model.Model.full` gives the positions and quaternions; ``rods``
    #: holds them), a warm start (``initial_state``) for the same scene.
    state: np.ndarray
    history: dict[str, list[float]] = field(default_factory=dict)
    #: Units and meaning of ``history["time"]``, supplied by the integrator (pseudo-time in s,
    #: or the load fraction of a load-stepping method).
    history_time: tuple[str, str] = ("s", "pseudo-time after each step")
    version: str = __version__
    #: Stability verdict of a successful run's equilibrium (rodsim/core/stability.py); None for
    #: a failed run.
    stability: Stability | None = None
    #: A-posteriori penalty-error estimate in units of L (rodsim/app/trust.py), when made.
    penalty_error: float | None = None
    #: A-posteriori discretisation-error estimate in units of L (rodsim/app/discretisation.py),
    #: when made.
    discretisation_error: float | None = None
    #: Rod tendons found in compression: the most compressive axial force [N] of each
    #: (rodsim/app/trust.py), when checked.
    tendon_compression: dict[str, float] = field(default_factory=dict)
    #: The tension [N] each tendon under displacement control ends with
    #: (rodsim/core/terms/tendon_string_displacement.py): an outcome, not an input.
    tendon_tension: dict[str, float] = field(default_factory=dict)
    #: The states over time the run recorded (:class:`~rodsim.solvers.trajectory.Trajectory`:
    #: times, states, each rod's positions at each time), when its ``SaveAt`` asked for
    #: them (:mod:`rodsim.solvers.recorder`); None otherwise.
    trajectory: Trajectory | None = None
    #: With friction (rodsim/core/tendon_friction.py): each such tendon's (rest arc length of
    #: each chord's midpoint [m], chord tension [N]), actuator first.
    tension_profiles: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    #: With friction: each such tendon's (rest arc length of the routing point at each
    #: chord's start [m], its stick/slip state: −1 sliding in, 0 stuck, +1 sliding out).
    point_states: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    @classmethod
    def from_model(cls, model: Model, x: np.ndarray, *, integrator: str,
                   options: dict[str, Any], success: bool, message: str, residual: float,
                   stats: dict[str, float], history: dict[str, list[float]],
                   history_time: tuple[str, str] = ("s", "pseudo-time after each step"),
                   stability: Stability | None = None,
                   trajectory: Trajectory | None = None) -> Result:
        full = model.full(x)
        rods = {
            name: RodShape(full[rod.layout.position_index], full[rod.layout.quaternion_index],
                           rod.geometry.node_s, rod.geometry.segment_s)
            for name, rod in model.rods.items()
        }
        stats = {key: float(stats.get(key, 0.0)) for key in STAT_DOCS} | {
            k: float(v) for k, v in stats.items() if k not in STAT_DOCS}
        tensions = {}
        profiles = {}
        slips = {}
        for term in model.terms:
            if isinstance(term, TendonTerm):
                tension = term.tension_outcome(full)
                if tension is not None:
                    tensions[term.tendon.name] = float(tension)
                profile = term.tension_profile(full)
                if profile is not None:
                    profiles[term.tendon.name] = profile
                states = term.point_states(full)
                if states is not None:
                    slips[term.tendon.name] = states
        return cls(model.scene, integrator, dict(options), success, message, residual, stats,
                   rods, np.array(x, dtype=float), history, history_time=history_time,
                   stability=stability, tendon_tension=tensions, tension_profiles=profiles,
                   point_states=slips, trajectory=trajectory)

    def positions(self, rod: str | None = None) -> np.ndarray:
        """Control points of ``rod`` (default: the first rod), shape (N, 3) [m]."""
        return self.rods[rod or next(iter(self.rods))].positions

    def tip(self, rod: str | None = None) -> np.ndarray:
        """Tip (last control point) of ``rod`` (default: the first rod) [m]."""
        return self.positions(rod)[-1]

    @property
    def quaternion_norm_error(self) -> float:
        """Largest | |q| − 1 | over every segment of every rod."""
        return float(max(np.max(np.abs(np.linalg.norm(r.quaternions, axis=1) - 1.0))
                         for r in self.rods.values()))

    def summary_rows(self) -> list[tuple[str, str]]:
        """The summary's rows: outcome, residual, work, rods, the first rod's tip, the
        stability verdict, and the error estimate and trajectory when there are any."""
        tolerance = self.stats.get("effective_tolerance", 0.0)
        rows = [("outcome", self.message if self.success else f"FAILED: {self.message}"),
                ("residual", f"{self.residual:.3g}"
                 + (f" (tolerance {tolerance:.3g})" if tolerance else "")),
                ("work", f"{int(self.stats.get('steps', 0))} steps, "
                 f"{count_text(self.stats.get('newton_iters', 0.0))} Newton iterations, "
                 f"{self.stats.get('wall_time', 0.0):.3g} s"),
                ("rods", ", ".join(f"{name} ({len(rod.positions)} nodes)"
                                   for name, rod in self.rods.items()))]
        if self.rods:
            rows.append((f"tip of {next(iter(self.rods))}", millimetres(self.tip())))
        if self.stability is not None:
            rows.append(("stability", "stable" if self.stability.stable else
                         f"neutral ({self.stability.neutral_text})" if self.stability.neutral
                         else f"UNSTABLE ({self.stability.eigenvalue_text})"))
        if self.penalty_error is not None:
            rows.append(("penalty error", f"{self.penalty_error:.2g} L"))
        if self.tendon_tension:
            rows.append(("tendon tension", ", ".join(
                f"{name} {value:.4g} N" for name, value in self.tendon_tension.items())))
        if self.trajectory is not None:
            rows.append(("trajectory", f"{len(self.trajectory.times)} recorded states"))
        return rows

    def _title(self) -> str:
        return f"rodsim Result: scene {self.scene.name!r}, integrator {self.integrator}"

    def __repr__(self) -> str:
        return summary_text(self._title(), self.summary_rows())

    def _repr_html_(self) -> str:
        return summary_html(self._title(), self.summary_rows(),
                            sketch_svg([rod.positions for rod in self.rods.values()]))

    def to_xarray(self) -> Any:
        """The run's archive Dataset (docs/archive.md), as ``rodsim.run_dataset(result)``
        and ``rodsim run -o RUN.nc`` write it: ``position`` (node, axis), ``quaternion``,
        the statistics, the verdict and the scene. RuntimeError when no entry point was
        imported (a Result made by the solvers alone): ``import rodsim.app.api``."""
        if not _ARCHIVE_MAKER:
            raise RuntimeError("Result.to_xarray needs rodsim's entry points: import "
                               "rodsim.app.api, or call rodsim.run_dataset(result)")
        return _ARCHIVE_MAKER[0](self)
