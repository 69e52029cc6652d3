"""The ``tiered`` evaluation path: numpy first, the compiled kernels once they pay.

Loading the compiled kernels costs a process a fixed ~0.3 s of CPU before its first
evaluation (numba's import and each kernel read from the on-disk cache; a fresh machine also
compiles them, seconds per kernel), while the numpy reference computes the same numbers at
a few to twenty times the cost per evaluation (docs/benchmarks.md, "Start-up"). A process
that makes one solve of a small scene — ``rodsim run`` on a shipped scene — spends less
than that fixed cost on all of its numpy evaluations; a study, a track or a large scene
spends far more.

Which case a run is cannot be told before it runs (tip-on-tissue under static makes 11 500
evaluations of a 280-unknown model, table1-50g under CVODE a few dozen), so the choice is
made as the classic rent-or-buy rule: evaluate by numpy, count the CPU those evaluations
take, and move to the compiled kernels for good once that count passes the fixed cost of
loading them (:data:`NUMPY_BUDGET`). A run that stays below it never loads numba; one that passes it
pays at most about twice what the better path alone would have cost. The count is the
process's, not a model's: once one model has moved on, every model of the process
evaluates compiled (the kernels are loaded).

The two paths compute the same numbers to round-off (tests/test_kernels.py), so where the
move happens changes a result only at round-off, and the move is reported
(:meth:`KernelTier.describe`, stored with a run's archive).
"""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["KernelTier", "NUMPY_BUDGET", "PROCESS_TIER"]

#: CPU seconds of numpy evaluations after which a ``tiered`` model moves to the compiled
#: kernels: about what loading them costs a process from a warm cache (numba's import
#: 0.12 s and eight cached kernels 0.17 s for table1-50g, docs/benchmarks.md "Start-up").
NUMPY_BUDGET = 0.25


class KernelTier:
    """A process's account of its numpy evaluations under ``solver.kernels = "tiered"``:
    the CPU they took and whether the compiled kernels have taken over."""

    def __init__(self, budget: float = NUMPY_BUDGET,
                 clock: Callable[[], float] = time.process_time) -> None:
        self.budget = budget
        self.clock = clock
        #: CPU seconds spent in numpy evaluations of tiered models so far.
        self.spent = 0.0
        #: Numpy evaluations made before the move (all of them while it has not happened).
        self.numpy_evaluations = 0
        #: Whether tiered models now evaluate by the compiled kernels.
        self.compiled = False

    def charge(self, seconds: float) -> None:
        """Count one numpy evaluation that took ``seconds`` of CPU; move to the compiled
        kernels once the total passes the budget."""
        self.numpy_evaluations += 1
        self.spent += seconds
        if self.spent > self.budget:
            self.compiled = True

    def describe(self) -> str:
        """One line: which path the tiered evaluations took."""
        if self.compiled:
            return (f"numpy for the first {self.numpy_evaluations} evaluations "
                    f"({self.spent:.2f} s CPU), compiled after")
        return f"numpy ({self.numpy_evaluations} evaluations, {self.spent:.2f} s CPU)"

    def reset(self) -> None:
        """Start the account again (a test's fixture; a process never needs it)."""
        self.spent = 0.0
        self.numpy_evaluations = 0
        self.compiled = False


#: The account of this process.
PROCESS_TIER = KernelTier()
