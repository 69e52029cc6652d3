"""The one atomic write of the package: a file is written to a temporary in its folder and
renamed over its target only when complete (``os.replace`` is atomic on POSIX), so a failed,
interrupted or crashed write never leaves a partial file, nor clobbers an older one, nor
leaves its temporary behind. Used by the archives (``rodsim.io.archive``), the study's
point records (``rodsim.app.study_runner``) and the figures
(``rodsim.app.figures.writer``).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

__all__ = ["write_atomic", "write_text_atomic"]

T = TypeVar("T")


def write_atomic(path: Path, write: Callable[[Path], None], *, prefix: str | None = None,
                 follow_umask: bool = False,
                 before_replace: Callable[[], T] | None = None) -> T | None:
    """Write ``path`` through ``write(temporary)`` and an ``os.replace`` onto ``path``.

    The temporary is made by ``tempfile.mkstemp`` in ``path``'s folder, named
    ``prefix…tmp`` (default ``.<name>.``); it is created with mode 0600, or with the umask's
    mode for an ordinary file when ``follow_umask``. ``before_replace`` is called after the
    write and just before the rename; its value is returned. Any exception (an interrupt
    too) removes the temporary and propagates unchanged: the caller words the error."""
    folder = path.parent if str(path.parent) else Path(".")
    handle, name = tempfile.mkstemp(prefix=prefix or f".{path.name}.", suffix=".tmp",
                                    dir=folder)
    temporary = Path(name)
    try:
        os.close(handle)
        if follow_umask:
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(temporary, 0o666 & ~umask)
        write(temporary)
        seen = before_replace() if before_replace is not None else None
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise
    return seen


def write_text_atomic(path: Path, text: str) -> None:
    """``write_atomic`` of a UTF-8 text, synced to the disk before the rename."""

    def write(temporary: Path) -> None:
        with open(temporary, "w", encoding="utf-8") as stream:
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())

    write_atomic(path, write)
