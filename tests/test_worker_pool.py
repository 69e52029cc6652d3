"""The worker pool the study runner and the benchmarks share (rodsim/app/worker_pool.py): a
task whose worker dies or overruns its deadline is reported as such, and the others finish."""

from __future__ import annotations

import os
import threading
import time
from concurrent.futures.process import _ExecutorManagerThread

import pytest

from rodsim.app.worker_pool import TaskFailure, run_tasks


def task(what: str) -> str:
    if what == "exit":
        os._exit(70)
    if what.startswith("hang"):
        time.sleep(3600.0)
    return what.upper()


def test_dead_and_late_tasks_are_reported_and_the_rest_finishes():
    outcomes: dict[str, object] = {}
    logged: list[str] = []
    names = ["a", "exit", "b", "hang", "c", "d"]
    start = time.perf_counter()
    run_tasks(task, [(name, (name,)) for name in names], 2,
              lambda key, value, seconds: outcomes.__setitem__(key, value),
              deadline=lambda key: 3.0, log=logged.append)
    assert time.perf_counter() - start < 60
    assert set(outcomes) == set(names)
    for name in ("a", "b", "c", "d"):
        assert outcomes[name] == name.upper()
    assert outcomes["exit"] == TaskFailure("died", outcomes["exit"].detail)
    assert outcomes["hang"].kind == "deadline" and "deadline 3 s" in outcomes["hang"].detail


def test_an_interrupt_ends_the_pools_management_thread_before_returning():
    """Ctrl-C in the parent (here: raised by ``done`` after the first result) ends the pool's
    workers and its management thread before ``run_tasks`` re-raises: a process that then
    exits no longer races that thread for its wake-up pipe (an interrupted study printed
    "OSError: [Errno 9] Bad file descriptor" and a traceback at its exit in 2 of 60 runs)."""
    def done(key: str, value: object, seconds: float) -> None:
        raise KeyboardInterrupt

    start = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        run_tasks(task, [(name, (name,)) for name in ["a", "hang", "hang2", "hang3"]], 2,
                  done)
    assert time.perf_counter() - start < 30
    assert not [thread for thread in threading.enumerate()
                if isinstance(thread, _ExecutorManagerThread) and thread.is_alive()]
