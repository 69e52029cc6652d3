"""Run tasks on local worker processes that may crash or hang, and go on without them.

The pool the study runner (rodsim/app/study_runner.py) and the benchmarks
(benchmarks/rodsim_bench/scaling.py) share. ``run_tasks`` runs ``function(*args)`` for
every task on a ``concurrent.futures.ProcessPoolExecutor``, at most ``workers`` at a time,
and hands each task's outcome to ``done`` as it finishes:

- the function's return value;
- ``TaskFailure`` ``"died"`` when the task's worker process died (a crash, ``os._exit``,
  the OOM killer). A dying worker breaks the whole pool: the tasks running beside it are run
  again one at a time, each in a pool of its own, to find which one killed it; the rest goes
  on in a fresh pool;
- ``TaskFailure`` ``"deadline"`` when the task ran longer than ``deadline(key)`` seconds:
  the pool's workers are ended, the tasks running beside it start again in a fresh pool;
- ``TaskFailure`` ``"error"`` when the task's result could not come back (the transport
  failed, or the task called ``sys.exit``).

``fresh_processes`` runs every task in a process of its own (spawned, never reused): what a
measurement of a process's peak memory needs. Workers ignore Ctrl-C (the parent ends them),
end quietly on SIGTERM, and exit by themselves within ``PARENT_POLL`` seconds when the
process that started them dies. A ``KeyboardInterrupt`` (or any error) in the parent cancels
the tasks not yet started and ends the running workers at once.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable, Hashable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, TypeVar

__all__ = ["TaskFailure", "run_tasks", "PARENT_POLL"]

#: How often a worker checks that the process that started it is still alive [s].
PARENT_POLL = 1.0
#: How often the parent checks the running tasks' deadlines [s] (when there are deadlines).
DEADLINE_POLL = 0.1
#: How long an abandoned pool's management thread is given to end [s] (``_end_pool``).
MANAGER_JOIN = 5.0
#: A task's key (the caller's: a study point's index, a benchmark's case).
K = TypeVar("K", bound=Hashable)


@dataclass(frozen=True)
class TaskFailure:
    """What ``run_tasks`` hands over instead of a task's value: ``kind`` is ``"died"``,
    ``"deadline"`` or ``"error"``; ``detail`` says what happened, in a few words."""

    kind: str
    detail: str


def _worker_init(parent: int, pids: Any) -> None:
    """Initializer of the workers: leave Ctrl-C to the parent (which ends the workers), end
    quietly on SIGTERM (the default action, not a handler the parent installed and a forked
    worker inherits, which would print a KeyboardInterrupt traceback when the parent ends its
    workers), report this process's id (the parent ends its workers by it) and exit when the
    parent dies (no idle workers left behind by a SIGKILL)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})
    pids.put(os.getpid())
    started_by = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(PARENT_POLL)
            if os.getppid() != started_by:  # reparented: whoever started us is gone
                os._exit(1)
            try:
                os.kill(parent, 0)
            except ProcessLookupError:
                os._exit(1)
            except OSError:
                pass

    threading.Thread(target=watch, name="rodsim-parent-watch", daemon=True).start()


def _end_pool(pool: ProcessPoolExecutor, abandon: bool, pids: Any) -> None:
    """Shut a pool down: wait for it after a normal end; after an interrupt, an error or a
    deadline cancel what has not started and end the running workers at once (SIGTERM to
    the process ids they reported; multiprocessing reaps them), then give the pool's
    management thread up to ``MANAGER_JOIN`` seconds to see them gone and end.

    Why that wait: the management thread closes its wake-up pipe as it ends, and Python's
    exit (concurrent.futures' ``_python_exit``, 3.11) writes to that pipe after checking,
    without a lock, that it is open. An interrupted ``rodsim study`` that exited while the
    thread was closing it printed "Exception ignored … OSError: [Errno 9] Bad file
    descriptor" and a traceback: 2 of 60 runs of a pool abandoned as here and the process
    exited at once; none of 60 with the wait."""
    if not abandon:
        pool.shutdown(wait=True)
        return
    workers = []
    with contextlib.suppress(Exception):
        while not pids.empty():
            workers.append(int(pids.get()))
    manager = getattr(pool, "_executor_manager_thread", None)  # shutdown forgets it
    pool.shutdown(wait=False, cancel_futures=True)
    for pid in workers:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGTERM)
    if isinstance(manager, threading.Thread):
        manager.join(timeout=MANAGER_JOIN)


def _pass(function: Callable[..., Any], tasks: dict[K, tuple], queue: deque[K],
          workers: int, done: Callable[[K, Any, float], None],
          deadline: Callable[[K], float] | None, fresh: bool) -> list[K]:
    """Run the tasks of ``queue`` (consumed) on a fresh pool, at most ``workers`` at a time.

    Returns ``[]`` once the queue is done, or the tasks that were running when a worker
    process died and broke the pool (one of them killed it; the others were collateral); the
    tasks not started stay in ``queue``. A task past its deadline is reported, the pool
    ended, and the tasks running beside it go back to the front of ``queue``.
    """
    context = multiprocessing.get_context("spawn" if fresh else None)
    pids = context.SimpleQueue()
    pool = ProcessPoolExecutor(max_workers=max(1, min(workers, len(queue))),
                               mp_context=context, initializer=_worker_init,
                               initargs=(os.getpid(), pids),
                               max_tasks_per_child=1 if fresh else None)
    # Workers fork on the first submit and inherit the parent's SIGTERM handler until their
    # initializer resets it: SIGTERM stays blocked across the forks, so a worker receives it
    # only once it would end quietly (the parent's is delivered when unblocked below).
    blocked = threading.current_thread() is threading.main_thread()
    if blocked:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    running: dict[Future[Any], tuple[K, float]] = {}
    suspects: list[K] = []
    broken = abandon = False
    try:
        while True:
            while queue and len(running) < workers and not broken:
                key = queue.popleft()
                try:
                    running[pool.submit(function, *tasks[key])] = key, time.perf_counter()
                except BrokenProcessPool:  # an idle worker died: start a fresh pool
                    queue.appendleft(key)
                    broken = True
            if blocked:  # the workers are forked: a pending SIGTERM is delivered here
                blocked = False
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})
            if not running:
                break
            finished, _ = wait(running, return_when=FIRST_COMPLETED,
                               timeout=DEADLINE_POLL if deadline is not None else None)
            for future in finished:
                key, started = running.pop(future)
                elapsed = time.perf_counter() - started
                try:
                    value = future.result()
                except BrokenProcessPool:
                    suspects.append(key)
                    broken = True
                    continue
                except KeyboardInterrupt:
                    raise
                except BaseException as exc:  # the transport failed, or the task sys.exit-ed
                    detail = traceback.format_exception_only(type(exc), exc)[-1].strip()
                    value = TaskFailure("error", detail)
                done(key, value, elapsed)
            if deadline is None or broken:
                continue
            now = time.perf_counter()
            late = [(future, key, now - started) for future, (key, started) in running.items()
                    if now - started > deadline(key)]
            if late:
                for future, key, elapsed in late:
                    del running[future]
                    done(key, TaskFailure("deadline", f"killed after {elapsed:.0f} s "
                                          f"(deadline {deadline(key):.0f} s)"), elapsed)
                queue.extendleft(reversed([key for key, _ in running.values()]))
                running.clear()
                abandon = True
                break
    except BaseException:
        abandon = True
        raise
    finally:
        try:
            _end_pool(pool, abandon, pids)
        finally:
            if blocked:  # only after an error before the first wait: the workers are ended
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})
    return suspects


def run_tasks(function: Callable[..., Any], tasks: Iterable[tuple[K, tuple]],
              workers: int, done: Callable[[K, Any, float], None], *,
              deadline: Callable[[K], float] | None = None,
              fresh_processes: bool = False, log: Callable[[str], None] | None = None,
              noun: str = "tasks") -> None:
    """Run ``function(*args)`` for every ``(key, args)`` of ``tasks`` on local worker
    processes (see the module docstring); ``done(key, value or TaskFailure, seconds)`` is
    called in this process as each one finishes. ``function`` and the arguments must pickle.
    ``log`` hears (in ``noun``) when the tasks beside a dying worker are re-run one at a time.
    """
    table = dict(tasks)
    queue = deque(table)
    while queue:
        suspects = _pass(function, table, queue, workers, done, deadline, fresh_processes)
        if len(suspects) > 1:  # find which one died: each alone, in a pool of its own
            if log is not None:
                log(f"a worker process died while {len(suspects)} {noun} ran; running them "
                    "one at a time to find which")
            suspects = [key for key in suspects
                        if _pass(function, table, deque([key]), 1, done, deadline,
                                 fresh_processes)]
        for key in suspects:
            done(key, TaskFailure("died", "a crash, os._exit or the out-of-memory killer"),
                 float("nan"))
