"""Where a result came from: the rodsim version, the git commit of the source it ran from
(and whether that source had uncommitted changes), and the versions of the numerical
libraries. Recorded in every archive (docs/archive.md)."""

from __future__ import annotations

import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

#: The repository root when rodsim runs from a source checkout (rodsim/io/ is two levels in).
_ROOT = Path(__file__).resolve().parents[2]


def git_commit() -> str | None:
    """The git commit of the rodsim source, when it runs from a git checkout."""
    root = _ROOT
    if not (root / ".git").exists():
        return None
    try:
        out = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                             text=True, timeout=5, check=True)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


#: The paths whose uncommitted changes can change a study's results (git_dirty).
SOURCE_PATHS = ("rodsim", "studies", "data", "pyproject.toml")


def git_dirty() -> bool | None:
    """Whether the rodsim source (package, studies, scenes) has uncommitted changes —
    modified, staged or untracked files — when it runs from a git checkout."""
    root = _ROOT
    if not (root / ".git").exists():
        return None
    try:
        out = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--",
                              *SOURCE_PATHS], capture_output=True, text=True, timeout=10,
                             check=True)
    except (OSError, subprocess.SubprocessError):
        return None
    return bool(out.stdout.strip())


#: What every archive cites (CF ``references``): the paper rodsim implements.
REFERENCES = ("Pierre-Frederic Villard, Thomas M. Waite and Robert D. Howe, \"Cosserat Rods "
              "for Modeling Tendon-Driven Robotic Catheter Systems\"")

#: The CF conventions the archives follow (docs/archive.md, "Conventions and provenance").
CONVENTIONS = "CF-1.8"

_invocation: ContextVar[str | None] = ContextVar("rodsim_invocation", default=None)


@contextmanager
def invocation(command: str) -> Iterator[None]:
    """Within this block, archives record ``command`` (the CLI's command line, e.g. ``rodsim
    run table1-50g --integrator static``) in their ``history`` instead of the Python call
    that built them."""
    token = _invocation.set(command)
    try:
        yield
    finally:
        _invocation.reset(token)


def library_versions() -> dict[str, str]:
    """Versions of the numerical libraries a result depends on, as archive attributes."""
    import numpy
    import scipy

    versions = {"numpy_version": numpy.__version__, "scipy_version": scipy.__version__}
    try:
        versions["scikit_sundae_version"] = metadata.version("scikit-sundae")
    except metadata.PackageNotFoundError:
        versions["scikit_sundae_version"] = "not installed"
    try:
        import sksundae  # loads SUNDIALS: called when an archive is built, not at import

        versions["sundials_version"] = str(sksundae.SUNDIALS_VERSION)
    except (ImportError, AttributeError):
        versions["sundials_version"] = "unknown"
    return versions


def utc_now() -> str:
    """The current time, ISO 8601 in UTC to the second (``2026-11-24T03:00:00Z``)."""
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def history(call: str, created: str) -> str:
    """The ``history`` line of an archive created at ``created``: the CLI's command line
    when :func:`invocation` is active, else ``call``, the Python call that built it."""
    from rodsim.version import __version__

    return f"{created} rodsim {__version__}: {_invocation.get() or call}"


def archive_attributes(call: str) -> dict[str, Any]:
    """The provenance attributes every archive kind carries (docs/archive.md, "Conventions
    and provenance"): CF's ``Conventions``, ``history`` (:func:`history`), ``source``,
    ``references``, ``date_created``, ``rodsim_version``, the git commit and dirty flag
    when rodsim runs from a checkout, and :func:`library_versions`."""
    from rodsim.version import __version__

    created = utc_now()
    attrs: dict[str, Any] = {
        "Conventions": CONVENTIONS,
        "history": history(call, created),
        "source": f"rodsim {__version__}",
        "references": REFERENCES,
        "date_created": created,
        "rodsim_version": __version__,
    }
    commit = git_commit()
    if commit:
        attrs["git_commit"] = commit
        dirty = git_dirty()
        if dirty is not None:
            attrs["git_dirty"] = int(dirty)
    attrs.update(library_versions())
    return attrs
