"""netCDF archives: atomic writes and checked reads (:func:`rodsim.app.api.rerun` re-runs one).

A write goes to a temporary file in the target's folder and is renamed over the target
only when complete (``os.replace`` is atomic on POSIX), so a failed or interrupted write
never leaves a corrupt archive nor clobbers an existing one. The target rules (a regular
file or nothing; symbolic links followed; stale temporaries removed) are
:mod:`rodsim.io.output`'s. A read checks the archive against its contract
(:mod:`rodsim.io.archive_schema`) before returning it.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

import xarray as xr

from rodsim.core.scene import Scene
from rodsim.io.archive_schema import (
    READABLE_SCHEMA_VERSIONS,
    SCHEMA_VERSION,
    ArchiveSchemaError,
    check_archive,
)
from rodsim.io.cf_layout import from_file, to_file
from rodsim.io.output import OutputError, check_target, remove_stale_temporaries, temporary_prefix

__all__ = ["ArchiveError", "write_dataset", "read_dataset", "scene_of"]


class ArchiveError(OSError):
    """An archive cannot be written or read, or is not a rodsim archive."""


def write_dataset(dataset: xr.Dataset, path: str | Path) -> Path:
    """Write ``dataset`` to ``path`` (netCDF4) atomically; returns the path written (a
    symbolic link's target)."""
    try:
        path = check_target(path)
    except OutputError as exc:
        raise ArchiveError(str(exc)) from None
    folder = path.parent if str(path.parent) else Path(".")
    remove_stale_temporaries(path)
    try:
        handle, temporary = tempfile.mkstemp(prefix=temporary_prefix(path), suffix=".tmp",
                                             dir=folder)
    except OSError as exc:
        raise ArchiveError(f"cannot write {str(path)!r}: {exc}") from exc
    try:
        os.close(handle)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o666 & ~umask)  # mkstemp creates 0600; archives follow the umask
        # No _FillValue on coordinates (CF: a coordinate has no missing values; xarray would
        # add NaN as the fill value of every float one). An archive of the current schema
        # is stored in its CF layout (numeric index coordinates, text as characters:
        # rodsim.io.cf_layout); a Dataset of an older schema is written as it is.
        if str(dataset.attrs.get("schema_version")) == SCHEMA_VERSION:
            dataset, encoding = to_file(dataset)
        else:
            encoding = {name: {"_FillValue": None} for name in dataset.coords}
        dataset.to_netcdf(temporary, engine="netcdf4", encoding=encoding)
        os.replace(temporary, path)
    except BaseException as exc:  # an interrupt too: never leave a half-written temporary
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        if isinstance(exc, Exception):
            raise ArchiveError(f"cannot write {str(path)!r}: {exc}") from exc
        raise
    return path


def read_dataset(path: str | Path) -> xr.Dataset:
    """Read an archive fully into memory (the file is closed on return) and check it against
    the archive contract (ArchiveError naming the first mismatch)."""
    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            loaded = ds.load()
    except (OSError, ValueError, RuntimeError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ArchiveError(f"cannot read {str(path)!r}: {reason[:200]}") from None
    if "schema_version" not in loaded.attrs or "scene_json" not in loaded.attrs:
        raise ArchiveError(f"{str(path)!r} is not a rodsim archive (no scene_json attribute)")
    # Schema 3 files hold numeric index coordinates with text labels beside them
    # (rodsim.io.cf_layout): the labels become the coordinates again.
    loaded = from_file(loaded)
    if str(loaded.attrs["schema_version"]) not in READABLE_SCHEMA_VERSIONS:
        raise ArchiveError(f"{str(path)!r} has archive schema {loaded.attrs['schema_version']}, "
                           "this rodsim reads schemas "
                           + ", ".join(READABLE_SCHEMA_VERSIONS[:-1]) + " and "
                           + READABLE_SCHEMA_VERSIONS[-1])
    try:
        check_archive(loaded)
    except ArchiveSchemaError as exc:
        raise ArchiveError(f"{str(path)!r} is not a valid rodsim archive: {exc}") from None
    return loaded


def scene_of(dataset: xr.Dataset) -> Scene:
    """The scene stored in an archive (resolved values plus the original TOML text)."""
    return Scene.from_json(dataset.attrs["scene_json"], dataset.attrs.get("scene_toml", ""))
