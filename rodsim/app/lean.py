"""A lean ``rodsim`` process: what the command line does for its own process only (never in
a Python user's process, nor in the tests' process that calls ``rodsim.app.cli.main``).

Two things cost a short command more than its work (docs/benchmark-history.md, "Start-up"):

* **dask, when it is installed.** xarray imports ``dask.array`` and ``distributed`` (0.5 s
  of CPU) to learn whether the arrays of a Dataset it builds or writes are dask arrays, and
  ``to_netcdf`` asks dask for its scheduler. The commands that never hand xarray a dask
  array nor run on dask (``LEAN_COMMANDS``: everything but ``study``, ``batch`` and
  ``bench``; and ``study`` and ``batch`` on local workers, without ``--scheduler``:
  ``hides_dask``) mark dask as absent in their process before anything imports it
  (``hide_dask``).
* **The interpreter's exit.** Once numba has loaded kernels, the normal exit tears down
  LLVM and every module (0.4–0.6 s of CPU). ``fast_exit`` ends the process with
  ``os._exit`` instead, after flushing stdout and stderr, on the command's normal path
  only: its archives are complete by then (written to a temporary file, closed, then
  renamed: ``rodsim.io.archive``), its figures closed. Anything unusual (a flush that
  fails, another live thread, a child process still running) falls back to the normal
  exit. ``study`` and ``batch`` exit early too (``EARLY_EXIT_COMMANDS``): their worker
  pools and dask clusters are shut down before they return; ``bench`` keeps the normal
  exit.
"""

from __future__ import annotations

import os
import sys
from typing import NoReturn

__all__ = ["LEAN_COMMANDS", "EARLY_EXIT_COMMANDS", "hides_dask", "hide_dask", "fast_exit"]

#: The commands that use neither dask nor worker processes: their process hides dask and
#: ends with :func:`fast_exit`. ``study``, ``batch`` and ``bench`` start workers and clusters
#: whose shutdown belongs to the normal exit.
LEAN_COMMANDS = frozenset({"run", "rerun", "track", "fit", "reach", "plot", "scenes", "terms",
                           "compile"})
#: The commands whose process ends with :func:`fast_exit` once they return normally.
EARLY_EXIT_COMMANDS = LEAN_COMMANDS | {"study", "batch"}


def hides_dask(command: str, scheduler: str | None = None) -> bool:
    """Whether the process of ``command`` hides dask: the lean commands, and ``study`` and
    ``batch`` when they run on local workers (no ``--scheduler``; their workers are forked
    from this process and never use dask either). On a dask scheduler they keep it."""
    return command in LEAN_COMMANDS or (command in ("study", "batch") and not scheduler)


def hide_dask() -> None:
    """Make ``import dask`` fail in this process (``sys.modules["dask"] = None``, the
    import system's documented way to mark a module absent) unless dask or xarray is
    imported already (xarray remembers at import whether dask is there). xarray then
    treats every array as in memory, as they are."""
    if any(name in sys.modules for name in ("dask", "distributed", "xarray")):
        return
    for name in ("dask", "distributed"):
        sys.modules[name] = None  # type: ignore[assignment]


def fast_exit(code: int) -> NoReturn:
    """End the process with exit status ``code`` without the interpreter's teardown, once
    stdout and stderr are flushed; the normal exit (``SystemExit``) when a flush fails or
    another non-daemon thread is alive (it would be killed mid-work) or a child process of
    ``multiprocessing`` still runs (the normal exit joins it)."""
    import threading

    others: list[object] = [t for t in threading.enumerate()
                            if t is not threading.main_thread() and not t.daemon
                            and t.is_alive()]
    if "multiprocessing" in sys.modules:
        others += sys.modules["multiprocessing"].active_children()
    try:
        for stream in (sys.stdout, sys.stderr):
            if stream is not None and not stream.closed:
                stream.flush()
        if "logging" in sys.modules:
            sys.modules["logging"].shutdown()
    except (OSError, ValueError):  # a closed pipe, a full disk: let the normal exit report
        raise SystemExit(code) from None
    if others:
        raise SystemExit(code)
    os._exit(code)
