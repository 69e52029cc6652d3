"""Output targets: what may be written to, checked before any work starts.

Every file rodsim writes (archives, figures, benchmark results) is written through a
temporary file ``.<name>.<random>.tmp`` in the target's folder, renamed over the target when
complete. This module holds the rules shared by those writers:

- the folder must exist and accept new files (``probe_folder`` creates and removes a
  temporary file there, with the same name pattern as the real write: an over-long name, a
  read-only or pseudo file system fails here, before the solve or the benchmark runs);
- an existing target must be a regular file: a folder, device (``/dev/full``), socket or
  FIFO is refused rather than replaced by a regular file;
- a symbolic link is followed: the file it points to is replaced and the link stays (so a
  link into a results folder keeps working); a dangling link's target is created;
- every temporary carries its owner's stamp, ``.<name>.<host>-<pid>.<random>.tmp`` (host:
  8 hex digits of a hash of the host name): a temporary is removed only by the process that
  made it, or by a later write of the same target when it is provably stale — made on this
  host by a process that no longer exists (a ``kill -9``) (``remove_stale_temporaries``).
  A live writer's temporary is never touched, so concurrent writers of one target each
  finish, and the target holds the archive of the last one to rename
  (``other_writers`` lets a writer say so).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import socket
import stat
import tempfile
from pathlib import Path

from rodsim.core.schema import shown_path

__all__ = ["OutputError", "check_target", "probe_folder", "remove_stale_temporaries",
           "temporary_prefix", "owned_prefix", "other_writers"]

#: Characters of the random part of a ``tempfile.mkstemp`` name, and its length.
_RANDOM = r"[a-z0-9_]{8}"
#: The owner stamp of a temporary: a hash of the host name and the writer's process id.
_OWNER = r"(?P<host>[0-9a-f]{8})-(?P<pid>[0-9]{1,10})\."


class OutputError(OSError):
    """An output path cannot be written (one-line message naming the path and why)."""


def _folder(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def temporary_prefix(path: Path) -> str:
    """Prefix of the temporary files written on the way to ``path`` (before the stamp)."""
    return f".{path.name}."


def _host() -> str:
    """8 hex digits naming this host (a hash: the name itself never lands in a file name)."""
    return hashlib.sha256(socket.gethostname().encode("utf-8", "replace")).hexdigest()[:8]


def owned_prefix(path: Path) -> str:
    """Prefix of this process's temporaries for ``path``: ``temporary_prefix`` and the
    owner stamp ``<host>-<pid>.`` (module docstring)."""
    return f"{temporary_prefix(path)}{_host()}-{os.getpid()}."


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists on this host (one we may not signal exists too)."""
    if pid <= 0:
        return True  # not a real owner: never provably gone
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True
    return True


def _temporaries(path: Path) -> list[tuple[Path, str, int]]:
    """(file, host, pid) of every stamped temporary of ``path`` in its folder."""
    pattern = re.compile(re.escape(temporary_prefix(path)) + _OWNER + _RANDOM + r"\.tmp")
    found = []
    with contextlib.suppress(OSError):
        for candidate in _folder(path).iterdir():
            match = pattern.fullmatch(candidate.name)
            if match:
                found.append((candidate, match["host"], int(match["pid"])))
    return found


def other_writers(path: Path) -> int:
    """How many other live processes are writing ``path`` now (their temporaries in its
    folder): more than 0 means the target will hold whichever finishes last."""
    host, me = _host(), os.getpid()
    return len({(h, pid) for _, h, pid in _temporaries(path)
                if (h, pid) != (host, me) and (h != host or _alive(pid))})


def probe_folder(folder: Path, prefix: str = ".rodsim-probe.", what: str = "") -> None:
    """Raise ``OutputError`` unless a file can be created (and removed) in ``folder``."""
    what = what or str(folder)
    try:
        is_folder = folder.is_dir()
    except (OSError, ValueError) as exc:  # a name too long, a NUL
        raise OutputError(f"cannot write {what}: {getattr(exc, 'strerror', None) or exc}") \
            from None
    if not is_folder:
        raise OutputError(f"cannot write {what}: folder {str(folder)!r} does not exist")
    stamped = f"{prefix}{_host()}-{os.getpid()}."  # removable if this process is killed here
    try:
        handle, probe = tempfile.mkstemp(prefix=stamped, suffix=".tmp", dir=folder)
    except OSError as exc:
        raise OutputError(f"cannot write {what}: cannot create files in folder "
                          f"{str(folder)!r} ({_reason(exc)})") from None
    os.close(handle)
    with contextlib.suppress(OSError):
        os.unlink(probe)


def check_target(path: str | Path) -> Path:
    """The file to write for output ``path``, after the checks of the module docstring.

    Returns the path with symbolic links resolved (what a writer should replace); raises
    ``OutputError`` for a non-regular existing target or an unwritable folder.
    """
    path = Path(path)
    try:
        target = Path(os.path.realpath(path)) if path.is_symlink() else path
        mode = os.stat(target).st_mode
    except FileNotFoundError:
        mode = None
    except OSError as exc:  # a name too long, a path through a file, a loop of links
        raise OutputError(f"cannot write {shown_path(path)}: {_reason(exc)}") from None
    except ValueError as exc:  # a NUL in the path
        raise OutputError(f"cannot write {shown_path(path)}: {exc}") from None
    if mode is not None and not stat.S_ISREG(mode):
        kind = "a folder" if stat.S_ISDIR(mode) else "not a regular file (a device, " \
                                                      "socket or FIFO)"
        raise OutputError(f"cannot write {shown_path(path)}: it is {kind}; give a file name")
    probe_folder(_folder(target), temporary_prefix(target), shown_path(path))
    return target


def remove_stale_temporaries(path: Path) -> list[Path]:
    """Remove the temporaries ``.<name>.<host>-<pid>.<random>.tmp`` of ``path`` whose
    writer is provably gone — this host's stamp and a process id that no longer exists (a
    killed write); returns what was removed. A live writer's temporary, another host's
    (its process cannot be checked from here), an unstamped name, another target's
    temporaries and other files are left alone."""
    host = _host()
    removed = []
    for candidate, owner_host, pid in _temporaries(path):
        if owner_host != host or pid == os.getpid() or _alive(pid):
            continue
        with contextlib.suppress(OSError):
            if candidate.is_file():
                candidate.unlink()
                removed.append(candidate)
    return removed
