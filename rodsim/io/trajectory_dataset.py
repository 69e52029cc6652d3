"""The archive of ``rodsim simulate`` (docs/archive.md, "Trajectory archives"): a run in
physical time (rodsim/app/simulate.py, docs/dynamics.md).

Coordinate ``time`` [s] (the output times); ``position`` (time, node, axis) and
``quaternion`` (time, segment, component) laid out as in a run archive
(``rodsim.io.run_dataset.run_content``: the rods concatenated, coordinates ``s``,
``rod``, ``segment_s``, ``segment_rod``); ``kinetic_energy``, ``potential_energy``,
``dissipated_energy`` and ``work`` along ``time`` [J]. Attributes: ``kind`` =
``trajectory``, the provenance, ``success``, ``complete`` (0: the run stopped before
``t_end``; the times it reached are kept) and ``message``, ``t_end``, the scene, the
programs and the starting values. With tendon friction, as a track's archive per step:
``tension_profile`` and ``slip_state`` (time, chord) and the attribute ``friction_history``;
and every routing point that broke loose (stiction; none without) along ``breakaway``:
``breakaway_time`` [s] (located inside its step), ``breakaway_tendon``,
``breakaway_point`` (the point's index along its tendon, as ``slip_state``'s chords),
``breakaway_point_s`` [m] and ``breakaway_direction`` (−1 sliding in, +1 out); and every
sliding point that stuck again along ``restick``, named alike: ``restick_time`` [s],
``restick_tendon``, ``restick_point``, ``restick_point_s`` [m] and ``restick_direction`` (the
way it slid until then).
Under error control (the midpoint rule with ``rtol``), the steps (``StepLog``):
``step_end`` and ``step_size`` along ``accepted`` (each accepted step's end time and length
[s]), ``rejected_time``, ``rejected_size`` and ``rejected_error`` along ``rejected`` (each
rejected attempt's start time and length [s] and its scaled error err, inf where its
Newton failed), the attributes ``stats_accepted`` and ``stats_rejected`` and
``error_control`` (the tolerances).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.core.scene import Scene
from rodsim.io.archive_schema import SCHEMA_VERSION
from rodsim.io.provenance import archive_attributes
from rodsim.io.run_dataset import (
    FRICTION_HISTORY,
    slip_variables,
    tension_coordinates,
    tension_variable,
)

if TYPE_CHECKING:
    import xarray as xr

    from rodsim.core.friction_record import Breakaway, FrictionRecord, Restick

__all__ = ["StepLog", "TrajectoryRecord", "breakaway_variables", "restick_variables",
           "trajectory_dataset"]

#: The energy variables, their long names (docs/dynamics.md, "Energy").
ENERGIES = {
    "kinetic_energy": "kinetic energy T of the control points and segments",
    "potential_energy": "potential energy V (elastic, penalties, gravity, loads; NaN for a "
                        "non-conservative scene)",
    "dissipated_energy": "energy dissipated by the damping since t = 0",
    "work": "work done by the programs (values changing in time) since t = 0 (NaN for a "
            "non-conservative scene)",
}


@dataclass(frozen=True)
class StepLog:
    """The steps of a run under error control (rodsim/solvers/physical/error_control.py),
    in the order taken: each accepted step's end time [s] and length [s]; each rejected
    attempt's start time [s], length [s] and scaled error err (> 1; inf where its Newton
    failed)."""

    ends: np.ndarray
    sizes: np.ndarray
    rejected_times: np.ndarray
    rejected_sizes: np.ndarray
    rejected_errors: np.ndarray


@dataclass(frozen=True)
class TrajectoryRecord:
    """What a run in physical time computed, as plain arrays (the archive's content)."""

    scene: Scene
    #: Each rod's rest arc lengths (control points, segment midpoints) [m], scene order.
    rods: Mapping[str, tuple[np.ndarray, np.ndarray]]
    times: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    energies: Mapping[str, np.ndarray]
    success: bool
    message: str
    t_end: float
    integrator: str
    step_size: float
    stats: Mapping[str, float]
    #: key → [times, values] (a table) or the sinusoid's amplitude, frequency, phase,
    #: offset (rodsim/core/program.py)
    program: Mapping[str, list[list[float]] | dict[str, float]]
    initial: str
    #: (time [s], name) of each event found (docs/dynamics.md, "Events").
    events: Sequence[tuple[float, str]] = ()
    #: With tendon friction: the chord tensions and the routing points' stick/slip states
    #: at each output time (``rodsim.core.friction_record.FrictionRecord`` with a leading
    #: time axis).
    friction: FrictionRecord | None = None
    #: With stiction: every routing point that broke loose, in time order.
    breakaways: Sequence[Breakaway] = ()
    #: Under error control: its steps (None otherwise) and its tolerances (text).
    steps: StepLog | None = None
    error_control: str = ""
    #: With stiction: every sliding routing point that stuck again, in time order.
    resticks: Sequence[Restick] = ()
    #: Whether each output was read off its step's interpolant (empty: not recorded).
    interpolated: np.ndarray | None = None


def trajectory_dataset(record: TrajectoryRecord) -> xr.Dataset:
    """The trajectory archive of ``record`` (module docstring)."""
    import xarray as xr

    names = list(record.rods)
    node_s = [s for s, _ in record.rods.values()]
    segment_s = [s for _, s in record.rods.values()]
    coords: dict[str, Any] = {
        "time": ("time", np.asarray(record.times, dtype=float),
                 {"units": "s", "long_name": "physical time", "standard_name": "time"}),
        "axis": ("axis", ["x", "y", "z"], {"long_name": "world axis"}),
        "component": ("component", ["q1", "q2", "q3", "q4"],
                      {"long_name": "quaternion component"}),
        "s": ("node", np.concatenate(node_s),
              {"units": "m", "long_name": "rest arc length of the control point"}),
        "rod": ("node", np.concatenate([[n] * len(s) for n, s in zip(names, node_s,
                                                                     strict=True)]).astype(str),
                {"long_name": "rod of the control point"}),
        "segment_s": ("segment", np.concatenate(segment_s),
                      {"units": "m", "long_name": "rest arc length of the segment midpoint"}),
        "segment_rod": ("segment", np.concatenate(
            [[n] * len(s) for n, s in zip(names, segment_s, strict=True)]).astype(str),
            {"long_name": "rod of the segment"}),
    }
    data: dict[str, Any] = {
        "position": (("time", "node", "axis"), np.asarray(record.positions, dtype=float),
                     {"units": "m", "long_name": "control point position"}),
        "quaternion": (("time", "segment", "component"),
                       np.asarray(record.quaternions, dtype=float),
                       {"units": "1", "long_name": "segment orientation quaternion (q1, q2, "
                        "q3 imaginary, q4 real)"}),
    }
    for name, long_name in ENERGIES.items():
        data[name] = ("time", np.asarray(record.energies[name], dtype=float),
                      {"units": "J", "long_name": long_name})
    data["events"] = ("event", np.array([t for t, _ in record.events], dtype=float),
                          {"units": "s", "long_name": "time of the event"})
    data["event_name"] = ("event", np.array([e for _, e in record.events], dtype=str),
                          {"long_name": "what happened (contact onset: rod on obstacle; "
                           "tendon slack: tendon)"})
    if record.interpolated is not None and len(record.interpolated) == len(record.times):
        data["interpolated"] = ("time", np.asarray(record.interpolated, dtype=np.int8),
                                {"long_name": "1: the output was read off the interpolant "
                                 "of the step that covers it (an output between step "
                                 "ends); 0: a step's end state"})
    if record.steps is not None:
        data.update(_step_variables(record.steps))
    friction = record.friction
    if friction is not None:
        coords.update(tension_coordinates(friction.chords))
        data.update(tension_variable(friction.tension, ("time",)))
        point_coords, slip_data = slip_variables(friction.points, friction.slip, ("time",))
        coords.update(point_coords)
        data.update(slip_data)
    if friction is not None:
        data.update(breakaway_variables(record.breakaways))
        data.update(restick_variables(record.resticks))
    ds = xr.Dataset(data_vars=data, coords=coords)
    name = record.scene.name
    reached = float(record.times[-1]) if len(record.times) else 0.0
    ds.attrs.update({
        "title": f"rodsim simulate of scene {name!r} to t = {record.t_end:g} s with the "
                 f"{record.integrator} integrator",
        "kind": "trajectory",
        **archive_attributes(f"rodsim.simulate(scene {name!r}, t_end={record.t_end!r}, "
                             f"integrator={record.integrator!r})"),
        "schema_version": SCHEMA_VERSION,
        "integrator": record.integrator,
        "success": int(record.success),
        "complete": int(record.success and reached >= record.t_end),
        "message": record.message,
        "t_end": float(record.t_end),
        "time_step": float(record.step_size),
        "program_json": json.dumps(dict(record.program), sort_keys=True),
        "initial": record.initial,
        "scene_json": record.scene.to_json(),
        "scene_toml": record.scene.source,
    })
    if record.error_control:
        ds.attrs["error_control"] = record.error_control
    if friction is not None:
        ds.attrs["friction_history"] = (f"t = 0: the start's equilibrium, {FRICTION_HISTORY}; "
                                        "then each time step from the one before")
    for key, value in record.stats.items():
        ds.attrs[f"stats_{key}"] = float(value)
    return ds


def breakaway_variables(found: Sequence[Breakaway]) -> dict[str, Any]:
    """The variables along ``breakaway`` of the routing points that broke loose (module
    docstring; empty along it when none did)."""
    return _point_event_variables("breakaway", found, "broke loose",
                                  "way the point slides once loose")


def restick_variables(found: Sequence[Restick]) -> dict[str, Any]:
    """The variables along ``restick`` of the sliding routing points that stuck again
    (module docstring; empty along it when none did)."""
    return _point_event_variables("restick", found, "stuck again",
                                  "way the point slid until it stuck")


def _point_event_variables(name: str, found: Sequence[Breakaway] | Sequence[Restick],
                           what: str, direction: str) -> dict[str, Any]:
    """``<name>_time``, ``_tendon``, ``_point``, ``_point_s`` and ``_direction`` along the
    dimension ``name``: one entry per routing point that ``what`` inside a step."""
    point = "sliding routing point" if name == "restick" else "routing point"
    return {
        f"{name}_time": (name, np.array([e.time for e in found], dtype=float),
                         {"units": "s", "long_name": f"time a {point} of a string tendon "
                          f"{what} (stiction), located inside its step"}),
        f"{name}_tendon": (name, np.array([e.tendon for e in found], dtype=str),
                           {"long_name": f"tendon of the routing point that {what}"}),
        f"{name}_point": (name, np.array([e.point for e in found], dtype=np.int32),
                          {"long_name": "index of the routing point along its tendon (0 "
                           "the entry; the chord it starts, as slip_state's)"}),
        f"{name}_point_s": (name, np.array([e.s for e in found], dtype=float),
                            {"units": "m", "long_name": "rest arc length of the routing "
                             f"point that {what}"}),
        f"{name}_direction": (name, np.array([e.direction for e in found], dtype=np.int8),
                              {"long_name": direction,
                               "flag_values": np.array([-1, 1], dtype=np.int8),
                               "flag_meanings": "sliding_in sliding_out"}),
    }


def _step_variables(log: StepLog) -> dict[str, Any]:
    """The error control's steps (module docstring) as the archive's variables."""
    return {
        "step_end": ("accepted", np.asarray(log.ends, dtype=float),
                     {"units": "s", "long_name": "end time of each accepted step"}),
        "step_size": ("accepted", np.asarray(log.sizes, dtype=float),
                      {"units": "s", "long_name": "length of each accepted step"}),
        "rejected_time": ("rejected", np.asarray(log.rejected_times, dtype=float),
                          {"units": "s", "long_name": "start time of each rejected attempt"}),
        "rejected_size": ("rejected", np.asarray(log.rejected_sizes, dtype=float),
                          {"units": "s", "long_name": "length of each rejected attempt"}),
        "rejected_error": ("rejected", np.asarray(log.rejected_errors, dtype=float),
                           {"units": "1", "long_name": "scaled local error err of each "
                            "rejected attempt (> 1; inf where its Newton failed)"}),
    }
