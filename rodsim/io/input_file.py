"""Input files: what may be opened for reading (an archive, a fit's data points).

A path given to read must name a regular file (symbolic links followed) of bounded size:
a FIFO would block the reader forever, a character device such as ``/dev/zero`` never
ends, a folder or a socket cannot be read. ``check_input_file`` refuses them from the
file's status alone, before anything opens it.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from rodsim.core.schema import shown_path

__all__ = ["InputError", "check_input_file", "MAX_INPUT_BYTES"]

#: Largest input file read (an archive of a 100 000-step track of 40 nodes is ~200 MB).
MAX_INPUT_BYTES = 2 * 1024 ** 3


class InputError(OSError):
    """An input path cannot be read (one-line message naming the path and why)."""


def check_input_file(path: str | Path, what: str = "file",
                     max_bytes: int = MAX_INPUT_BYTES) -> Path:
    """``path`` as a Path once it is known to be a regular file of at most ``max_bytes``
    bytes; ``InputError`` otherwise (missing, a folder, a FIFO, a device, a socket,
    too large, a name the system refuses)."""
    named = shown_path(path)
    try:
        status = os.stat(path)
    except FileNotFoundError:
        raise InputError(f"cannot read {what} {named}: no such file") from None
    except (OSError, ValueError) as exc:  # a name too long, a NUL, a loop of links
        raise InputError(f"cannot read {what} {named}: "
                         f"{getattr(exc, 'strerror', None) or exc}") from None
    mode = status.st_mode
    if stat.S_ISDIR(mode):
        raise InputError(f"cannot read {what} {named}: it is a folder")
    if not stat.S_ISREG(mode):
        raise InputError(f"cannot read {what} {named}: not a regular file (a FIFO, device "
                         "or socket)")
    if status.st_size > max_bytes:
        raise InputError(f"cannot read {what} {named}: {status.st_size} bytes, more than "
                         f"the {max_bytes} bytes allowed")
    return Path(path)
