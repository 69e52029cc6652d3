"""The ``tiered`` evaluation path: numpy first, the compiled kernels once they pay.

Loading the compiled kernels costs a process a fixed ~0.3 s of CPU before its first
evaluation (numba's import and each kernel read from the on-disk cache; a fresh machine also
compiles them, seconds per kernel), while the numpy reference computes the same numbers at
a few to twenty times the cost per evaluation (docs/benchmark-history.md, "Start-up"). A process
that makes one solve of a small scene — ``rodsim run`` on a shipped scene — spends less
than that fixed cost on all of its numpy evaluations; a study, a track or a large scene
spends far more.

Which case a run is cannot be told before it runs (tip-on-tissue under static makes 11 500
evaluations of a 280-unknown model, table1-50g under CVODE a few dozen), so the choice is
made as the classic rent-or-buy rule: evaluate by numpy, count what those evaluations cost,
and move to the compiled kernels for good once that count passes the fixed cost of loading
them (``NUMPY_BUDGET``). A run that stays below it never loads numba.

The cost counted is **nominal**, never the clock's: each numpy evaluation is charged what
its terms' element arrays should cost (``nominal_cost``: a fixed cost per term call and
one per entry, measured once on the shipped scenes' terms), so the move happens after the
same evaluations on every run of a scene, loaded machine or not. Until 2026-12 the CPU the
evaluations took was charged: the move then came after 40, 41 or 44 evaluations of one
guidewire scene, and CVODE landed on different equilibria of it from run to run.

The count is the process's, not a model's: once one model has moved on, every model of the
process evaluates compiled (the kernels are loaded). A process that runs one scene — ``rodsim
run``, ``rodsim rerun`` — so moves at the same evaluation every time; a Python process that
solves several ``tiered`` scenes moves where their sequence makes it. The two paths compute
the same numbers to round-off (tests/test_kernels.py), and the move is reported
(``KernelTier.describe``, stored with a run's archive).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rodsim.core.terms.base import Term

__all__ = ["KernelTier", "NUMPY_BUDGET", "PROCESS_TIER", "nominal_cost"]

#: Nominal seconds of numpy evaluations after which a ``tiered`` model moves to the compiled
#: kernels: about what loading them costs a process from a warm cache (numba's import
#: 0.12 s and eight cached kernels 0.17 s for table1-50g, docs/benchmark-history.md "Start-up").
NUMPY_BUDGET = 0.25

#: Nominal CPU of one term's numpy call [s], whatever its size (measured 20–120 µs).
TERM_CALL_SECONDS = 40e-6
#: Nominal CPU per entry of a term's numpy element forces [s] (measured 100–450 ns on the
#: shipped scenes' stretch, bending, centerline, lumen, string and contact terms).
FORCE_ENTRY_SECONDS = 100e-9
#: Nominal CPU per entry of a term's numpy element Jacobians [s] (measured 18–160 ns).
JACOBIAN_ENTRY_SECONDS = 40e-9


def nominal_cost(terms: Iterable[Term], *, force: bool, jacobian: bool) -> float:
    """What a numpy evaluation of ``terms`` is charged [nominal s]: per term, a call and each
    entry of its element forces (``force``; also an energy's cost) and element Jacobians
    (``jacobian``), times the term's ``rodsim.core.terms.base.Term.numpy_cost_factor``.
    A function of the terms' sizes alone, so of the scene."""
    total = 0.0
    for term in terms:
        elements, width = term.dofs.shape if term.dofs.ndim == 2 else (term.dofs.size, 1)
        entries = 0.0
        if force:
            entries += FORCE_ENTRY_SECONDS * elements * width
        if jacobian and term.has_jacobian:
            entries += JACOBIAN_ENTRY_SECONDS * elements * width * width
        calls = int(force) + int(jacobian and term.has_jacobian)
        total += calls * TERM_CALL_SECONDS + term.numpy_cost_factor * entries
    return total


class KernelTier:
    """A process's account of its numpy evaluations under ``solver.kernels = "tiered"``:
    their nominal cost and whether the compiled kernels have taken over."""

    def __init__(self, budget: float = NUMPY_BUDGET) -> None:
        self.budget = budget
        #: Nominal seconds charged for numpy evaluations of tiered models so far.
        self.spent = 0.0
        #: Numpy evaluations made before the move (all of them while it has not happened).
        self.numpy_evaluations = 0
        #: Whether tiered models now evaluate by the compiled kernels.
        self.compiled = False

    def charge(self, seconds: float) -> None:
        """Count one numpy evaluation of nominal cost ``seconds``; move to the compiled
        kernels once the total passes the budget."""
        self.numpy_evaluations += 1
        self.spent += seconds
        if self.spent > self.budget:
            self.compiled = True

    def describe(self) -> str:
        """One line: which path the tiered evaluations took."""
        if self.compiled:
            return (f"numpy for the first {self.numpy_evaluations} evaluations "
                    f"({self.spent:.2f} s nominal), compiled after")
        return f"numpy ({self.numpy_evaluations} evaluations, {self.spent:.2f} s nominal)"

    def reset(self) -> None:
        """Start the account again (a test's fixture; a process never needs it)."""
        self.spent = 0.0
        self.numpy_evaluations = 0
        self.compiled = False


#: The account of this process.
PROCESS_TIER = KernelTier()
