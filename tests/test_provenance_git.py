"""The git commit of an archive's provenance read from the git files (rodsim/io/provenance.py,
no subprocess), checked against ``git rev-parse HEAD`` in a scratch repository: a branch's
loose ref, packed refs, a detached HEAD and a linked worktree."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from rodsim.io.provenance import _read_head

pytestmark = pytest.mark.skipif(shutil.which("git") is None, reason="git is not installed")


def _git(folder: Path, *args: str) -> str:
    return subprocess.run(["git", "-C", str(folder), *args], capture_output=True, text=True,
                          check=True).stdout.strip()


@pytest.fixture
def repository(tmp_path: Path) -> Path:
    folder = tmp_path / "repo"
    folder.mkdir()
    _git(folder, "init", "-q", "-b", "main")
    for name, value in (("user.email", "a@b.c"), ("user.name", "t"), ("commit.gpgsign",
                                                                        "false")):
        _git(folder, "config", name, value)
    for text in ("one", "two"):
        (folder / "file.txt").write_text(text)
        _git(folder, "add", "file.txt")
        _git(folder, "commit", "-q", "-m", text)
    return folder


def test_a_branch_head_loose_and_packed(repository):
    head = _git(repository, "rev-parse", "HEAD")
    assert _read_head(repository) == head
    _git(repository, "pack-refs", "--all")
    assert not (repository / ".git" / "refs" / "heads" / "main").exists()
    assert _read_head(repository) == head


def test_a_detached_head_and_a_linked_worktree(repository, tmp_path):
    first = _git(repository, "rev-parse", "HEAD~1")
    _git(repository, "worktree", "add", "-q", "-b", "side", str(tmp_path / "side"), first)
    assert (tmp_path / "side" / ".git").is_file()
    assert _read_head(tmp_path / "side") == first
    (tmp_path / "side" / "file.txt").write_text("three")
    _git(tmp_path / "side", "commit", "-q", "-am", "three")
    assert _read_head(tmp_path / "side") == _git(tmp_path / "side", "rev-parse", "HEAD")
    _git(repository, "checkout", "-q", "--detach", first)
    assert _read_head(repository) == first
