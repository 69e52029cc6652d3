"""Where a result came from: the rodsim version, the git commit of the source it ran from
(and whether that source had uncommitted changes), and the versions of the numerical
libraries. Recorded in every archive (docs/archive.md)."""

from __future__ import annotations

import subprocess
from pathlib import Path

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
