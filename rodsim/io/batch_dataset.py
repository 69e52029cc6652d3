"""The batch archive's layout (``kind = "batch"``, docs/batch.md): the equilibria of many
cases of one scene along a ``case`` dimension, with the study archive's conventions (a
``status`` flag and a ``message`` per case, NaN where a case failed, the statistics of
``rodsim.io.statistics.POINT_STATS``) and the track archive's shapes (``position`` and
``quaternion`` concatenated over the rods, each case's value of every key a variable along
``case`` named as ``rodsim.io.cf_layout.variable_name`` names it). Built from the chunk
records the batch runner keeps (rodsim/app/batch.py); ``check_chunk_record`` checks a
record of the parts folder before a resumed batch trusts it."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr

from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.io.archive_schema import SCHEMA_VERSION, STATUS, ArchiveSchemaError
from rodsim.io.cf_layout import variable_name
from rodsim.io.provenance import archive_attributes
from rodsim.io.statistics import POINT_STAT_DOCS, POINT_STATS

__all__ = ["batch_dataset", "check_chunk_record"]


def batch_dataset(scene: Scene, integrator: str, keys: Sequence[Any], values: np.ndarray,
                  records: list[dict[str, Any]], model: Model, call: str,
                  warm: bool = False, penalty: bool = False) -> xr.Dataset:
    """One Dataset for the batch from one record per case (in case order). ``keys`` are the
    cases' ``rodsim.app.inverse.parameter_keys.NumericKey`` (their ``name`` and
    ``unit`` are read), ``values`` the (cases, keys) table, ``model`` the base scene's
    (its rods give the node and segment coordinates); ``call`` the history's words;
    ``warm``: the cases were warm-started (attribute ``warm_starts`` 1, else 0;
    rodsim/app/batch_warm.py); ``penalty``: the records carry each case's penalty estimate
    (variable ``penalty_error``, attribute ``penalty_estimates`` 1; rodsim/app/batch_penalty.py)."""
    from rodsim.solvers import registered_integrators

    count = len(records)
    rods = model.rods
    node_rod = np.concatenate([[name] * rod.nodes for name, rod in rods.items()])
    seg_rod = np.concatenate([[name] * (rod.nodes - 1) for name, rod in rods.items()])
    status = np.full(count, STATUS["error"], dtype=np.int8)
    message = np.full(count, "", dtype=object)
    position = np.full((count, len(node_rod), 3), np.nan)
    quaternion = np.full((count, len(seg_rod), 4), np.nan)
    optional = ("penalty_error",) if penalty else ()
    scalars = {k: np.full(count, np.nan) for k in ("residual", "quaternion_norm_error",
                                                  "stable", "stiffness_min_eigenvalue",
                                                  *optional, *POINT_STATS)}
    for case, record in enumerate(records):
        status[case], message[case] = record["status"], record["message"]
        for key in ("residual", "quaternion_norm_error", "stable", "stiffness_min_eigenvalue",
                    *optional):
            if record.get(key) is not None:
                scalars[key][case] = record[key]
        for key in POINT_STATS:
            if "stats" in record:
                scalars[key][case] = record["stats"][key]
        if "position" in record:
            position[case] = record["position"]
            quaternion[case] = record["quaternion"]
    coords: dict[str, Any] = {
        "case": ("case", np.arange(count), {"units": "1", "long_name": "case (row of the "
                                            "cases table)"}),
        "axis": ("axis", ["x", "y", "z"], {"long_name": "world axis"}),
        "component": ("component", ["q1", "q2", "q3", "q4"],
                      {"long_name": "quaternion component"}),
        "s": ("node", np.concatenate([r.geometry.node_s for r in rods.values()]),
              {"units": "m", "long_name": "rest arc length of the control point"}),
        "rod": ("node", node_rod.astype(str), {"long_name": "rod of the control point"}),
        "segment_s": ("segment", np.concatenate([r.geometry.segment_s for r in rods.values()]),
                      {"units": "m", "long_name": "rest arc length of the segment midpoint"}),
        "segment_rod": ("segment", seg_rod.astype(str), {"long_name": "rod of the segment"}),
    }
    data: dict[str, Any] = {
        "status": ("case", status, {"units": "1", "long_name": "case status",
                                    "flag_values": np.array(list(STATUS.values()),
                                                            dtype=np.int8),
                                    "flag_meanings": " ".join(STATUS)}),
        "message": ("case", message.astype(str),
                    {"long_name": "solver message of the case, or why it failed"}),
        "position": (("case", "node", "axis"), position,
                     {"units": "m", "long_name": "control point position (NaN: failed case)"}),
        "quaternion": (("case", "segment", "component"), quaternion,
                       {"units": "1", "long_name": "segment orientation quaternion (q1, q2, "
                        "q3 imaginary, q4 real; NaN: failed case)"}),
    }
    docs = {
        "residual": ("1", "final scaled force residual"),
        "quaternion_norm_error": ("1", "largest | |q| - 1 |"),
        "stable": ("1", "1 if the case's equilibrium is stable, 0 if not (NaN: failed case "
                        "or no verdict)"),
        "stiffness_min_eigenvalue": ("1", "smallest eigenvalue of the stiffness of an "
                                          "unstable case (NaN where stable)"),
        "penalty_error": ("1", "estimated penalty error of the case's equilibrium in units of "
                               "the longest rod's length L, from a warm static re-solve with "
                               "every penalty x10, as rodsim run's (0: no penalty in the "
                               "scene; NaN: failed case or failed re-solve)"),
        **POINT_STAT_DOCS,
    }
    for key, array in scalars.items():
        units, long_name = docs[key]
        data[key] = ("case", array, {"units": units, "long_name": long_name})
    for column, key in enumerate(keys):
        data[variable_name(key.name)] = ("case", np.asarray(values[:, column], dtype=float),
                                         {"units": key.unit, "scene_key": key.name,
                                          "long_name": f"value of {key.name} in the case"})
    ds = xr.Dataset(data, coords)
    options = registered_integrators()[integrator].options_of(scene)
    ds.attrs.update({
        "title": f"rodsim batch of scene {scene.name!r}: {count} cases",
        "kind": "batch",
        **archive_attributes(call),
        "schema_version": SCHEMA_VERSION,
        "integrator": integrator,
        "integrator_options": json.dumps(dataclasses.asdict(options), sort_keys=True),
        "case_keys": json.dumps([key.name for key in keys]),
        "cases": count,
        "failed_cases": int(np.sum(status != STATUS["ok"])),
        "warm_starts": int(warm),
        "penalty_estimates": int(penalty),
        "solver_tolerance": float(scene.solver.tolerance),
        "scene_json": scene.to_json(),
        "scene_toml": scene.source,
    })
    return ds


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def check_chunk_record(record: Any, shape: tuple[int, int], stats: tuple[str, ...],
                       cases_expected: Sequence[int] | None = None) -> None:
    """Check one chunk record of a batch's parts folder (rodsim/app/batch.py writes them)
    for a scene of ``shape`` = (control points, segments): its cases in order (those of
    ``cases_expected``, default ``start`` to ``end``: a warm batch's chunk holds positions
    of its solve order), each with a status and a message, a successful one with finite
    positions and quaternions of that shape; ArchiveSchemaError otherwise."""
    if not isinstance(record, dict):
        raise ArchiveSchemaError("not a JSON object")
    start, end, cases = record.get("start"), record.get("end"), record.get("cases")
    if not (isinstance(start, int) and isinstance(end, int) and isinstance(cases, list)):
        raise ArchiveSchemaError("no start, end and cases")
    expected = list(range(start, end)) if cases_expected is None else list(cases_expected)
    if [c.get("case") if isinstance(c, dict) else None for c in cases] != expected:
        raise ArchiveSchemaError(f"its cases are not {start} to {end - 1}"
                                 if cases_expected is None else
                                 f"its cases are not those of positions {start} to {end - 1} "
                                 "of the solve order")
    for case in cases:
        if case.get("status") not in STATUS.values() or isinstance(case.get("status"), bool):
            raise ArchiveSchemaError(f"case {case['case']}: status is not one of "
                                     + ", ".join(map(str, STATUS.values())))
        if not isinstance(case.get("message"), str):
            raise ArchiveSchemaError(f"case {case['case']}: message is not text")
        if "stats" in case and not (isinstance(case["stats"], dict) and all(
                _number(case["stats"].get(k)) for k in stats)):
            raise ArchiveSchemaError(f"case {case['case']}: stats lack a statistic")
        if case["status"] != STATUS["ok"]:
            continue
        for key, rows, width in (("position", shape[0], 3), ("quaternion", shape[1], 4)):
            try:
                array = np.asarray(case[key], dtype=float)
            except (KeyError, TypeError, ValueError):
                raise ArchiveSchemaError(f"case {case['case']}: no {key}") from None
            if array.shape != (rows, width) or not np.all(np.isfinite(array)):
                raise ArchiveSchemaError(f"case {case['case']}: {key} is not {rows} × "
                                         f"{width} finite numbers")
        for key in ("residual", "quaternion_norm_error"):
            if not _number(case.get(key)):
                raise ArchiveSchemaError(f"case {case['case']}: {key} is not a number")
        if case.get("penalty_error") is not None and not _number(case["penalty_error"]):
            raise ArchiveSchemaError(f"case {case['case']}: penalty_error is not a number")
