"""The archive Dataset of one run (docs/archive.md).

All rods' control points are concatenated along one ``node`` dimension, with the coordinate
``rod`` naming the rod of each node; likewise ``segment`` for quaternions. Select one rod
with ``ds.sel(node=ds.rod == "tendon", segment=ds.segment_rod == "tendon")``. The resolved
scene is one JSON attribute (``scene_json``); the provenance attributes (CF ``Conventions``,
``history``, versions, git commit) are ``rodsim.io.provenance.archive_attributes``'.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.core.tendon_friction import SLIP_NAMES
from rodsim.io.archive_content import ArchiveContent
from rodsim.io.archive_schema import SCHEMA_VERSION
from rodsim.io.provenance import archive_attributes
from rodsim.solvers.result import Result

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["FRICTION_HISTORY", "actuator_variable", "contact_variables", "run_content",
           "run_dataset", "self_crossings", "slip_variables", "step_coordinate",
           "tension_coordinates", "tension_variable"]

#: The history a solve from rest assumes for tendon friction (rodsim/core/tendon_friction.py).
FRICTION_HISTORY = ("tendons pulled in from slack to their tension, monotonically (the "
                    "friction's history a solve from rest assumes)")


def run_dataset(result: Result) -> xr.Dataset:
    """The archive Dataset of one run (see the module docstring and docs/archive.md)."""
    return run_content(result).to_xarray()


def run_content(result: Result) -> ArchiveContent:
    """The archive of one run as plain values (``run_dataset`` without xarray;
    ``rodsim run`` writes it with ``rodsim.io.archive.write_content``)."""
    names = list(result.rods)
    shapes = list(result.rods.values())
    node_rod = np.concatenate([[n] * len(r.s) for n, r in zip(names, shapes, strict=True)])
    seg_rod = np.concatenate([[n] * len(r.segment_s)
                              for n, r in zip(names, shapes, strict=True)])
    content = ArchiveContent(
        data_vars={
            "position": (("node", "axis"), np.concatenate([r.positions for r in shapes]),
                         {"units": "m", "long_name": "control point position"}),
            "quaternion": (("segment", "component"),
                           np.concatenate([r.quaternions for r in shapes]),
                           {"units": "1", "long_name": "segment orientation quaternion "
                            "(q1, q2, q3 imaginary, q4 real)"}),
        },
        coords={
            "axis": ("axis", ["x", "y", "z"], {"long_name": "world axis"}),
            "component": ("component", ["q1", "q2", "q3", "q4"],
                          {"long_name": "quaternion component"}),
            "s": ("node", np.concatenate([r.s for r in shapes]),
                  {"units": "m", "long_name": "rest arc length of the control point"}),
            "rod": ("node", node_rod.astype(str), {"long_name": "rod of the control point"}),
            "segment_s": ("segment", np.concatenate([r.segment_s for r in shapes]),
                          {"units": "m", "long_name": "rest arc length of the segment "
                           "midpoint"}),
            "segment_rod": ("segment", seg_rod.astype(str),
                            {"long_name": "rod of the segment"}),
        },
    )
    if result.history.get("time"):
        content.coords.update(step_coordinate(len(result.history["time"])))
        units, meaning = result.history_time  # the integrator's (Integrator.history_time)
        time_attrs = {"units": units, "long_name": meaning}
        content.data_vars.update({
            "history_time": (("step",), np.asarray(result.history["time"], dtype=float),
                             time_attrs),
            "history_residual": (("step",), np.asarray(result.history["residual"],
                                                       dtype=float),
                                 {"units": "1", "long_name": "scaled force residual "
                                  "after each step"}),
            "history_tip": (("step", "axis"), np.asarray(result.history["tip"], dtype=float),
                            {"units": "m", "long_name": f"tip of rod {names[0]!r} after "
                             "each step"})})
    if result.scene.data.get("obstacles"):
        content.data_vars.update(_contact_variables(result))
    if result.tension_profiles:
        profiles = result.tension_profiles
        content.coords.update(tension_coordinates(
            {name: s for name, (s, _) in profiles.items()}))
        content.data_vars.update(tension_variable(
            np.concatenate([tension for _, tension in profiles.values()]), ()))
    if result.point_states:
        points = result.point_states
        coords, data = slip_variables({name: s for name, (s, _) in points.items()},
                                      np.concatenate([state for _, state in points.values()]),
                                      ())
        content.coords.update(coords)
        content.data_vars.update(data)
    content.attrs.update(_attributes(result))
    return content


def tension_coordinates(chords: dict[str, np.ndarray]) -> dict[str, Any]:
    """The ``chord`` coordinates of the tension profiles of the tendons with friction: each
    chord's rest arc length (``chord_s``, its midpoint's) and tendon (``chord_tendon``),
    tendon by tendon, actuator first."""
    names = np.concatenate([[name] * len(s) for name, s in chords.items()])
    return {
        "chord_s": (("chord",), np.concatenate(list(chords.values())),
                    {"units": "m", "long_name": "rest arc length of the tendon chord's "
                     "midpoint"}),
        "chord_tendon": (("chord",), names.astype(str), {"long_name": "tendon of the chord"}),
    }


def pulled_in_variables(pulled: dict[str, np.ndarray], leading: tuple[str, ...]
                        ) -> tuple[dict[str, Any], dict[str, Any]]:
    """(coordinates, variables) of the actuators' displacement of the tendons with friction:
    the coordinate ``friction_tendon`` (their names) and the variable ``tendon_pulled_in``
    (*leading, friction_tendon) [m], the length of tendon each actuator has drawn in since
    the first state, ℓ_0 − ℓ (ℓ the tendon's path length; docs/tendon.md, "Friction")."""
    return ({"friction_tendon": (("friction_tendon",), np.array(list(pulled), dtype=str),
                                 {"long_name": "tendon with friction"})},
            {"tendon_pulled_in": ((*leading, "friction_tendon"),
                                  np.stack(list(pulled.values()), axis=-1),
                                  {"units": "m", "long_name": "tendon drawn in at the "
                                   "actuator since the first state (its path's shortening)"})})


def actuator_variable(tension: np.ndarray, leading: tuple[str, ...]) -> dict[str, Any]:
    """The archive variable ``tendon_actuator_tension`` (*leading, friction_tendon) [N]:
    each tendon with friction's tension at its actuator, the scene's under tension control,
    the outcome under displacement control (docs/tendon.md, "Friction")."""
    return {"tendon_actuator_tension": ((*leading, "friction_tendon"), tension,
                                        {"units": "N", "long_name": "tendon tension at the "
                                         "actuator (friction)"})}


def tension_variable(tension: np.ndarray, leading: tuple[str, ...]) -> dict[str, Any]:
    """The archive variable ``tension_profile`` (*leading, chord) [N]: the tension each
    chord of a tendon with friction carries (docs/tendon.md, "Friction")."""
    return {"tension_profile": ((*leading, "chord"), tension,
                                {"units": "N", "long_name": "tendon tension along its path "
                                 "(friction), one value per chord"})}


def slip_variables(points: dict[str, np.ndarray], states: np.ndarray,
                   leading: tuple[str, ...]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(coordinates, variables) of the stick/slip states of the tendons with friction: the
    coordinate ``chord_point_s`` (rest arc length of the routing point at each chord's
    start, whose turn the state is about) and the variable ``slip_state``
    (*leading, chord), int8 with the CF ``flag_values`` / ``flag_meanings`` of
    ``SLIP_NAMES`` (rodsim/core/tendon_friction.py)."""
    return ({"chord_point_s": (("chord",), np.concatenate(list(points.values())),
                               {"units": "m", "long_name": "rest arc length of the routing "
                                "point at the tendon chord's start"})},
            {"slip_state": ((*leading, "chord"), np.asarray(states).astype(np.int8),
                            {"long_name": "stick/slip state of the routing point at the "
                             "chord's start (friction): the tendon sliding in over it "
                             "(toward the actuator), stuck, or sliding out",
                             "flag_values": np.array(list(SLIP_NAMES), dtype=np.int8),
                             "flag_meanings": " ".join(SLIP_NAMES.values())})})


def _contact_variables(result: Result) -> dict[str, Any]:
    """Contact force on every control point (zero on rods no obstacle acts on) and their
    resultant, for a scene with obstacles (docs/contact.md)."""
    from rodsim.core.model import Model
    from rodsim.core.terms.contact import contact_forces

    model = Model(result.scene, "numpy")
    stacked = contact_forces(model, model.full(result.state))
    assert stacked is not None  # called for a scene with obstacles only
    return contact_variables(stacked, ())


def contact_variables(force: np.ndarray, leading: tuple[str, ...]) -> dict[str, Any]:
    """The archive variables ``contact_force`` (*leading, node, axis) and
    ``contact_resultant`` (*leading, axis) [N] of contact forces ``force`` (a run's, or a
    track's per step with ``leading = ("step",)``)."""
    return {
        "contact_force": ((*leading, "node", "axis"), force,
                          {"units": "N", "long_name": "contact force on the control point "
                           "(every obstacle)"}),
        "contact_resultant": ((*leading, "axis"), force.sum(axis=-2),
                              {"units": "N", "long_name": "sum of the contact forces on "
                               "every control point"}),
    }


def step_coordinate(steps: int, long_name: str = "integrator step") -> dict[str, Any]:
    """The ``step`` coordinate of a history, 0, 1, … (so that every dimension has one)."""
    return {"step": (("step",), np.arange(steps, dtype=np.int64),
                     {"units": "1", "long_name": long_name})}


def self_crossings(result: Result) -> list[str]:
    """One line per rod of ``result`` that passes through itself
    (rodsim/core/self_crossing.py)."""
    from rodsim.core.self_crossing import self_crossing

    lines = []
    for name, rod in result.rods.items():
        found = self_crossing(rod.positions, float(result.scene.data["rods"][name]["radius"]))
        if found is not None:
            lines.append(found.text(name))
    return lines


def _attributes(result: Result) -> dict[str, Any]:
    attrs: dict[str, Any] = {
        "title": f"rodsim run of scene {result.scene.name!r} with the {result.integrator} "
                 "integrator",
        **archive_attributes(f"rodsim.solve(scene {result.scene.name!r}, "
                             f"integrator={result.integrator!r})"),
        "rodsim_version": result.version,
        "schema_version": SCHEMA_VERSION,
        "integrator": result.integrator,
        "integrator_options": json.dumps(result.options, sort_keys=True),
        "success": int(result.success),
        "message": result.message,
        "residual": float(result.residual),
        "solver_tolerance": float(result.scene.solver.tolerance),
        "quaternion_norm_error": result.quaternion_norm_error,
        "scene_json": result.scene.to_json(),
        "scene_toml": result.scene.source,
    }
    if result.stability is not None:
        attrs["stable"] = int(result.stability.stable)
        attrs["stiffness_min_eigenvalue"] = float(result.stability.min_eigenvalue)
        if result.stability.neutral:  # rodsim/core/stability.py, "Neutral states"
            attrs["stiffness_neutral_modes"] = int(result.stability.neutral_modes)
            attrs["stiffness_neutral_tolerance"] = float(result.stability.tolerance)
    crossings = self_crossings(result)
    if crossings:  # rodsim/core/self_crossing.py: no self-contact, so flagged
        attrs["self_crossing"] = "; ".join(crossings)
    if result.penalty_error is not None:
        attrs["penalty_error"] = float(result.penalty_error)
    if result.discretisation_error is not None:
        attrs["discretisation_error"] = float(result.discretisation_error)
    if result.tendon_compression:
        attrs["tendon_compression"] = json.dumps(result.tendon_compression, sort_keys=True)
    if result.tension_profiles:
        attrs["friction_history"] = FRICTION_HISTORY
    if result.tendon_tension:
        attrs["tendon_tension"] = json.dumps(result.tendon_tension, sort_keys=True)
    for key, value in result.stats.items():
        attrs[f"stats_{key}"] = float(value)
    return attrs
