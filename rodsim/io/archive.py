"""netCDF archives: atomic writes and checked reads (``rodsim.app.api.rerun`` re-runs one).

A write goes to a temporary file in the target's folder and is renamed over the target
only when complete (``os.replace`` is atomic on POSIX), so a failed or interrupted write
never leaves a corrupt archive nor clobbers an existing one. The target rules (a regular
file or nothing; symbolic links followed; stale temporaries removed) are
``rodsim.io.output``'s. A read checks the archive against its contract
(``rodsim.io.archive_schema``) before returning it.
"""

from __future__ import annotations

import contextlib
import errno
import faulthandler
import math
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from rodsim.core.scene import Scene
from rodsim.core.schema import shown_path
from rodsim.io.archive_content import ArchiveContent
from rodsim.io.archive_schema import (
    READABLE_SCHEMA_VERSIONS,
    SCHEMA_VERSION,
    ArchiveSchemaError,
    check_archive,
)
from rodsim.io.atomic import write_atomic
from rodsim.io.cf_layout import file_layout, from_file, to_file
from rodsim.io.input_file import InputError, check_input_file
from rodsim.io.output import (
    OutputError,
    check_target,
    other_writers,
    owned_prefix,
    remove_stale_temporaries,
)

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["ArchiveError", "write_content", "write_dataset", "read_dataset", "scene_of"]

#: Seconds a probe read of an archive (:func:`_probe_in_child`) may take, at least; plus one
#: second per 10 MB of file.
PROBE_SECONDS = 10.0


class ArchiveError(OSError):
    """An archive cannot be written or read, or is not a rodsim archive."""


def write_dataset(dataset: xr.Dataset, path: str | Path,
                  note: Callable[[str], None] | None = None) -> Path:
    """Write ``dataset`` to ``path`` (netCDF4, by xarray) atomically; returns the path
    written (a symbolic link's target). ``note`` is told when other processes are writing
    the same target at the moment of the rename (the target then holds the last one's
    archive)."""

    def write(temporary: Path) -> None:
        # No _FillValue on coordinates (CF: a coordinate has no missing values; xarray would
        # add NaN as the fill value of every float one). An archive of the current schema
        # is stored in its CF layout (numeric index coordinates, text as characters:
        # rodsim.io.cf_layout); a Dataset of an older schema is written as it is.
        if str(dataset.attrs.get("schema_version")) == SCHEMA_VERSION:
            stored, encoding = to_file(dataset)
        else:
            stored = dataset
            encoding = {name: {"_FillValue": None} for name in dataset.coords}
        stored.to_netcdf(temporary, engine="netcdf4", encoding=encoding)

    return _write_archive(path, write, note)


def write_content(content: ArchiveContent, path: str | Path,
                  note: Callable[[str], None] | None = None) -> Path:
    """``write_dataset`` of an archive's plain content (the current schema), written by
    the netCDF4 library without importing xarray (``rodsim.io.netcdf_writer``): the
    same file as ``write_dataset(content.to_xarray(), path)`` reads back."""
    from rodsim.io.netcdf_writer import write_netcdf

    stored = file_layout(content)
    return _write_archive(path, lambda temporary: write_netcdf(stored, temporary), note)


def _write_archive(path: str | Path, write: Callable[[Path], None],
                   note: Callable[[str], None] | None) -> Path:
    """The target rules (``rodsim.io.output``) and the atomic write of an archive."""
    try:
        path = check_target(path)
    except OutputError as exc:
        raise ArchiveError(str(exc)) from None
    remove_stale_temporaries(path)
    try:  # archives follow the umask (mkstemp alone would make them 0600)
        others = write_atomic(path, write, prefix=owned_prefix(path), follow_umask=True,
                              before_replace=lambda: other_writers(path))
    except Exception as exc:
        reason = "the disk is full (no space left on the device)" if _disk_full(exc, path) \
            else str(exc)
        raise ArchiveError(f"cannot write {shown_path(path)}: {reason}") from exc
    if others and note is not None:
        note(f"{others} other process(es) were writing {shown_path(path)} at the same time: it "
             "holds the archive of whichever finished last")
    return path


def _disk_full(exc: BaseException, path: Path) -> bool:
    """Whether a failed write failed for want of space: ENOSPC or EDQUOT, or a library
    error (the HDF5 library says "HDF error") on a file system with no block left."""
    if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
        return True
    try:
        status = os.statvfs(path.parent if str(path.parent) else ".")
    except (OSError, AttributeError):
        return False
    return status.f_bavail == 0


def read_dataset(path: str | Path) -> xr.Dataset:
    """The one validating reader of archives: read an archive fully into memory (the file is
    closed on return) and check it against the archive contract. Everything that is not a
    readable, valid rodsim archive is an ``ArchiveError`` with a one-line message — a
    special file (FIFO, device, socket: refused before it is opened, so a FIFO cannot
    block), a file over ``rodsim.io.input_file.MAX_INPUT_BYTES``, damaged bytes
    (whatever the netCDF and HDF5 libraries or xarray's decoding raise: a text
    ``scale_factor`` too), and every
    mismatch of ``rodsim.io.archive_schema.check_archive`` (bounded attribute lengths,
    step counts and JSON depths, each kind's own fields)."""
    try:
        check_input_file(path, "archive")
    except InputError as exc:
        raise ArchiveError(str(exc)) from None
    _probe_in_child(Path(path))
    import xarray as xr

    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            loaded = ds.load()
    except Exception as exc:  # noqa: BLE001 - damaged bytes raise anything (issue 23)
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ArchiveError(f"cannot read {shown_path(path)}: {reason[:200]} (not a netCDF archive, "
                           "or a damaged one)") from None
    if "schema_version" not in loaded.attrs or "scene_json" not in loaded.attrs:
        raise ArchiveError(f"{shown_path(path)} is not a rodsim archive (no scene_json attribute)")
    # Schema 3 files hold numeric index coordinates with text labels beside them
    # (rodsim.io.cf_layout): the labels become the coordinates again.
    if str(loaded.attrs["schema_version"])[:10] not in READABLE_SCHEMA_VERSIONS:
        raise ArchiveError(f"{shown_path(path)} has archive schema "
                           f"{str(loaded.attrs['schema_version'])[:10]}, this rodsim reads "
                           "schemas " + ", ".join(READABLE_SCHEMA_VERSIONS[:-1]) + " and "
                           + READABLE_SCHEMA_VERSIONS[-1])
    try:
        loaded = from_file(loaded)
    except Exception as exc:  # noqa: BLE001 - damaged label variables raise anything
        raise ArchiveError(f"{shown_path(path)}: damaged coordinate labels "
                           f"({type(exc).__name__})") from None
    try:
        check_archive(loaded)
    except ArchiveSchemaError as exc:
        raise ArchiveError(f"{shown_path(path)} is not a valid rodsim archive: {exc}") from None
    except (ValueError, TypeError, KeyError, IndexError, AttributeError, OverflowError,
            RecursionError) as exc:  # a check tripped on a value of an unexpected type
        raise ArchiveError(f"{shown_path(path)} is not a valid rodsim archive: "
                           f"{type(exc).__name__}: {str(exc)[:100]}") from None
    return loaded


def scene_of(dataset: xr.Dataset) -> Scene:
    """The scene stored in an archive (resolved values plus the original TOML text), validated
    as fully as ``rodsim.load_scene`` validates a scene file: its ``[solver.<name>]``
    tables checked by the integrators too (SceneError)."""
    from rodsim.solvers import check_solver_options

    scene = Scene.from_json(dataset.attrs["scene_json"], dataset.attrs.get("scene_toml", ""))
    check_solver_options(scene)
    return scene


def _probe_in_child(path: Path) -> None:
    """Read ``path`` once in a forked child before this process reads it: some damaged
    bytes make the netCDF/HDF5 C library abort the process ("double free or corruption") or
    loop forever, which no exception handler can turn into a message (found by
    tests/test_fuzz.py). A child that dies by a signal, or is still reading after
    ``PROBE_SECONDS`` (plus a second per 10 MB), makes it an ``ArchiveError``; a
    child that ends (read or raised) lets this process read the file itself. The child
    ends itself a second after that limit (SIGALRM), so a parent killed meanwhile leaves no
    reader spinning behind it.

    Only where it is safe to fork: a POSIX process with one thread (the CLI; a forked
    child copies only the calling thread, and a lock another thread held would never be
    released in it). Elsewhere the file is read without the probe."""
    if not hasattr(os, "fork") or threading.active_count() > 1:
        return
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    limit = PROBE_SECONDS + path.stat().st_size / 1e7
    pid = os.fork()
    if pid == 0:  # the child: read, and leave without running this process's exit code
        code = 0
        try:
            # Its own end a second after the parent's limit, whatever becomes of the parent:
            # a parent killed while the library loops left the child spinning for ever.
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
            signal.alarm(math.ceil(limit) + 1)
            # A fault handler (pytest's, `python -X faulthandler`) writes its dump to its own
            # copy of stderr, which the dup2 below does not reach: a deliberate or damaged
            # abort here printed "Fatal Python error: Aborted" and every thread's stack.
            faulthandler.disable()
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, 1)
            os.dup2(null, 2)  # what the C library prints as it aborts is not ours to show
            import xarray as xr

            with xr.open_dataset(path, engine="netcdf4") as ds:
                ds.load()
        except BaseException:  # noqa: BLE001 - the parent's own read reports it
            code = 3
        finally:
            os._exit(code)
    deadline = time.monotonic() + limit
    delay = 0.001
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            raise ArchiveError(f"cannot read {shown_path(path)}: the netCDF library was still "
                               f"reading it after {limit:.0f} s (a damaged archive)")
        time.sleep(delay)
        delay = min(2 * delay, 0.05)
    if os.WIFSIGNALED(status):
        raise ArchiveError(f"cannot read {shown_path(path)}: the netCDF/HDF5 library crashed "
                           f"reading it (signal {os.WTERMSIG(status)}): a damaged archive")
