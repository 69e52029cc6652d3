"""Tracking: a sequence of equilibria along an actuation path (``rodsim track``).

Several numeric scene keys ramp together (a tendon force, a tip load, a modulus …): step k
has the values ``ramps[key][k]``. Step 0 is solved cold with the chosen integrator (from
rest); every later step is warm-started from the previous equilibrium and its registration
(rodsim/app/inverse/continuation.py). With ``static``, step k + 1 starts from the first-order
predictor x_k + (x_k − x_{k−1}) |p_{k+1} − p_k| / |p_k − p_{k−1}| (the path's last chord,
from step 2 on; as the integrator takes it, ``Integrator.predicted``: ``static`` turns
the segments as rigid frames where its retraction does) and solves from there (chord
iterations with a factorisation made at the step's start, then Newton if they stall; no
polishing past the tolerance). The path's chord is free. The
tangent predictor x_k + (dx/dp)(p_{k+1} − p_k) from the sensitivities
(rodsim/app/inverse/sensitivity.py) was measured on table3-catheter1 (201 steps of the tendon
force, 0 → 2 N, before the chord iterations): it saved about one Newton iteration per step
but cost model builds and a factorisation per ramped key, 9.7 ms per step against 5.3 ms
with no predictor and 2.2 ms with the path's chord (docs/inverse.md).

A step that fails is retried with half the increment, halved again on each failure and
doubled after an easy sub-step; at the ``MAX_HALVINGS``-th failed attempt the track
stops and reports the failure at that step (never skipped).

Every step's equilibrium gets a stability verdict (rodsim/core/stability.py): a warm start
from a straight rod stays on the straight branch past the Euler load, an equilibrium that
is not a minimum of the energy. The first unstable step stops the track (``success`` False,
``unstable_step`` names it, the arrays hold it, flagged) unless ``allow_unstable``: then
the track goes on and every step stays flagged (``stable``, ``min_eigenvalues``, and the
archive's ``stable`` and ``stiffness_min_eigenvalue`` along ``step``).

``solver.max_wall_time`` bounds the whole track (checked between steps and between the
attempts of a step; an integrator's own solve is bounded by what is left).

The archive holds every step's shape along a ``step`` dimension with the ramped values as
coordinates (docs/inverse.md). A track that stops early (a failed or unstable step, a spent
budget, or Ctrl-C / SIGTERM: ``rodsim.app.interrupted.Interrupted`` carries the steps
done) keeps its finished steps: its archive says ``complete = 0`` (docs/archive.md).
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.app.interrupted import Interrupted
from rodsim.app.inverse import track_friction, track_steps
from rodsim.app.inverse.continuation import MAX_HALVINGS, Continuation
from rodsim.app.inverse.parameter_keys import NumericKey, numeric_keys, scene_with
from rodsim.app.inverse.ramps import check_rules_across_tables, parse_ramp, ramp_values
from rodsim.app.inverse.track_steps import record_contact, record_stability, values_text
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.core.stability_tracking import NearestModes
from rodsim.io.archive_schema import SCHEMA_VERSION
from rodsim.io.cf_layout import variable_name
from rodsim.io.provenance import archive_attributes
from rodsim.io.run_dataset import (
    FRICTION_HISTORY,
    contact_variables,
    step_coordinate,
)
from rodsim.solvers import DEFAULT_INTEGRATOR, integrator_named, registered_integrators
from rodsim.solvers.base import Progress
from rodsim.solvers.result import Result

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Track", "track", "parse_ramp", "MAX_HALVINGS"]


@dataclass
class Track:
    """The equilibria of a track: ``states`` the full state (clamped coordinates included,
    which a ramped length or origin moves) of every completed step, ``positions`` (steps,
    nodes, 3) [m] and ``quaternions`` (steps, segments, 4) the same concatenated over the rods
    as in a run archive; ``values`` (steps planned, keys) the ramped values. ``success`` is
    False when a step failed: ``failed_step`` names it and the arrays hold the steps before
    it; or when a step's equilibrium is unstable (and ``allow_unstable`` was not given):
    ``unstable_step`` names it and the arrays end with it. ``stable`` and
    ``min_eigenvalues`` hold every completed step's stability verdict (the smallest
    eigenvalue of the stiffness is NaN for a stable step)."""

    scene: Scene
    integrator: str
    keys: list[NumericKey]
    values: np.ndarray
    model: Model
    states: list[np.ndarray] = field(default_factory=list)
    residuals: list[float] = field(default_factory=list)
    iterations: list[int] = field(default_factory=list)
    halvings: list[int] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    stable: list[bool] = field(default_factory=list)
    min_eigenvalues: list[float] = field(default_factory=list)
    #: With obstacles: the contact force on every control point, (nodes, 3) [N] per step.
    contact: list[np.ndarray] = field(default_factory=list)
    #: With tendon friction: the tension of every chord of those tendons, (chords,) [N] per
    #: step, and each such tendon's chords (rest arc lengths of their midpoints [m]).
    tension: list[np.ndarray] = field(default_factory=list)
    chords: dict[str, np.ndarray] = field(default_factory=dict)
    #: With tendon friction: the stick/slip state of the routing point at each chord's start
    #: (−1 sliding in, 0 stuck, +1 sliding out), (chords,) per step, and each such tendon's
    #: points (their rest arc lengths [m]).
    slip: list[np.ndarray] = field(default_factory=list)
    points: dict[str, np.ndarray] = field(default_factory=dict)
    #: With tendon friction: each such tendon's actuator tension [N] per step, in the order
    #: of ``chords`` (the ramped value under tension control, the outcome under
    #: displacement control).
    actuator: list[np.ndarray] = field(default_factory=list)
    success: bool = True
    message: str = "converged"
    failed_step: int | None = None
    unstable_step: int | None = None
    allow_unstable: bool = False
    #: The last step's penalty-error estimate [L] and compressed tendons, when assessed
    #: (track_estimates.py: the last per-step figure): archive attributes as a run's.
    penalty_error: float | None = None
    #: The last step's discretisation-error estimate in units of L (the last per-step
    #: figure, track_estimates.py): an archive attribute as a run's.
    discretisation_error: float | None = None
    tendon_compression: dict[str, float] = field(default_factory=dict)
    #: Each step's estimates [L] (track_estimates.py; rodsim.track and rodsim track make them)
    step_discretisation_error: list[float] = field(default_factory=list)
    step_penalty_error: list[float] = field(default_factory=list)
    #: The last completed step's own model (with friction: that step's anchors).
    last_model: Model | None = None
    #: Stopped by Ctrl-C or SIGTERM (:class:`rodsim.app.interrupted.Interrupted`).
    interrupted: bool = False

    @property
    def complete(self) -> bool:
        """Every planned step was solved (an archive of fewer steps is marked incomplete)."""
        return self.steps == len(self.values)

    def drop_unfinished(self) -> None:
        """Keep only the steps whose every record was made (a stop between two records of a
        step leaves the lists of different lengths)."""
        records: list[list[Any]] = [self.states, self.residuals, self.iterations,
                                    self.halvings, self.times, self.stable,
                                    self.min_eigenvalues]
        done = min(len(r) for r in records)
        for r in [*records, *(r for r in (self.contact, self.tension, self.slip, self.actuator)
                                   if r)]:
            del r[done:]

    @property
    def unstable_steps(self) -> list[int]:
        """The completed steps whose equilibrium is unstable."""
        return [k for k, stable in enumerate(self.stable) if not stable]

    @property
    def steps(self) -> int:
        """Completed steps."""
        return len(self.states)

    def _stacked(self, kind: str) -> np.ndarray:
        index = np.concatenate([getattr(rod.layout, f"{kind}_index")
                                for rod in self.model.rods.values()])
        return np.array([full[index] for full in self.states])

    @property
    def positions(self) -> np.ndarray:
        return self._stacked("position")

    @property
    def quaternions(self) -> np.ndarray:
        return self._stacked("quaternion")

    @property
    def dead_zone_steps(self) -> list[int]:
        """With tendon friction: the steps inside the backlash dead zone (docs/tendon.md,
        "Friction"; rodsim/app/inverse/track_friction.py)."""
        return track_friction.dead_zone_steps(self.values, self.tension, self.chords,
                                              self.steps)

    @property
    def pulled_in(self) -> dict[str, np.ndarray]:
        """With tendon friction: each such tendon's actuator displacement at every step
        since step 0 [m], for the loop of the actuator's tension against its displacement
        (rodsim/app/inverse/track_friction.py, ``pulled_in``)."""
        return track_friction.pulled_in(self.model, self.chords, self.states, self.tension)

    def tips(self, rod: str | None = None) -> np.ndarray:
        """Tip of ``rod`` (default: the first) at every completed step, (steps, 3) [m]."""
        layout = self.model.rods[rod or next(iter(self.model.rods))].layout
        return np.array([full[layout.position_index[-1]] for full in self.states])

    def __repr__(self) -> str:
        from rodsim.app.inverse.summaries import summary

        return summary(self, html=False)

    def _repr_html_(self) -> str:
        from rodsim.app.inverse.summaries import summary

        return summary(self, html=True)

    def to_xarray(self) -> xr.Dataset:
        """The track archive (docs/inverse.md): ``position`` (step, node, axis) and
        ``quaternion`` (step, segment, component), one coordinate per ramped key along
        ``step``, per-step residual, Newton iterations, halvings and wall time."""
        import xarray as xr

        rods = self.model.rods
        steps = self.steps
        node_rod = np.concatenate([[name] * rod.nodes for name, rod in rods.items()])
        seg_rod = np.concatenate([[name] * (rod.nodes - 1) for name, rod in rods.items()])
        coords = {
            **step_coordinate(steps, "step along the ramp"),
            "axis": ("axis", ["x", "y", "z"], {"long_name": "world axis"}),
            "component": ("component", ["q1", "q2", "q3", "q4"],
                          {"long_name": "quaternion component"}),
            "s": ("node", np.concatenate([r.geometry.node_s for r in rods.values()]),
                  {"units": "m", "long_name": "rest arc length of the control point"}),
            "rod": ("node", node_rod.astype(str), {"long_name": "rod of the control point"}),
            "segment_s": ("segment", np.concatenate([r.geometry.segment_s
                                                     for r in rods.values()]),
                          {"units": "m", "long_name": "rest arc length of the segment "
                           "midpoint"}),
            "segment_rod": ("segment", seg_rod.astype(str), {"long_name": "rod of the segment"}),
        }
        for column, key in enumerate(self.keys):
            coords[variable_name(key.name)] = (
                "step", self.values[:steps, column],
                {"units": key.unit, "long_name": f"ramped value of {key.name}",
                 "scene_key": key.name})
        size = (steps, len(node_rod), 3)
        data = {
            "position": (("step", "node", "axis"),
                         self.positions if steps else np.zeros(size),
                         {"units": "m", "long_name": "control point position"}),
            "quaternion": (("step", "segment", "component"),
                           self.quaternions if steps else np.zeros((steps, len(seg_rod), 4)),
                           {"units": "1", "long_name": "segment orientation quaternion "
                            "(q1, q2, q3 imaginary, q4 real)"}),
            "residual": ("step", np.asarray(self.residuals, dtype=float),
                         {"units": "1", "long_name": "scaled force residual of the step's "
                          "equilibrium"}),
            "iterations": ("step", np.asarray(self.iterations, dtype=float),
                           {"units": "1", "long_name": "Newton iterations (static) or "
                            "integrator steps of the step, halvings included"}),
            "halvings": ("step", np.asarray(self.halvings, dtype=float),
                         {"units": "1", "long_name": "failed attempts of the step, each "
                          "halving its increment"}),
            "wall_time": ("step", np.asarray(self.times, dtype=float),
                          {"units": "s", "long_name": "wall time of the step"}),
            "stable": ("step", np.asarray(self.stable, dtype=np.int8),
                       {"units": "1", "long_name": "1 if the step's equilibrium is stable (its "
                        "stiffness K = -dF/dx is positive definite), else 0"}),
            "stiffness_min_eigenvalue": ("step", np.asarray(self.min_eigenvalues, dtype=float),
                                         {"long_name": "smallest eigenvalue of the stiffness "
                                          "of an unstable step (NaN when stable)"}),
        }
        data.update(track_steps.estimate_variables(self.step_discretisation_error,
                                                   self.step_penalty_error, steps))
        if self.contact:
            data.update(contact_variables(np.array(self.contact), ("step",)))
        friction_coords, friction_data = track_friction.friction_variables(self, steps)
        coords.update(friction_coords)
        data.update(friction_data)
        ds = xr.Dataset(data_vars=data, coords=coords)
        warm = np.asarray(self.times[1:])
        ds.attrs.update({
            "title": f"rodsim track of scene {self.scene.name!r} with the {self.integrator} "
                     "integrator",
            "kind": "track",
            **archive_attributes(f"rodsim.track(scene {self.scene.name!r}, ramps "
                                 f"{', '.join(k.name for k in self.keys)}, integrator="
                                 f"{self.integrator!r})"),
            "schema_version": SCHEMA_VERSION,
            "integrator": self.integrator,
            "integrator_options": json.dumps(dataclasses.asdict(
                registered_integrators()[self.integrator].options_of(self.scene)),
                sort_keys=True),
            "success": int(self.success),
            "complete": int(self.complete),
            "message": self.message,
            "unstable_steps": len(self.unstable_steps),
            "allow_unstable": int(self.allow_unstable),
            "ramp_json": json.dumps({k.name: self.values[:, i].tolist()
                                     for i, k in enumerate(self.keys)}),
            "solver_tolerance": float(self.scene.solver.tolerance),
            "scene_json": self.scene.to_json(),
            "scene_toml": self.scene.source,
            "stats_steps": float(steps),
            "stats_wall_time": float(np.sum(self.times)),
            "stats_cold_wall_time": float(self.times[0]) if self.times else float("nan"),
            "stats_warm_step_mean_wall_time": float(warm.mean()) if warm.size else float("nan"),
        })
        if self.penalty_error is not None:
            ds.attrs["penalty_error"] = float(self.penalty_error)
        if self.discretisation_error is not None:
            ds.attrs["discretisation_error"] = float(self.discretisation_error)
        if self.tension:
            ds.attrs["friction_history"] = (f"step 0: {FRICTION_HISTORY}; then the track's "
                                            "path, each step from the one before")
            ds.attrs["dead_zone_steps"] = json.dumps(self.dead_zone_steps)
        if self.tendon_compression:
            ds.attrs["tendon_compression"] = json.dumps(self.tendon_compression,
                                                        sort_keys=True)
        return ds


def track(scene: Scene, ramps: Mapping[str, Sequence[float] | np.ndarray],
          integrator: str = DEFAULT_INTEGRATOR,
          *, progress: Progress | None = None, allow_unstable: bool = False,
          verdicts: bool = True) -> Track:
    """Equilibria along the path ``ramps`` (key → values, all of one length ≥ 2), step 0
    from rest and every later step warm-started from the previous one (module docstring);
    ``progress`` is called after each step with the fraction done and a status line. The
    first unstable step stops the track unless ``allow_unstable`` (module docstring);
    ``verdicts`` False skips the stability verdicts (every step "stable": a companion path).

    Raises SceneError for bad keys or values; a solver failure, a spent wall-time budget or
    an unstable step comes back as ``Track.success = False`` with the step in the message
    (the steps before it kept, ``complete`` False). A ``KeyboardInterrupt`` (Ctrl-C; the
    ``rodsim`` command turns SIGTERM into one) after step 0 is raised as
    ``rodsim.app.interrupted.Interrupted``, whose ``partial`` is the track of the steps
    done (``interrupted`` True).
    """
    from rodsim.app.api import solve

    if not isinstance(scene, Scene):
        raise SceneError(f"track needs a Scene (rodsim.load_scene), got {type(scene).__name__}")
    integrator_named(integrator)
    values = ramp_values(ramps)
    keys = numeric_keys(scene, list(ramps))
    for column, key in enumerate(keys):  # every value in range before any work
        low, high = key.bounds()
        outside = (values[:, column] < low) | (values[:, column] > high)
        if np.any(outside):
            raise SceneError(f"{key.name} = {values[outside, column][0]:g}: out of range; "
                             f"allowed: {key.allowed}")
    check_rules_across_tables(scene, keys, values)
    started = time.perf_counter()
    budget = float(scene.solver.max_wall_time)
    deadline = started + budget
    first_scene = scene_with(scene, keys, values[0])
    first = solve(first_scene, integrator)
    model = Model(first_scene)
    out = Track(scene, integrator, keys, values, model, allow_unstable=allow_unstable)
    if not first.success:
        out.success, out.failed_step = False, 0
        out.message = f"step 0 ({values_text(keys, values[0])}) failed: {first.message}"
        return out
    try:
        _walk(out, first, scene, deadline=deadline, budget=budget, started=started,
              progress=progress, judge=track_steps.stability_assess if verdicts
              else track_steps.no_verdict)
    except KeyboardInterrupt:
        out.drop_unfinished()
        if not out.steps:
            raise
        out.success, out.interrupted = False, True
        out.message = (f"interrupted (Ctrl-C or SIGTERM) after {out.steps} of {len(values)} "
                       "steps")
        raise Interrupted(out, out.message) from None
    return out


def _walk(out: Track, first: Result, scene: Scene, *, deadline: float, budget: float,
          started: float, progress: Progress | None, judge: Any) -> None:
    """Record step 0 (``first``, solved cold) and walk the later steps into ``out``
    (``track``; a stop leaves ``out`` with the steps done); ``judge``: the verdict's."""
    keys, values, model = out.keys, out.values, out.model
    integrator, allow_unstable = out.integrator, out.allow_unstable
    kind = integrator_named(integrator)
    continuation = Continuation(model, first.state, integrator, deadline=deadline)
    out.states.append(model.full(first.state))
    out.last_model = model
    record_contact(out, model)
    out.residuals.append(first.residual)
    out.iterations.append(kind.work(first.stats))
    out.halvings.append(0)
    out.times.append(time.perf_counter() - started)
    stability = first.stability or judge(model, first.state)
    if not record_stability(out, 0, stability, allow_unstable):
        return
    previous: np.ndarray | None = None  # the equilibrium before the last, for the predictor
    certified = True  # the last verdict certified K's symmetric part (assess's order)
    modes = NearestModes()  # the verdicts' eigenvectors nearest zero, step to step
    for step in range(1, len(values)):
        started = time.perf_counter()
        if started > deadline:
            out.success, out.failed_step = False, step
            out.message = (f"step {step} ({values_text(keys, values[step])}) not started: "
                           f"the wall-time budget of {budget:g} s (solver.max_wall_time) is "
                           "spent")
            return
        predictor = None
        chord = float(np.linalg.norm(values[step - 1] - values[step - 2])) if step > 1 else 0.0
        if previous is not None and continuation.takes_predictor and chord > 0.0:
            # First-order (secant) predictor: the path's last chord, scaled to this step (none
            # after a step that did not move: a constant ramp, START = STOP).
            ratio = float(np.linalg.norm(values[step] - values[step - 1])) / chord
            predictor = continuation.predicted(scene, ratio * (continuation.x - previous))
        last = continuation.x
        ok, iterations, halvings, message = continuation.walk(
            scene, keys, values[step - 1], values[step], predictor)
        if not ok:
            out.success, out.failed_step = False, step
            out.message = (f"step {step} ({values_text(keys, values[step])}) failed: "
                           f"{halvings} failed attempts, each halving the increment; last: "
                           f"{message}")
            return
        previous = last
        out.states.append(continuation.model.full(continuation.x))
        out.last_model = continuation.model
        record_contact(out, continuation.model)
        out.residuals.append(continuation.model.force_residual(continuation.model.force(
            continuation.x)))
        out.iterations.append(iterations)
        out.halvings.append(halvings)
        verdict = judge(continuation.model, continuation.x,  # part of the step's time
                         continuation.factorisation(), certified, modes)
        # The next verdict tries the certificate first only if this one was certified
        # (stable with no eigenvalue computed): the same verdicts, rodsim/core/stability.py.
        certified = verdict.stable and np.isnan(verdict.min_eigenvalue)
        out.times.append(time.perf_counter() - started)
        if not record_stability(out, step, verdict, allow_unstable):
            return
        if progress is not None:
            progress(step / (len(values) - 1), f"track: step {step}/{len(values) - 1}")
