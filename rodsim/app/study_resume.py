"""Resuming a study whose base scene names no integrator, across a change of the default.

A parts folder is resumed only by the same spec (rodsim/app/study_parts.py): the resolved
base scene is compared key by key, and the resolved scene holds the integrator a scene that
names none runs (``solver.integrator``). That default moved (a scene without obstacles that
named none ran `cvode` until round 15 and runs `static` since,
rodsim/core/integrator_default.py), so a study started before the change was refused on
resume as "a different base scene" although neither its file nor its definition changed.

Such a study resumes with the integrator its points were started with: when the stored
spec differs from the new one only in its base scene's ``solver.integrator``, the base
scene's file text is the same and names no integrator, and the new value is the one a
scene that names none resolves to now (``implicit_integrator``), the resumed run takes the
stored base scene — every point of the study then comes from one integrator, as the
archive's ``spec_json`` says — and notes it. Anything else (a file that names its
integrator, another difference, a scene built from a dict, whose text is empty) is judged
by the spec comparison as before.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

from rodsim.app.study_parts import MARKER, StudyLog, spec_differences
from rodsim.app.study_spec import StudySpec

__all__ = ["implicit_integrator", "names_integrator", "resumed_spec"]


def implicit_integrator(scene: dict[str, Any]) -> str:
    """The integrator a resolved scene ``scene`` runs when its file names none now: the
    registry's default, or ``OBSTACLE_INTEGRATOR`` for a scene with obstacles
    (rodsim/core/scene.py)."""
    from rodsim.core.integrator_default import DEFAULT_INTEGRATOR
    from rodsim.core.scene import OBSTACLE_INTEGRATOR

    return OBSTACLE_INTEGRATOR if "obstacles" in scene else DEFAULT_INTEGRATOR


def names_integrator(source: str) -> bool | None:
    """Whether the scene file text ``source`` names its integrator (``[solver]
    integrator``); None when that cannot be told (no text, or not TOML)."""
    if not source:
        return None
    try:
        solver = tomllib.loads(source).get("solver", {})
    except (tomllib.TOMLDecodeError, RecursionError):
        return None
    return isinstance(solver, dict) and "integrator" in solver


def _stored_spec(folder: Path) -> dict[str, Any] | None:
    """The spec a parts folder's marker holds, or None (no folder, an unreadable marker:
    ``open_folder`` reports those)."""
    try:
        stored = json.loads((folder / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    spec = stored.get("spec") if isinstance(stored, dict) else None
    return spec if isinstance(spec, dict) else None


def resumed_spec(folder: Path, spec: StudySpec, log: StudyLog) -> StudySpec:
    """The spec to resume the parts folder ``folder`` with: ``spec``, or ``spec`` with the
    stored base scene when the two differ only in the integrator a scene that names none
    resolved to (module docstring; ``log`` gets a note then)."""
    stored = _stored_spec(folder)
    new = spec.to_dict()
    if stored is None or stored.get("base_scene_json") == new["base_scene_json"]:
        return spec
    try:
        old_scene = json.loads(stored["base_scene_json"])
        new_scene = json.loads(new["base_scene_json"])
        old_integrator = old_scene["solver"]["integrator"]
        now = new_scene["solver"]["integrator"]
    except (KeyError, TypeError, ValueError, RecursionError):
        return spec
    if not isinstance(old_integrator, str) or names_integrator(spec.base_scene_toml) is not False \
            or now != implicit_integrator(new_scene):
        return spec
    old_scene["solver"]["integrator"] = now
    if old_scene != new_scene or spec_differences(
            stored | {"base_scene_json": new["base_scene_json"]}, new):
        return spec
    log(f"note: the points in {folder} were started when a scene that names no integrator "
        f"ran {old_integrator!r} (it runs {now!r} now); its base scene names none, so the "
        f"study resumes with {old_integrator!r} (name one in the scene to choose)")
    return StudySpec.from_dict(new | {"base_scene_json": stored["base_scene_json"]})
