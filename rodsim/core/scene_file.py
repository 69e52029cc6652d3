"""Reading a scene file safely: a regular file of bounded size, UTF-8 text, TOML of
bounded nesting. Every problem is a ``rodsim.core.schema.SceneError`` with one line.

``rodsim run /dev/zero`` would otherwise read forever, a binary file would raise a
``UnicodeDecodeError``, and deeply nested arrays (in a file or a ``--set`` value) would
raise a ``RecursionError`` in the TOML parser.
"""

from __future__ import annotations

import os
import stat
import tomllib
from pathlib import Path
from typing import Any

from rodsim.core.schema import SceneError

__all__ = ["MAX_SCENE_BYTES", "read_scene_text", "parse_toml"]

#: Largest scene file read (the shipped ones are under 4 KiB).
MAX_SCENE_BYTES = 1 << 20


def read_scene_text(path: Path) -> str:
    """The text of the scene file ``path`` (SceneError when it is no readable scene file)."""
    try:
        # Checked before opening: opening a FIFO would wait for a writer.
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise SceneError(f"cannot read scene {str(path)!r}: not a regular file")
        with open(path, "rb") as stream:
            data = stream.read(MAX_SCENE_BYTES + 1)
    except OSError as exc:
        raise SceneError(f"cannot read scene {str(path)!r}: {exc.strerror or exc}") from None
    if len(data) > MAX_SCENE_BYTES:
        raise SceneError(f"cannot read scene {str(path)!r}: larger than "
                         f"{MAX_SCENE_BYTES // 1024} KiB (not a scene file)")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(f"cannot read scene {str(path)!r}: not UTF-8 text (byte "
                         f"{exc.start})") from None


def parse_toml(text: str, what: str) -> dict[str, Any]:
    """``text`` parsed as TOML; SceneError naming ``what`` when it is not valid TOML."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{what}: not valid TOML: {exc}") from None
    except RecursionError:
        raise SceneError(f"{what}: nested too deeply") from None
