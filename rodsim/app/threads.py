"""Pinning OpenMP and OpenBLAS to one thread, for the command line and the tests.

The solvers' callbacks hold the GIL and their linear algebra is small (band solves of a few
hundred to a few thousand unknowns), so BLAS threads only add contention; on the shared
2-core machine threaded BLAS gave intermittent 10× slow-downs (docs/design.md, "Threads").
The setting takes effect only before numpy is first imported, so the CLI calls
``pin_threads`` first thing and the tests in their configuration; a Python user who wants
it sets the variables or calls this before importing numpy. An existing setting is kept.
"""

from __future__ import annotations

import os

__all__ = ["pin_threads"]

#: Environment variables read by OpenMP and OpenBLAS when they load.
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")


def pin_threads() -> None:
    """Set each of ``THREAD_VARIABLES`` to 1 unless it is already set."""
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
