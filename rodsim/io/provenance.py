"""Where a result came from: the rodsim version, the git commit of the source it ran from
(and whether that source had uncommitted changes), and the versions of the numerical
libraries. Recorded in every archive (docs/archive.md)."""

from __future__ import annotations

import functools
import importlib.util
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

#: The repository root when rodsim runs from a source checkout (rodsim/io/ is two levels in).
_ROOT = Path(__file__).resolve().parents[2]


def _git_folders(root: Path) -> tuple[Path, Path] | None:
    """The git folder of the checkout at ``root`` and its common folder (they differ in a
    linked worktree, whose ``.git`` is a file ``gitdir: …`` and whose folder names the
    common one in ``commondir``)."""
    dot = root / ".git"
    if dot.is_dir():
        return dot, dot
    text = dot.read_text(encoding="utf-8").strip()
    if not text.startswith("gitdir:"):
        return None
    folder = (root / text.removeprefix("gitdir:").strip()).resolve()
    common = folder / "commondir"
    if common.is_file():
        return folder, (folder / common.read_text(encoding="utf-8").strip()).resolve()
    return folder, folder


def _read_head(root: Path) -> str | None:
    """HEAD's commit read from the checkout's git files (a detached HEAD, a loose ref or a
    packed one); None when they hold anything else (then ``git`` is asked)."""
    try:
        folders = _git_folders(root)
        if folders is None:
            return None
        folder, common = folders
        head = (folder / "HEAD").read_text(encoding="utf-8").strip()
        if not head.startswith("ref:"):
            return head if _is_commit(head) else None
        ref = head.removeprefix("ref:").strip()
        for base in (folder, common):
            loose = base / ref
            if loose.is_file():
                value = loose.read_text(encoding="utf-8").strip()
                return value if _is_commit(value) else None
        packed = common / "packed-refs"
        if packed.is_file():
            for line in packed.read_text(encoding="utf-8").splitlines():
                value, _, name = line.partition(" ")
                if name.strip() == ref and _is_commit(value):
                    return value
    except (OSError, UnicodeDecodeError):
        return None
    return None


def _is_commit(text: str) -> bool:
    return len(text) in (40, 64) and all(c in "0123456789abcdef" for c in text)


@functools.cache
def git_commit() -> str | None:
    """The git commit of the rodsim source, when it runs from a git checkout: read from the
    git files (no subprocess), else from ``git rev-parse``; once per process."""
    root = _ROOT
    if not (root / ".git").exists():
        return None
    head = _read_head(root)
    if head is not None:
        return head
    try:
        out = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                             text=True, timeout=5, check=True)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


#: The paths whose uncommitted changes can change a study's results (git_dirty).
SOURCE_PATHS = ("rodsim", "studies", "data", "pyproject.toml")


@functools.cache
def git_dirty() -> bool | None:
    """Whether the rodsim source (package, studies, scenes) has uncommitted changes —
    modified, staged or untracked files — when it runs from a git checkout; asked of
    ``git status`` once per process (a study's points share the answer)."""
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
    versions["sundials_version"] = sundials_version()
    return versions


def sundials_version() -> str:
    """SUNDIALS' version as scikit-sundae was built with it (``sksundae.SUNDIALS_VERSION``),
    without importing sksundae when no solver has: the package ships the Cython include its
    constant is compiled from (``py_config.pxi``, ``SUNDIALS_VERSION = "7.9.0"``), read as
    text. Importing sksundae costs a short command ~0.18 s of CPU (it imports
    scipy.optimize, scipy.special and scipy.fft; docs/benchmarks.md, "Start-up"). Without
    that file, sksundae is imported; "unknown" without sksundae."""
    module = sys.modules.get("sksundae")
    if module is None:
        version = _sundials_version_from_source()
        if version is not None:
            return version
    try:
        import sksundae  # loads SUNDIALS

        return str(sksundae.SUNDIALS_VERSION)
    except (ImportError, AttributeError):
        return "unknown"


def _sundials_version_from_source() -> str | None:
    """``SUNDIALS_VERSION`` from the installed sksundae's ``py_config.pxi``, or None when the
    package or the line is not there (then the caller imports sksundae)."""
    try:
        spec = importlib.util.find_spec("sksundae")  # a top-level name: nothing is imported
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    for folder in spec.submodule_search_locations:
        try:
            text = (Path(folder) / "py_config.pxi").read_text(encoding="utf-8")
        except OSError:
            continue
        for line in text.splitlines():
            name, _, value = line.partition("=")
            if name.strip() == "SUNDIALS_VERSION" and value.strip():
                return value.strip().strip("\"'")
    return None


def utc_now() -> str:
    """The current time, ISO 8601 in UTC to the second (``2026-11-24T03:00:00Z``)."""
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def history(call: str, created: str) -> str:
    """The ``history`` line of an archive created at ``created``: the CLI's command line
    when ``invocation`` is active, else ``call``, the Python call that built it."""
    from rodsim.version import __version__

    return f"{created} rodsim {__version__}: {_invocation.get() or call}"


def archive_attributes(call: str) -> dict[str, Any]:
    """The provenance attributes every archive kind carries (docs/archive.md, "Conventions
    and provenance"): CF's ``Conventions``, ``history`` (``history``), ``source``,
    ``references``, ``date_created``, ``rodsim_version``, the git commit and dirty flag
    when rodsim runs from a checkout, and ``library_versions``."""
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
