"""Rules for names a scene gives: the scene's ``name`` becomes a file name, rod names become
parts of dotted keys (``rods.<rod>.nodes``).

- A scene name is a plain file-name stem: one line of letters, digits, ``_``, ``-``, ``.``
  and ``+``, starting with a letter, digit or ``_``, at most ``MAX_NAME_LENGTH``
  characters. ``rodsim run`` writes ``<name>-<integrator>.nc`` in the current folder by
  default; a name with a ``/``, ``..``, a NUL or a newline could write elsewhere or break
  the one-line messages.
- A rod or tendon name follows the same rule without ``.`` (a dot would split its dotted
  keys: ``rods.a.b.nodes``).
"""

from __future__ import annotations

import re

from rodsim.core.schema import SceneError, shown

__all__ = ["MAX_NAME_LENGTH", "check_scene_name", "check_rod_name"]

#: Longest name accepted (``<name>-<integrator>.nc`` then fits in any file system's 255).
MAX_NAME_LENGTH = 100

_STEM = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*")
_ROD = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_+-]*")


def check_scene_name(name: object) -> str:
    """The scene's ``name`` if it is a plain file-name stem, else ``SceneError``."""
    if not isinstance(name, str) or not _STEM.fullmatch(name) or len(name) > MAX_NAME_LENGTH:
        raise SceneError(f"name = {shown(name)}: not a plain file-name stem; allowed: up to "
                         f"{MAX_NAME_LENGTH} letters, digits, '_', '-', '.' and '+', starting "
                         "with a letter, digit or '_' (it names the default archive)")
    return name


def check_rod_name(name: object, table: str, what: str = "rod") -> str:
    """A rod's (or tendon's, obstacle's, support's: ``what``) name in ``[<table>.<name>]``,
    else ``SceneError``."""
    if not isinstance(name, str) or not _ROD.fullmatch(name) or len(name) > MAX_NAME_LENGTH:
        raise SceneError(f"{table}.{shown(name)}: not a valid {what} name; allowed: up to "
                         f"{MAX_NAME_LENGTH} letters, digits, '_', '-' and '+', starting "
                         "with a letter, digit or '_' (no '.': it separates scene keys)")
    return name
