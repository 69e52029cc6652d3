"""When a run stops, as a value on the run, and the verdict on where it stopped.

A run's ``Stop`` is given to ``Integrator.init`` (as diffrax takes its ``t1``,
events and step-size controller as values beside the solver) and judges the state
``Integrator.advance`` returns (``Stop.verdict``):

- ``Equilibrium`` (the default): the run ends at rest, F(x) = 0. Its verdict is the
  common stopping test every integrator is held to — the integrator's own residual at the
  returned state (``Integrator.residual_at``), then, evaluated afresh on the
  full-penalty model, the force residual and the correction residual
  (``Integrator.verified_residual``) — and a successful result gets its stability
  verdict.
- ``Until``: the run ends at the time ``t_end`` (the integrator's time), whatever the
  state; it carries the output times the run records by dense output (its default
  ``rodsim.solvers.recorder.SaveAt``). Taken by the integrators whose ``stops`` name
  it (CVODE and IDA).

A new stop is one class here (or in its own file) with a ``verdict``, named in the
``stops`` of the integrators that can honour it, which read it from ``run.stop``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from rodsim.core.contact_validity import contact_failure
from rodsim.solvers.outcome import Outcome
from rodsim.solvers.recorder import SaveAt, increasing_times
from rodsim.solvers.tolerance import FLOOR_ADVICE, correction_limit, unresolvable_message

if TYPE_CHECKING:
    from rodsim.core.model import Model

__all__ = ["Stop", "Equilibrium", "Until", "Verdict"]


class Run(Protocol):
    """What a stop reads of a run's state (``rodsim.solvers.run_state.RunState``)."""

    tolerance: float
    note: str
    model: Model
    base_model: Model
    warm: bool

    def at_equilibrium(self, residual: float) -> bool: ...

    def where_text(self) -> str: ...


class Judged(Protocol):
    """What a stop asks of the integrator (``rodsim.solvers.base.Integrator``)."""

    @property
    def name(self) -> str: ...

    def advice(self, run: Any = None) -> str: ...

    def residual_at(self, run: Any, x: np.ndarray) -> float: ...

    def verified_residual(self, run: Any, x: np.ndarray) -> tuple[float, float]: ...

    def verified(self, run: Any, residuals: tuple[float, float]) -> bool: ...


@dataclass(frozen=True)
class Verdict:
    """How a run ended: ``success``, the result's ``message``, the ``residual`` it reports
    (the force residual at the state), and whether the state was finite."""

    success: bool
    message: str
    residual: float
    finite: bool


class Stop(ABC):
    """When a run stops (module docstring)."""

    #: Whether a successful run's state is an equilibrium, whose stability the result
    #: assesses (:attr:`Result.stability`).
    at_rest: ClassVar[bool] = False

    def save(self) -> SaveAt:
        """What a run with this stop records unless told otherwise."""
        return SaveAt()

    @abstractmethod
    def verdict(self, integrator: Judged, run: Run, outcome: Outcome) -> Verdict:
        """Judge the state ``outcome.x`` where ``integrator``'s ``advance`` ended on
        ``run``."""


def failure_text(integrator: Judged, run: Run, message: str, residual: float,
                 advice: str | None) -> str:
    """The message of a failed run: which integrator, where, what, and what to try."""
    return (f"{integrator.name} integrator failed at {run.where_text()}: {message} "
            f"(residual {residual:.3g}, tolerance {run.tolerance:.3g}); "
            f"{advice or integrator.advice(run)}")


@dataclass(frozen=True)
class Equilibrium(Stop):
    """Stop at rest: the state's force residual below the run's tolerance, checked afresh
    (module docstring)."""

    at_rest: ClassVar[bool] = True

    def verdict(self, integrator: Judged, run: Run, outcome: Outcome) -> Verdict:
        x, advice = outcome.x, outcome.advice
        finite = bool(np.isfinite(x).all())
        residual = integrator.residual_at(run, x) if finite else float("nan")
        success = outcome.success and finite and run.at_equilibrium(residual)
        message = outcome.message
        verified = (float("nan"), float("nan"))
        if success:
            # The integrator's own test is not the last word: the common stopping test on the
            # full-penalty model, evaluated afresh at the returned state, is.
            verified = integrator.verified_residual(run, x)
            if not integrator.verified(run, verified):
                success = False
                advice = advice or integrator.advice(run)
        # Not a state of rigid contact (rodsim/core/contact_validity.py): deeper than the
        # contact law, or a rod that meets an obstacle folded through itself.
        contact = contact_failure(run.model, x, None if run.warm else run.base_model) \
            if success else None
        outcome_note, contact_advice = "", ""
        if contact is not None:
            success, (outcome_note, contact_advice) = False, contact
        if success and run.note:
            message = f"{message}; {run.note}"
        tolerance = run.tolerance
        if not success:
            if outcome.success and not finite:
                message = "final state is not finite"
            elif outcome.success and run.at_equilibrium(residual) and not outcome_note:
                message = (f"the state it returned is not an equilibrium: evaluated afresh on "
                           f"the full-penalty model, its force residual is {verified[0]:.3g} "
                           f"(tolerance {tolerance:.3g}; its own test found "
                           f"{residual:.3g}) and its correction residual (distance to the "
                           f"equilibrium / the load's displacement) {verified[1]:.3g} "
                           f"(tolerance {correction_limit(run.model, tolerance):.3g})")
                residual = verified[0]
            elif outcome.success and outcome_note:
                message, advice = outcome_note, contact_advice
            elif outcome.success:
                message = (f"stopped with residual {residual:.3g} above the tolerance "
                           f"{tolerance:.3g}")
            floor = unresolvable_message(run.model)
            if floor is not None:  # tried above the floor (Integrator.resolves_below_floor)
                message, advice = f"{message}; {floor}", FLOOR_ADVICE
            message = failure_text(integrator, run, message, residual, advice)
        return Verdict(success, message, residual, finite)


@dataclass(frozen=True)
class Until(Stop):
    """Stop at the time ``t_end`` (s of the integrator's time, > 0), whatever the state;
    record the state at ``times`` (strictly increasing, in [0, t_end]; default: t_end
    alone) by dense output: outputs do not force steps."""

    t_end: float
    times: tuple[float, ...] = field(default=())

    def __post_init__(self) -> None:
        t_end = float(self.t_end)
        if not (math.isfinite(t_end) and t_end > 0.0):
            raise ValueError(f"Until: t_end must be a finite time > 0, got {self.t_end!r}")
        times = increasing_times(self.times, "Until.times") if len(self.times) else (t_end,)
        if times[-1] > t_end:
            raise ValueError(f"Until: output time {times[-1]:g} is after t_end = {t_end:g}")
        object.__setattr__(self, "t_end", t_end)
        object.__setattr__(self, "times", times)

    def save(self) -> SaveAt:
        return SaveAt(times=self.times)

    def verdict(self, integrator: Judged, run: Run, outcome: Outcome) -> Verdict:
        x, advice = outcome.x, outcome.advice
        finite = bool(np.all(np.isfinite(x)))
        residual = integrator.residual_at(run, x) if finite else float("nan")
        success = outcome.success and finite
        message = outcome.message
        if not success:
            if outcome.success:
                message = "final state is not finite"
            floor = unresolvable_message(run.model)
            if floor is not None:  # tried above the floor (Integrator.resolves_below_floor)
                message, advice = f"{message}; {floor}", FLOOR_ADVICE
            message = failure_text(integrator, run, message, residual, advice)
        return Verdict(success, message, residual, finite)
