"""A study's parts folder (``<output>.parts/``): where each finished point is kept as a
small JSON record, written atomically (``rodsim.io.atomic.write_text_atomic``), until
the study's Dataset is assembled. A folder is created complete with its marker (the spec and
the rodsim that computed its points) and is resumed only by the same spec and version."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rodsim.app.study_spec import StudyError, StudySpec, grid_points
from rodsim.io.archive_schema import ArchiveSchemaError
from rodsim.io.atomic import write_text_atomic
from rodsim.io.output import OutputError, check_target
from rodsim.io.point_record import check_point_record
from rodsim.io.provenance import git_commit, git_dirty
from rodsim.io.statistics import POINT_STATS
from rodsim.version import __version__

__all__ = ["StudyLog", "MARKER", "parts_folder", "point_file", "failure_reason", "save_text",
           "check_study_output", "spec_differences", "open_folder", "open_parts"]

#: Log callback for one-line warnings and notes (default: printed on stderr).
StudyLog = Callable[[str], None]

#: Marker file of a parts folder: the spec and the rodsim that computed its points.
MARKER = "spec.json"


def parts_folder(output: str | Path) -> Path:
    """Where the finished points of a study writing to ``output`` are kept until assembly."""
    output = Path(output)
    return output.with_name(output.name + ".parts")


def point_file(folder: Path, index: tuple[int, ...]) -> Path:
    return folder / ("point-" + "-".join(str(i) for i in index) + ".json")


def failure_reason(exc: BaseException) -> str:
    """An OSError's reason without its repeated path, other exceptions as they print."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    return str(exc) or type(exc).__name__


def save_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically and synced (``rodsim.io.atomic.
    write_text_atomic``): a crash or a full disk never leaves a partial ``path``, nor the
    temporary (StudyError)."""
    try:
        write_text_atomic(path, text)
    except Exception as exc:
        raise StudyError(f"cannot write {path}: {failure_reason(exc)}") from exc


def check_study_output(output: Path) -> None:
    """Refuse, before any point runs, an output the archive could not be written to."""
    folder = output.parent if str(output.parent) else Path(".")
    if not folder.is_dir():
        raise StudyError(f"cannot write {output}: folder {str(folder)!r} does not exist")
    if output.is_dir():
        raise StudyError(f"cannot write {output}: it is a folder; give a file name "
                         "(-o OUT.nc)")
    parts = parts_folder(output)
    if parts.exists() and not parts.is_dir():
        raise StudyError(f"cannot keep the study's points in {parts}: a file of that name "
                         "exists")
    try:  # permissions, read-only or pseudo file systems (/proc), devices: try, as the run will
        check_target(output)
    except OutputError as exc:
        raise StudyError(str(exc)) from None


def _short(value: Any, width: int = 60) -> str:
    text = json.dumps(value, sort_keys=True) if not isinstance(value, str) else repr(value)
    return text if len(text) <= width else text[:width - 1] + "…"


def _differences(old: Any, new: Any, path: str) -> list[str]:
    """Where two JSON values differ, as ``path: old → new`` lines (dicts and equal-length
    lists are compared item by item)."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for key in sorted(set(old) | set(new), key=str):
            where = f"{path}.{key}" if path else str(key)
            if key not in old:
                out.append(f"{where}: absent in the parts folder, {_short(new[key])} now")
            elif key not in new:
                out.append(f"{where}: {_short(old[key])} in the parts folder, absent now")
            else:
                out += _differences(old[key], new[key], where)
        return out
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        return [line for i, (a, b) in enumerate(zip(old, new, strict=True))
                for line in _differences(a, b, f"{path}[{i}]")]
    if old != new:
        return [f"{path}: {_short(old)} in the parts folder, {_short(new)} now"]
    return []


def spec_differences(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """What differs between two study specs, naming each key (the base scene key by key)."""
    old_scene = old.get("base_scene_json", "{}")
    new_scene = new.get("base_scene_json", "{}")
    rest = [key for key in sorted(set(old) | set(new))
            if key not in ("base_scene_json", "base_scene_toml")]
    lines = _differences({k: old[k] for k in rest if k in old},
                         {k: new[k] for k in rest if k in new}, "")
    if old_scene != new_scene:
        try:
            lines += ["base scene " + line for line in
                      _differences(json.loads(old_scene), json.loads(new_scene), "")]
        except (TypeError, ValueError):
            lines.append("base_scene_json differs")
    elif old.get("base_scene_toml") != new.get("base_scene_toml"):
        lines.append("base_scene_toml: the base scene file's text differs")
    return lines


def _marker(spec: dict[str, Any]) -> dict[str, Any]:
    return {"spec": spec, "rodsim_version": __version__, "git_commit": git_commit(),
            "git_dirty": git_dirty()}


def open_folder(folder: Path, spec: dict[str, Any], log: StudyLog, noun: str = "study"
                ) -> None:
    """Create the parts folder with its marker (``spec``, a JSON-able dict: a study's spec,
    a batch's job), or check an existing one belongs to the same ``spec`` and rodsim version
    (StudyError naming what differs, and the ``noun`` of its definition). The study's and the
    batch's (rodsim/app/batch.py)."""
    marker = folder / MARKER
    if folder.exists():
        if not marker.is_file():
            raise StudyError(f"{folder} exists but is not a rodsim study's parts folder "
                             f"(no {MARKER}); remove it or write the study elsewhere (-o)")
        try:
            stored = json.loads(marker.read_text(encoding="utf-8"))
        except RecursionError:
            raise StudyError(f"{folder}: unreadable {MARKER} (nested too deeply); remove the "
                             "folder or write the study elsewhere (-o)") from None
        except (OSError, ValueError) as exc:
            raise StudyError(f"{folder}: unreadable {MARKER} ({failure_reason(exc)}); remove the "
                             "folder or write the study elsewhere (-o)") from None
        if not isinstance(stored, dict) or not isinstance(stored.get("spec", {}), dict):
            raise StudyError(f"{folder}: {MARKER} does not hold a study spec; remove the "
                             "folder or write the study elsewhere (-o)")
        if "rodsim_version" not in stored:
            raise StudyError(f"{folder} was written by an older rodsim that did not record its "
                             f"version (rodsim_version differs: this is rodsim {__version__}); "
                             "remove it or write the study elsewhere (-o)")
        if stored["rodsim_version"] != __version__:
            raise StudyError(f"{folder} holds points computed by rodsim "
                             f"{stored['rodsim_version']}, this is rodsim {__version__} "
                             "(rodsim_version differs); remove it or write the study "
                             "elsewhere (-o)")
        differences = spec_differences(stored.get("spec", {}), spec)
        if differences:
            more = f" (and {len(differences) - 3} more)" if len(differences) > 3 else ""
            raise StudyError(f"{folder} holds points of a different {noun} definition: "
                             + "; ".join(differences[:3]) + more
                             + "; remove it or write the study elsewhere (-o)")
        commit = git_commit()
        if isinstance(stored.get("git_commit"), str) and commit and (
                stored["git_commit"] != commit):
            log(f"note: the points in {folder} were computed at git commit "
                f"{stored['git_commit'][:12]}, this rodsim is at {commit[:12]}; resuming")
    else:  # create it complete, then rename: a kill never leaves a folder without its marker
        try:
            staging = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", dir=folder.parent))
        except OSError as exc:
            raise StudyError(f"cannot create {folder}: {failure_reason(exc)}") from None
        try:
            save_text(staging / MARKER, json.dumps(_marker(spec), sort_keys=True))
            os.replace(staging, folder)
        except BaseException as exc:
            shutil.rmtree(staging, ignore_errors=True)
            if isinstance(exc, OSError):
                raise StudyError(f"cannot create {folder}: {failure_reason(exc)}") from None
            raise


def open_parts(folder: Path, spec: StudySpec,
               log: StudyLog) -> dict[tuple[int, ...], dict[str, Any]]:
    """Create the parts folder, or check it belongs to this spec and rodsim version
    (``open_folder``), and load its records (an unreadable record is reported and its
    point runs again)."""
    open_folder(folder, spec.to_dict(), log)
    grid = set(grid_points(spec))
    rods = spec.rod_names
    records = {}
    for path in sorted(folder.glob("point-*.json")):
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
            check_point_record(record, spec.sigma_points, rods, POINT_STATS)
            index = tuple(record["index"]) if isinstance(record["index"], list) else None
            if index not in grid or point_file(folder, index).name != path.name:
                raise ValueError(f"index {str(record['index'])[:40]} does not belong in "
                                 "this file")
        except (OSError, ValueError, RecursionError, ArchiveSchemaError) as exc:
            reason = "nested too deeply" if isinstance(exc, RecursionError) else failure_reason(exc)
            log(f"warning: {path} is unreadable, incomplete or invalid ({reason}); its point "
                "runs again")
            continue
        records[index] = record
    return records
