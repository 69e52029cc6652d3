"""The contract of a study's point record (docs/archive.md, "The parts folder"): what each
``point-<i>-<j>….json`` file of a parts folder must hold before a resumed study trusts it.

``check_point_record`` raises ``ArchiveSchemaError`` with a one-line message naming what is
wrong; the study then runs that point again (``rodsim.app.study_parts``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.io.archive_schema import ERROR_ESTIMATES, STATUS, ArchiveSchemaError, finite_number

__all__ = ["check_point_record"]


def _number(value: Any) -> bool:
    """A number, NaN allowed (statistics an integrator cannot count are NaN)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def check_point_record(record: Any, sigma_points: int, rods: list[str],
                       stats: tuple[str, ...]) -> None:
    """Check one point record of a study's parts folder (as ``rodsim.app.study.
    evaluate_point`` writes it) for a study spec with ``sigma_points`` samples of σ, whose
    scene has ``rods`` and whose records carry the statistics ``stats``. A successful point
    must hold finite numbers of the right shapes; a failed one, its status and message."""

    if not isinstance(record, dict):
        raise ArchiveSchemaError("not a JSON object")
    for key in ("index", "status", "message"):
        if key not in record:
            raise ArchiveSchemaError(f"no {key!r}")
    index = record["index"]
    if not isinstance(index, list) or not all(
            isinstance(i, int) and not isinstance(i, bool) for i in index):
        raise ArchiveSchemaError("index is not a list of whole numbers")
    if record["status"] not in STATUS.values() or isinstance(record["status"], bool):
        raise ArchiveSchemaError(f"status {str(record['status'])[:20]!r} is not one of "
                                 + ", ".join(map(str, STATUS.values())))
    if not isinstance(record["message"], str):
        raise ArchiveSchemaError("message is not text")
    if "residual" in record and not _number(record["residual"]):
        raise ArchiveSchemaError("residual is not a number")
    if "stats" in record:
        recorded = record["stats"]
        if not isinstance(recorded, dict) or not all(
                key in recorded and _number(recorded[key]) for key in stats):
            raise ArchiveSchemaError("stats lack a statistic or hold a non-number")
    if record["status"] != STATUS["ok"]:
        return
    for key in ("residual", "stats", "quaternion_norm_error", "tip", "centerline"):
        if key not in record:
            raise ArchiveSchemaError(f"a successful point without {key!r}")
    for key in ("residual", "quaternion_norm_error", "tip_error", "area_error"):
        if key in record and not finite_number(record[key]):
            raise ArchiveSchemaError(f"{key} is not a finite number")
    for key in ERROR_ESTIMATES:  # optional (a record of an older rodsim has none); NaN: none
        if key in record and not _number(record[key]):
            raise ArchiveSchemaError(f"{key} is not a number")
    if "stable" in record and record["stable"] not in (0, 1):
        raise ArchiveSchemaError("stable is not 0 or 1")
    if "stiffness_min_eigenvalue" in record and not _number(record["stiffness_min_eigenvalue"]):
        raise ArchiveSchemaError("stiffness_min_eigenvalue is not a number")
    for key, shape in (("tip", (3,)), ("centerline", (sigma_points, 3))):
        stored = record[key]
        if not isinstance(stored, dict) or sorted(stored) != sorted(rods):
            raise ArchiveSchemaError(f"{key} does not name the scene's rods")
        for rod, values in stored.items():
            try:
                array = np.asarray(values, dtype=float)
            except (TypeError, ValueError):
                raise ArchiveSchemaError(f"{key} of rod {rod!r} is not numbers") from None
            if array.shape != shape or not np.all(np.isfinite(array)):
                raise ArchiveSchemaError(f"{key} of rod {rod!r} is not {shape} finite numbers")
    _check_history(record)


def _check_history(record: dict[str, Any]) -> None:
    """The optional per-step history: times, tips (steps × 3) and errors of equal length."""
    if not any(key in record for key in ("history_time", "history_tip", "history_error")):
        return
    shapes = {}
    for key in ("history_time", "history_tip", "history_error"):
        try:
            shapes[key] = np.asarray(record.get(key, []), dtype=float).shape
        except (TypeError, ValueError):
            raise ArchiveSchemaError(f"{key} is not numbers") from None
    steps = shapes["history_time"]
    if len(steps) != 1 or shapes["history_tip"] not in ((steps[0], 3), (0,)) or (
            shapes["history_error"] not in (steps, (0,))):
        raise ArchiveSchemaError("history_time, history_tip and history_error do not have "
                                 "one entry per step")
