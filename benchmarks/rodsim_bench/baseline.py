"""Another revision's code, run in the same benchmark run (``RODSIM_BENCH_BASELINE``).

Timings on a shared machine drift by tens of percent between runs, so a before/after figure
is only worth its ratio when both sides were measured in one run, interleaved. With the
environment variable ``RODSIM_BENCH_BASELINE`` set to a git revision of this repository, a
benchmark that supports it (``tracking``, ``workers``) extracts that revision's tree
(``git archive``) into a temporary folder and runs the same work with it in subprocesses:
``PYTHONPATH`` points at the tree, so ``import rodsim`` and ``python -m rodsim`` there are
that revision's (its kernels compile into the tree's own numba cache on a warm-up run).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

__all__ = ["BASELINE_ENV", "BaselineTree", "baseline_revision"]

#: The environment variable naming the git revision to compare with.
BASELINE_ENV = "RODSIM_BENCH_BASELINE"


def baseline_revision() -> str:
    """The revision ``RODSIM_BENCH_BASELINE`` names, or "" when it is not set."""
    return os.environ.get(BASELINE_ENV, "")


class BaselineTree:
    """The tree of ``revision`` extracted into ``folder`` (which must exist and be empty of
    a ``tree`` entry), and how to run Python in it."""

    def __init__(self, revision: str, folder: Path) -> None:
        root = Path(__file__).resolve().parents[2]
        self.commit = subprocess.run(["git", "-C", str(root), "rev-parse", revision],
                                     capture_output=True, text=True,
                                     check=True).stdout.strip()
        self.tree = folder / "tree"
        self.tree.mkdir()
        archive = subprocess.run(["git", "-C", str(root), "archive", self.commit],
                                 capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(self.tree)], input=archive, check=True)

    def env(self, base: dict[str, str] | None = None) -> dict[str, str]:
        """``base`` (default: this process's environment) with ``PYTHONPATH`` at the tree."""
        return {**(os.environ if base is None else base), "PYTHONPATH": str(self.tree)}

    def python(self, args: list[str], base_env: dict[str, str] | None = None,
               timeout: float = 1800) -> subprocess.CompletedProcess:
        """``python ARGS`` with this revision's code, run in the tree; raises on failure."""
        done = subprocess.run([sys.executable, *args], env=self.env(base_env),
                              capture_output=True, text=True, cwd=str(self.tree),
                              timeout=timeout, check=False)
        if done.returncode != 0:
            raise RuntimeError(f"baseline {self.commit}: {done.stderr.strip()[-500:]}")
        return done
