"""netCDF archives: atomic writes, reads, and re-running a stored run.

A write goes to a temporary file in the target's folder and is renamed over the target
only when complete (``os.replace`` is atomic on POSIX), so a failed or interrupted write
never leaves a corrupt archive nor clobbers an existing one.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr

from rodsim.result import SCHEMA_VERSION, Result
from rodsim.scene import Scene

__all__ = ["ArchiveError", "write_dataset", "read_dataset", "scene_of", "rerun"]


class ArchiveError(OSError):
    """An archive cannot be written or read, or is not a rodsim archive."""


def write_dataset(dataset: xr.Dataset, path: str | Path) -> Path:
    """Write ``dataset`` to ``path`` (netCDF4) atomically; returns the path."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ArchiveError(f"cannot write {str(path)!r}: folder {str(folder)!r} does not exist")
    try:
        handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise ArchiveError(f"cannot write {str(path)!r}: {exc}") from exc
    try:
        os.close(handle)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o666 & ~umask)  # mkstemp creates 0600; archives follow the umask
        dataset.to_netcdf(temporary, engine="netcdf4")
        os.replace(temporary, path)
    except BaseException as exc:  # an interrupt too: never leave a half-written temporary
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        if isinstance(exc, Exception):
            raise ArchiveError(f"cannot write {str(path)!r}: {exc}") from exc
        raise
    return path


def read_dataset(path: str | Path) -> xr.Dataset:
    """Read an archive fully into memory (the file is closed on return)."""
    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            loaded = ds.load()
    except (OSError, ValueError) as exc:
        raise ArchiveError(f"cannot read {str(path)!r}: {exc}") from None
    if "schema_version" not in loaded.attrs or "scene_json" not in loaded.attrs:
        raise ArchiveError(f"{str(path)!r} is not a rodsim archive (no scene_json attribute)")
    if str(loaded.attrs["schema_version"]) != SCHEMA_VERSION:
        raise ArchiveError(f"{str(path)!r} has archive schema {loaded.attrs['schema_version']}, "
                           f"this rodsim reads schema {SCHEMA_VERSION}")
    return loaded


def scene_of(dataset: xr.Dataset) -> Scene:
    """The scene stored in an archive (resolved values plus the original TOML text)."""
    return Scene.from_json(dataset.attrs["scene_json"], dataset.attrs.get("scene_toml", ""))


def rerun(dataset: xr.Dataset) -> tuple[Result, float]:
    """Re-run a stored run from the archive alone.

    Returns the new result and the largest distance [m] between stored and recomputed
    control points.
    """
    from rodsim.api import solve

    scene = scene_of(dataset)
    stored_options = json.loads(dataset.attrs["integrator_options"])
    integrator = str(dataset.attrs["integrator"])
    if stored_options != scene.data["solver"][integrator]:
        raise ArchiveError("archive is inconsistent: integrator_options differ from the "
                           "scene's solver options")
    result = solve(scene, integrator)
    stored = dataset["position"].values
    new = result.to_xarray()["position"].values
    difference = float(np.max(np.linalg.norm(stored - new, axis=1)))
    return result, difference
