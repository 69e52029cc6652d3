"""Output targets: what may be written to, checked before any work starts.

Every file rodsim writes (archives, figures, benchmark results) is written through a
temporary file ``.<name>.<random>.tmp`` in the target's folder, renamed over the target when
complete. This module holds the rules shared by those writers:

- the folder must exist and accept new files (:func:`probe_folder` creates and removes a
  temporary file there, with the same name pattern as the real write: an over-long name, a
  read-only or pseudo file system fails here, before the solve or the benchmark runs);
- an existing target must be a regular file: a folder, device (``/dev/full``), socket or
  FIFO is refused rather than replaced by a regular file;
- a symbolic link is followed: the file it points to is replaced and the link stays (so a
  link into a results folder keeps working); a dangling link's target is created;
- a temporary left behind by a killed write (``kill -9``) of the same target is removed
  by the next write of that target (:func:`remove_stale_temporaries`).
"""

from __future__ import annotations

import contextlib
import os
import re
import stat
import tempfile
from pathlib import Path

__all__ = ["OutputError", "check_target", "probe_folder", "remove_stale_temporaries",
           "temporary_prefix"]

#: Characters of the random part of a ``tempfile.mkstemp`` name, and its length.
_RANDOM = r"[a-z0-9_]{8}"


class OutputError(OSError):
    """An output path cannot be written (one-line message naming the path and why)."""


def _folder(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def temporary_prefix(path: Path) -> str:
    """Prefix of the temporary files written on the way to ``path``."""
    return f".{path.name}."


def probe_folder(folder: Path, prefix: str = ".rodsim-probe.", what: str = "") -> None:
    """Raise :class:`OutputError` unless a file can be created (and removed) in ``folder``."""
    what = what or str(folder)
    try:
        is_folder = folder.is_dir()
    except (OSError, ValueError) as exc:  # a name too long, a NUL
        raise OutputError(f"cannot write {what}: {getattr(exc, 'strerror', None) or exc}") \
            from None
    if not is_folder:
        raise OutputError(f"cannot write {what}: folder {str(folder)!r} does not exist")
    try:
        handle, probe = tempfile.mkstemp(prefix=prefix, suffix=".tmp", dir=folder)
    except OSError as exc:
        raise OutputError(f"cannot write {what}: cannot create files in folder "
                          f"{str(folder)!r} ({_reason(exc)})") from None
    os.close(handle)
    with contextlib.suppress(OSError):
        os.unlink(probe)


def check_target(path: str | Path) -> Path:
    """The file to write for output ``path``, after the checks of the module docstring.

    Returns the path with symbolic links resolved (what a writer should replace); raises
    :class:`OutputError` for a non-regular existing target or an unwritable folder.
    """
    path = Path(path)
    try:
        target = Path(os.path.realpath(path)) if path.is_symlink() else path
        mode = os.stat(target).st_mode
    except FileNotFoundError:
        mode = None
    except OSError as exc:  # a name too long, a path through a file, a loop of links
        raise OutputError(f"cannot write {str(path)!r}: {_reason(exc)}") from None
    except ValueError as exc:  # a NUL in the path
        raise OutputError(f"cannot write {str(path)!r}: {exc}") from None
    if mode is not None and not stat.S_ISREG(mode):
        kind = "a folder" if stat.S_ISDIR(mode) else "not a regular file (a device, " \
                                                      "socket or FIFO)"
        raise OutputError(f"cannot write {str(path)!r}: it is {kind}; give a file name")
    probe_folder(_folder(target), temporary_prefix(target), repr(str(path)))
    return target


def remove_stale_temporaries(path: Path) -> list[Path]:
    """Remove the temporaries ``.<name>.<random>.tmp`` an interrupted write of ``path``
    left in its folder; returns what was removed. Only names of exactly that pattern are
    touched (another target's temporaries, and other files, are left alone)."""
    pattern = re.compile(re.escape(temporary_prefix(path)) + _RANDOM + r"\.tmp")
    removed = []
    with contextlib.suppress(OSError):
        for candidate in _folder(path).iterdir():
            if pattern.fullmatch(candidate.name) and candidate.is_file():
                with contextlib.suppress(OSError):
                    candidate.unlink()
                    removed.append(candidate)
    return removed
