"""The exception a solver raises to stop with a diagnostic (never past
``rodsim.solvers.base.Integrator.solve``, which turns it into a failed result)."""

from __future__ import annotations

__all__ = ["SolverFailure"]


class SolverFailure(RuntimeError):
    """Raised inside ``Integrator.advance`` to stop with a diagnostic message; ``advice``
    replaces the integrator's generic advice when the failure has a specific remedy."""

    def __init__(self, message: str, advice: str | None = None) -> None:
        super().__init__(message)
        self.advice = advice
