"""The wall-time budget (``solver.max_wall_time``) while a model is assembled.

Assembling a large model (the rods, the terms, the Jacobian pattern and the rest-state
stiffness of ``rodsim.core.model.Model``) takes seconds per 100 000 nodes and runs before
any integrator exists, so the integrators' own budget check only sees it once it is over.
``AssemblyBudget`` is checked between the assembly's phases and between the terms in its
per-term loops (one clock read each: a few dozen per model, nothing measurable); once the
budget is spent it raises ``AssemblyBudgetExceeded``, which ``rodsim.solve`` returns
as a failed result (the command line: a solver failure, exit 1).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

__all__ = ["AssemblyBudget", "AssemblyBudgetExceeded"]


class AssemblyBudgetExceeded(RuntimeError):
    """The wall-time budget was spent while the model was still being assembled."""

    def __init__(self, elapsed: float, budget: float, nodes: int) -> None:
        super().__init__(
            f"model assembly exceeded max_wall_time after {elapsed:.1f} s at N = {nodes} "
            f"(wall-time budget of {budget:g} s), lower nodes or raise the budget "
            "(solver.max_wall_time)")
        self.elapsed = elapsed
        self.budget = budget
        self.nodes = nodes


@dataclass(frozen=True)
class AssemblyBudget:
    """A budget of ``seconds`` of wall time counted from ``start`` (a
    ``time.perf_counter`` value) for assembling a model of ``nodes`` control points."""

    start: float
    seconds: float
    nodes: int

    def check(self) -> None:
        """Raise ``AssemblyBudgetExceeded`` once the budget is spent."""
        elapsed = time.perf_counter() - self.start
        if elapsed > self.seconds:
            raise AssemblyBudgetExceeded(elapsed, self.seconds, self.nodes)
