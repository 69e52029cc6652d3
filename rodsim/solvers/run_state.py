"""A run's state, as a value: what an integrator's run has reached, apart from the integrator.

An ``rodsim.solvers.base.Integrator`` holds configuration only (its options, the
requested tolerance, the wall-time budget, the progress callback). Everything a run changes
lives in a ``RunState``, made by ``Integrator.init`` and passed to and returned by
``Integrator.run`` (as diffrax's ``init`` / ``step(…, state)``): the model in use (its
tendon registration and penalty scales), the effective tolerance, the counters, the last
accepted state and where it was reached (``RunState.checkpoint``), the run's contract —
when it stops (``rodsim.solvers.stops.Stop``) and the recorder of what it records
(``rodsim.solvers.recorder.Recorder``, behind ``RunState.record``) — and the run's
clock. A run starts from a state of its model's free coordinates, refused in one line
otherwise (``checked_state``). The state's own
``RunState.force`` and ``RunState.jacobian_data`` are the only way a run evaluates
the model: each evaluation is counted and checked for non-finite values there (as scipy's
``OdeSolver`` counts through its base's ``fun``). An integrator needing more state (the
SUNDIALS system, IDA's last y, the static solve's kept factorisation) subclasses
``RunState`` with typed fields of its own.

A state returned by a run can start another (a warm start): ``Integrator.init`` with
``initial_state``, or ``Integrator.restart`` from a returned state on a nearby model.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, Self

import numpy as np

from rodsim.core.model import Model
from rodsim.core.stability import Stability, assess
from rodsim.solvers.failure import SolverFailure
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.recorder import History, Recorder, SaveAt
from rodsim.solvers.stops import Equilibrium, Stop
from rodsim.solvers.tolerance import effective_tolerance

__all__ = ["RunState", "History", "MAX_SETTLES", "linear_solver_of", "checked_state"]

#: Re-registrations at equilibrium (Model.reregistered(x, exact=True)) before a run accepts the
#: registration it reached with hysteresis: an equilibrium on the boundary between two
#: parents would otherwise flip between them forever.
MAX_SETTLES = 10


#: The linear solver of the last pattern asked for, with the symmetry it was made for: the
#: models of a track's or a fit's steps share one pattern (rodsim/app/inverse/), and each
#: step's run and its verification would otherwise rebuild the same band offsets.
_LAST_SOLVER: tuple[object, bool, LinearSolver] | None = None


def linear_solver_of(model: Model) -> LinearSolver:
    """The Newton linear solver of ``model``'s Jacobian pattern (band or sparse); the one
    made for the last pattern asked for when it is the same pattern object and symmetry (a
    solver holds only offsets computed from the pattern, and its counts)."""
    global _LAST_SOLVER
    symmetric = model.conservative
    cached = _LAST_SOLVER
    if cached is not None and cached[0] is model.pattern and cached[1] == symmetric:
        return cached[2]
    solver = LinearSolver(model.pattern, model.pattern_rows, model.pattern_cols,
                          (model.band.lower, model.band.upper), symmetric)
    _LAST_SOLVER = model.pattern, symmetric, solver
    return solver


def base_counts() -> dict[str, float]:
    """The counters every run reports (see rodsim.solvers.result.STAT_DOCS)."""
    return {"steps": 0, "newton_iters": 0, "force_evals": 0, "jacobian_evals": 0,
            "linear_solves": 0}


def checked_state(model: Model, state: Any) -> np.ndarray:
    """``state`` as a start of a run on ``model``: a copy, as floats, of its free
    coordinates (one vector of length ``model.n``, finite, every quaternion of non-zero
    length, as ``Model.step`` keeps them); ValueError, one line, otherwise — a
    full-coordinate vector or another model's state passed where this model's state was
    expected. A caller's start is checked further by ``plausible_start``."""
    x = np.array(state, dtype=float)
    if x.shape != (model.n,):
        raise ValueError(f"a state of this model is a vector of its {model.n} free "
                         f"coordinates (Model.x0, Result.state), got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("the state has non-finite coordinates (NaN or inf)")
    quaternions = model.full(x)[np.concatenate(
        [rod.layout.quaternion_index for rod in model.rods.values()])]
    lengths = np.linalg.norm(quaternions, axis=1)
    if np.any(lengths < 1e-3):
        raise ValueError(f"the state is not one of this model: a quaternion has length "
                         f"{lengths.min():.3g} (unit length expected; a force or another "
                         f"array passed as a state?)")
    return x


def plausible_start(model: Model, x: np.ndarray) -> None:
    """ValueError, one line, when a caller's start ``x`` (free coordinates of ``model``)
    keeps every quaternion at rest exactly and stretches a segment past
    ``MAX_START_STRETCH`` times its rest length: a force passed where a state was
    expected. The free coordinates are offsets from the rest
    state, so a force read as a state keeps the rest quaternions; its position entries
    (newtons read as metres) stretch the segments where the loads act (table1-20g: 11.5
    times the rest length at the tip). A loaded equilibrium turns its segments, however
    far it is stretched (table1 under an absurd 1e4 kg: 148 times), so a start with a
    quaternion off its rest value is accepted. Not applied to the warm starts a continuation
    predicts (``Integrator.restart``): extrapolated over a step it cannot pass, such a
    start may be stretched, and its run's failure is the step's report."""
    full, rest = model.full(x), model.full(model.x0)
    quaternions = np.concatenate([rod.layout.quaternion_index for rod in model.rods.values()])
    if np.any(full[quaternions] != rest[quaternions]):
        return  # a turned segment: a state, however loaded (1e4 kg stretches table1 148x)
    stretch = max(float(np.max(segment_lengths(full, rod) / segment_lengths(rest, rod)))
                  for rod in model.rods.values())
    if stretch > MAX_START_STRETCH:
        raise ValueError(f"the state is not one of this model: a segment is stretched "
                         f"{stretch:.3g} times its rest length (a force or another array "
                         f"passed as a state?)")


#: The largest stretch (segment length over rest length) :func:`plausible_start` accepts
#: in a caller's start: a rod's stretch strain stays far below 1 at an equilibrium.
MAX_START_STRETCH = 2.0


def segment_lengths(full: np.ndarray, rod: Any) -> np.ndarray:
    """The lengths of the segments of ``rod`` in the full state ``full``."""
    positions = full[rod.layout.position_index]
    return np.asarray(np.linalg.norm(np.diff(positions, axis=0), axis=1))


@dataclass(eq=False)
class RunState:
    """The state of one run of an integrator (module docstring).

    Attributes
    ----------
    model
        The model in use: replaced (a new value) when the tendon registration changes or
        penalties are scaled.
    base_model
        The model as built, at rest (its registration is the rest state's).
    tolerance
        The effective tolerance: the requested one raised to the model's round-off floor.
    start
        The free coordinates the run starts from (``model.x0`` unless a warm start).
    warm
        True when the run starts from a given state (loads in full from the start).
    continued
        True for a continuation step (a warm start from a returned state).
    x, where
        The last accepted state and where it was reached (a callable is formatted only when
        a failure report needs it).
    counts
        Counters reported in the result's statistics.
    recorder
        What the run records (``rodsim.solvers.recorder.Recorder``, behind
        ``record``): the per-step history and the trajectory its ``SaveAt`` asks for.
    stop
        When the run stops (``rodsim.solvers.stops.Stop``: at equilibrium, or at a
        time).
    budget_start, clock_start
        ``time.perf_counter()`` when the wall-time budget and the run started.
    note
        Appended to the message of a successful run.
    last_force
        The last F a right-hand side evaluated (a screen for the equilibrium test; None
        before the first).
    """

    model: Model
    base_model: Model
    tolerance: float
    start: np.ndarray
    warm: bool
    x: np.ndarray
    counts: dict[str, float]
    recorder: Recorder
    budget_start: float
    clock_start: float
    where: str | Callable[[], str] = "start"
    stop: Stop = field(default_factory=Equilibrium)
    #: True for a continuation step (:meth:`Integrator.restart`): a warm start from the
    #: state a run returned, on a nearby model, which an integrator may solve more cheaply.
    continued: bool = False
    note: str = ""
    last_force: np.ndarray | None = None
    _linear: tuple[Model, LinearSolver] | None = field(default=None, repr=False)
    _stability: tuple[Model, np.ndarray, Stability] | None = field(default=None, repr=False)
    #: (model, state) where :meth:`reregister` last found the model's registration exact
    #: (``exact`` and no parent changed): :meth:`registered_exactly`.
    _exact: tuple[Model, np.ndarray] | None = field(default=None, repr=False)
    #: (model, state, (J's data, J factored)) of the last verified state
    #: (:meth:`Integrator.verified_residual`), which its verdict reuses.
    factored: tuple[Model, np.ndarray, tuple[np.ndarray, Callable[[np.ndarray], np.ndarray]
                                              | None]] | None = field(default=None, repr=False)

    @classmethod
    def new(cls, model: Model, tolerance: float, initial_state: np.ndarray | None = None,
            budget_start: float | None = None, stop: Stop | None = None,
            save: SaveAt | None = None, **fields: Any) -> Self:
        """A fresh state on ``model`` from its rest state or ``initial_state``
        (``checked_state``), stopping by ``stop`` (default: ``Equilibrium``) and
        recording what ``save`` asks for (default: what the stop asks for)."""
        now = time.perf_counter()
        start = model.x0 if initial_state is None else checked_state(model, initial_state)
        stop = Equilibrium() if stop is None else stop
        counts = base_counts()
        if model.has_registration:
            counts["settles"] = 0
        return cls(model=model, base_model=model,
                   tolerance=effective_tolerance(model, tolerance), start=start,
                   warm=initial_state is not None, x=start, counts=counts,
                   recorder=Recorder(model, stop.save() if save is None else save),
                   stop=stop, budget_start=now if budget_start is None else budget_start,
                   clock_start=now, **fields)

    def derived(self, **changes: Any) -> Self:
        """A copy with ``changes`` (its counters shared unless given): for a trial on another
        model (lowered penalties, a finish) that the run adopts or drops."""
        return replace(self, **changes)

    # ------------------------------------------------------ counted evaluations
    def force(self, x: np.ndarray, load: float = 1.0, check: bool = True) -> np.ndarray:
        """F(x) on ``model``, counted; SolverFailure on a non-finite value (unless not
        ``check``: a caller that tests the value itself)."""
        self.counts["force_evals"] += 1
        f = self.model.force(x, load)
        if check and not np.isfinite(f).all():  # the method: no numpy wrapper
            raise SolverFailure("the force became non-finite (NaN or inf)")
        return f

    def jacobian_data(self, x: np.ndarray, load: float = 1.0) -> np.ndarray:
        """∂F/∂x in ``model``'s CSC pattern order, counted; SolverFailure on a
        non-finite value."""
        self.counts["jacobian_evals"] += 1
        data = self.model.jacobian_data(x, load)
        if not np.isfinite(data).all():
            raise SolverFailure("the Jacobian became non-finite (NaN or inf)")
        return data

    def residual_at(self, x: np.ndarray) -> float:
        """The scaled force residual (``Model.force_residual``) of F at the state ``x``
        (uncounted evaluation)."""
        return self.model.force_residual(self.model.force(x))

    def at_equilibrium(self, residual: float) -> bool:
        return residual < self.tolerance

    def linear_solver(self) -> LinearSolver:
        """The Newton linear solver of ``model``'s pattern (rebuilt when the model is
        replaced by one of another pattern: kept across penalty scales, as
        ``static``'s ``carry`` keeps it across continuation steps)."""
        linear = self._linear
        if linear is None or linear[0] is not self.model:
            if (linear is None or linear[0].pattern is not self.model.pattern
                    or linear[0].conservative != self.model.conservative):
                linear = self.model, linear_solver_of(self.model)
            else:  # the same pattern (other penalty scales): the same solver
                linear = self.model, linear[1]
            self._linear = linear
        return linear[1]

    # ------------------------------------------------------------- progress
    def checkpoint(self, x: np.ndarray, where: str | Callable[[], str]) -> None:
        """Remember the last accepted state and where it was reached."""
        self.x = x
        self.where = where

    def record(self, time: float, x: np.ndarray, residual: float) -> None:
        """An accepted step ended at ``time`` (the integrator's time) in the state ``x``
        with the force residual ``residual``: to the recorder."""
        self.recorder.record(time, x, residual)

    @property
    def history(self) -> History:
        """The per-step history the recorder keeps."""
        return self.recorder.history

    def where_text(self) -> str:
        return self.where() if callable(self.where) else self.where

    def elapsed(self) -> float:
        return time.perf_counter() - self.clock_start

    # --------------------------------------------------------- registration
    def reregister(self, x: np.ndarray, exact: bool = False) -> bool:
        """Apply the tendon registration rule at ``x`` (``exact``: without hysteresis);
        True when a parent changed and ``model`` was replaced (new pattern)."""
        if not self.model.has_registration:
            return False
        moved = self.model.reregistered(x, exact)
        if moved is None:
            if exact:
                self._exact = self.model, x
            return False
        self.model = moved
        return True

    def registered_exactly(self, x: np.ndarray) -> bool:
        """Whether ``model`` is known to carry the exact registration of the state
        ``x`` (no hysteresis: ``Model.reregistered`` with ``exact`` at ``x`` would change
        nothing) — true after ``reregister`` with ``exact`` found nothing to change at
        that state on this model, or for a model without registration."""
        if not self.model.has_registration:
            return True
        known = self._exact
        return known is not None and known[0] is self.model and np.array_equal(known[1], x)

    def settled(self, x: np.ndarray) -> bool:
        """Whether an equilibrium ``x`` may end the run: its registration needs no change
        without hysteresis (``Model.reregistered`` with ``exact``). False means a parent
        changed and the run must go on from ``x`` (the pattern changed too)."""
        if not self.model.has_registration:
            return True
        if self.counts["settles"] >= MAX_SETTLES:
            self.note = (f"the tendon registration did not settle in {MAX_SETTLES} "
                         "re-registrations (a point's equilibrium is on the boundary between "
                         "two parents); the registration reached with hysteresis is kept")
            return True
        if not self.reregister(x, exact=True):
            return True
        self.counts["settles"] += 1
        return False

    # ------------------------------------------------------------- verdicts
    def full_model(self) -> Model:
        """``model`` (its registration) with every penalty at its full value (continuation
        scales back to 1): the model a result must be an equilibrium of."""
        model = self.model
        lowered = {k: 1.0 for k, scale in enumerate(model.term_scales) if scale != 1.0}
        return model.with_term_scales(lowered) if lowered else model

    def stability(self, x: np.ndarray) -> Stability:
        """The stability verdict at the equilibrium ``x`` of ``model``
        (rodsim/core/stability.py), computed once per (model, state)."""
        cached = self._stability
        if cached is not None and cached[0] is self.model and cached[1] is x:
            return cached[2]
        verdict = assess(self.model, x, self.factorisation_at(self.model, x))
        self._stability = (self.model, x, verdict)
        return verdict

    def factorisation_at(self, model: Model, x: np.ndarray
                         ) -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray] | None
                                    ] | None:
        """(J's CSC data, J factored) of ``model`` at ``x`` if the last verification made
        them (the same model object and the same state), else None."""
        factored = self.factored
        if factored is None or factored[0] is not model or not np.array_equal(factored[1], x):
            return None
        return factored[2]
