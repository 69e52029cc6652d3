"""The integrator contract, its registry, and the template solve loop.

Every integrator is one file in :mod:`rodsim.solvers` defining one :class:`Integrator`
subclass with a unique ``name``; defining the class registers it. A subclass implements
:meth:`Integrator.advance`, which drives its method from the model's rest state toward
equilibrium and returns an :class:`Outcome`. The base class owns everything the integrators
share: counting force/Jacobian evaluations, the equilibrium test, the wall-time budget,
progress reporting, catching non-finite states, and turning the outcome into a
:class:`~rodsim.solvers.result.Result`. A failure is never raised past :meth:`Integrator.solve`:
it comes back as ``Result.success = False`` with a message saying which integrator, where,
the residual reached, and what to try.
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from rodsim.core.model import Model
from rodsim.core.schema import Parameter, register_with_options, validate_table
from rodsim.core.stability import Stability, assess
from rodsim.solvers.failure import SolverFailure
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.result import Result

if TYPE_CHECKING:
    from rodsim.core.scene import Scene

__all__ = ["Integrator", "Outcome", "Progress", "SolverFailure", "INTEGRATORS"]

#: Every defined integrator class, by name. Filled by ``Integrator.__init_subclass__``.
INTEGRATORS: dict[str, type[Integrator]] = {}

#: A model whose residual floor (round-off of the internal forces relative to the loads)
#: exceeds this cannot resolve its equilibrium: every integrator refuses it with a diagnostic
#: rather than accept the rest state as "converged".
MAX_RESIDUAL_FLOOR = 1e-3

#: Largest correction residual (:func:`correction_residual`: the distance to the equilibrium
#: over the load's displacement) a result may have, unless the tolerance is looser. Measured
#: on the suite's honest runs (tests/test_integrators.py, test_tendon_integrators.py): at most
#: 3.1e-6 (paper at N = 1000), Newton-finished runs ~1e-9 and below; IDA's wrong success on
#: table1-50g at N = 40 000 (1.4 % L from static's, force residual 4.7e-6 under its
#: tolerance 1.2e-5): 0.048.
CORRECTION_TOLERANCE = 1e-5

#: Re-registrations at equilibrium (Model.reregistered(x, exact=True)) before a run accepts the
#: registration it reached with hysteresis: an equilibrium on the boundary between two
#: parents would otherwise flip between them forever.
MAX_SETTLES = 10

#: Progress callback: (fraction done in [0, 1] or None, one-line status).
Progress = Callable[[float | None, str], None]


@dataclass
class Outcome:
    """What :meth:`Integrator.advance` returns: the final state (free coordinates), whether
    it is an equilibrium by the method's own test, and a short message. Where the method
    stopped, its counters and its history live on the integrator (:meth:`checkpoint`,
    ``counts``, ``history``), so they survive a :class:`SolverFailure` raised mid-run."""

    x: np.ndarray
    success: bool
    message: str


def correction_residual(model: Model, x: np.ndarray, force: np.ndarray) -> float:
    """How far ``x`` is from the equilibrium of ``model``, as a fraction of the load's effect:
    max |J⁻¹ F| / max |J⁻¹ F_load| over the coordinates scaled by their size (L_ref for
    positions, 1 for quaternions), J and the load forces F_load = F(x) − F(x, load 0) at ``x``.

    The numerator is the Newton correction: the distance to the equilibrium to first order.
    The denominator is the displacement the whole load makes, linearised there. So a residual
    imbalance that is a fraction ε of the load, however it is spread over the N nodes, reads
    ε; the max-norm force residual reads ε/N for an imbalance spread smoothly over the rod
    (what let IDA stop 1.4 % L off at N = 40 000 with a force residual 4.7e-6). Its round-off
    floor is that of the positions (the force round-off, ∝ N, lands in stiff directions that
    J⁻¹ maps to displacements of order eps L). 0 when it cannot be told: J singular (the
    stability verdict speaks then) or no load."""
    solver = LinearSolver(model.pattern, model.pattern_rows, model.pattern_cols,
                          (model.band.lower, model.band.upper), model.conservative)
    solve = solver.factorized(model.jacobian_data(x))
    if solve is None:
        return 0.0
    loads = model.force(x, 1.0) - model.force(x, 0.0)
    both = solve(np.column_stack([force, loads]))
    size = np.where(model.is_quaternion, 1.0, model.length_scale)
    correction = float(np.max(np.abs(both[:, 0]) / size))
    reach = float(np.max(np.abs(both[:, 1]) / size))
    if not (np.isfinite(correction) and np.isfinite(reach)) or reach == 0.0:
        return 0.0
    return correction / reach


class History:
    """Per-step record of pseudo-time, residual and the first rod's tip (for Fig. 8)."""

    def __init__(self, model: Model) -> None:
        first = next(iter(model.rods.values()))
        free_of = np.full(model.full_size, -1)
        free_of[model.free] = np.arange(model.n)
        self._tip_free = free_of[first.layout.position_index[-1]]
        self.data: dict[str, list] = {"time": [], "residual": [], "tip": []}

    def record(self, time: float, x: np.ndarray, residual: float) -> None:
        self.data["time"].append(float(time))
        self.data["residual"].append(float(residual))
        self.data["tip"].append(x[self._tip_free].tolist())


class Integrator(ABC):
    """Base class of the four integrators; see the module docstring.

    Parameters
    ----------
    model
        The assembled rod system.
    options
        Validated options of this integrator, an :attr:`Options` instance (:meth:`options_of`).
    tolerance
        Equilibrium residual tolerance (``solver.tolerance``), see :meth:`Model.residual`.
        A tolerance below the model's round-off floor (:attr:`Model.residual_floor`) is
        raised to it; the result records the tolerance actually used.
    max_wall_time
        Wall-time budget [s]; exceeding it is a failure.
    progress
        Optional callback for progress on long runs.
    budget_start
        ``time.perf_counter()`` at which the wall-time budget started (default: when
        :meth:`solve` starts); :func:`rodsim.app.api.solve` passes the time before the model
        was assembled, so the budget covers the assembly too.
    initial_state
        Free coordinates to start from instead of the rest state ``model.x0`` — a warm
        start from a nearby equilibrium (rodsim/app/inverse/track.py). The loads then act in full
       from
        the start (no load ramp or continuation), and ``model`` should carry the
        registration of that state.
    """

    name: ClassVar[str]
    #: One line for ``--help``: the method and the paper's equation it implements.
    summary: ClassVar[str]
    #: How the integrator keeps the quaternions at unit norm.
    quaternion_norm: ClassVar[str]
    parameters: ClassVar[tuple[Parameter, ...]] = ()
    #: Units and meaning of the history's ``time`` (recorded once per step).
    history_time: ClassVar[tuple[str, str]] = ("s", "pseudo-time after each step")

    #: The frozen dataclass of this integrator's options, one typed field per declared
    #: parameter (made from :attr:`parameters` when the class is defined).
    Options: ClassVar[type]

    @classmethod
    def options_of(cls, scene: Scene) -> Any:
        """This integrator's options in ``scene`` (its ``[solver.<name>]`` table), validated,
        with every default filled in, as an :attr:`Options` instance (SceneError on a bad
        value)."""
        return cls.Options(**validate_table(scene.data["solver"].get(cls.name, {}),
                                            cls.parameters, f"solver.{cls.name}"))

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        register_with_options(cls, INTEGRATORS, "integrator")

    def __init__(self, model: Model, options: Any, tolerance: float,
                 max_wall_time: float = 600.0, progress: Progress | None = None,
                 budget_start: float | None = None,
                 initial_state: np.ndarray | None = None) -> None:
        #: The model as built, at rest (its registration is the rest state's).
        self.base_model = model
        #: The model in use: a new one replaces it when the tendon registration changes.
        self.model = model
        self.options = options
        #: The requested tolerance, raised to the model's round-off floor if below it.
        self.tolerance = max(tolerance, model.residual_floor)
        self.max_wall_time = max_wall_time
        self._progress = progress
        #: Counters reported in the result's statistics (see rodsim.solvers.result.STAT_DOCS).
        self.counts: dict[str, float] = {"steps": 0, "newton_iters": 0, "force_evals": 0,
                                         "jacobian_evals": 0, "linear_solves": 0}
        #: Per-step record (pseudo-time, residual, first rod's tip).
        self.history = History(model)
        if model.has_registration:
            self.counts["settles"] = 0
        #: Appended to the message of a successful run (a registration that did not settle).
        self.note = ""
        #: True when the run starts from ``initial_state`` rather than the rest state.
        self.warm = initial_state is not None
        #: The state the run starts from.
        self.start_state = (model.x0 if initial_state is None
                            else np.array(initial_state, dtype=float))
        self.state = self.start_state
        self.where = "start"
        self._start = 0.0
        self._linear: tuple[Model, LinearSolver] | None = None
        self._stability: tuple[Model, np.ndarray, Stability] | None = None
        self._budget_start = budget_start

    def checkpoint(self, x: np.ndarray, where: str | Callable[[], str]) -> None:
        """Remember the last accepted state and where it was reached (for failure reports;
        a callable is formatted only if a report needs it)."""
        self.state = x
        self.where = where

    @property
    def reporting(self) -> bool:
        """Whether a progress callback listens (status lines are formatted only then)."""
        return self._progress is not None

    # ----------------------------------------------------- shared services
    def force(self, x: np.ndarray, load: float = 1.0) -> np.ndarray:
        """F(x), counted; raises SolverFailure on a non-finite value."""
        self.counts["force_evals"] += 1
        f = self.model.force(x, load)
        if not np.all(np.isfinite(f)):
            raise SolverFailure("the force became non-finite (NaN or inf)")
        return f

    def jacobian_data(self, x: np.ndarray, load: float = 1.0) -> np.ndarray:
        """∂F/∂x in the model's CSC pattern order, counted."""
        self.counts["jacobian_evals"] += 1
        data = self.model.jacobian_data(x, load)
        if not np.all(np.isfinite(data)):
            raise SolverFailure("the Jacobian became non-finite (NaN or inf)")
        return data

    def newton_linear_solver(self) -> LinearSolver:
        """The Newton linear solver of :attr:`model`'s pattern (rebuilt when the model is
        replaced by a re-registration)."""
        if self._linear is None or self._linear[0] is not self.model:
            model = self.model
            self._linear = model, LinearSolver(model.pattern, model.pattern_rows,
                                               model.pattern_cols,
                                               (model.band.lower, model.band.upper),
                                               model.conservative)
        return self._linear[1]

    def newton_equilibrium(self, x: np.ndarray, load: float, max_iterations: int,
                           where: str, polish: bool = True,
                           retraction: str | None = None) -> tuple[bool, np.ndarray, int]:
        """Newton on F(x) = 0 at a fixed load fraction from ``x`` (analytic Jacobian, energy
        line search when the model is conservative); returns (converged, x, iterations), which
        the caller counts. ``polish``: see :func:`rodsim.solvers.newton.newton`;
        ``retraction``: how a step moves the rods — ``None``: x + Δx; ``"lengths"``:
        :meth:`Model.step` (segment lengths kept); ``"frames"``: :meth:`Model.turned_step`
        (segments turned as rigid frames)."""
        from rodsim.solvers.newton import NewtonProblem, newton

        model = self.model
        problem = NewtonProblem(
            force=lambda y: self.force(y, load),
            jacobian=lambda y: self.jacobian_data(y, load),
            linear=self.newton_linear_solver(),
            residual=model.residual,
            weight=model.residual_weight,
            potential=(lambda y: model.energy(y, load)) if model.conservative else None,
            step={None: None, "lengths": model.step,
                  "frames": model.turned_step}[retraction],
        )
        outcome = newton(problem, x, self.tolerance, max_iterations, polish=polish,
                         check=self.iteration_check(where))
        return outcome.converged, outcome.x, outcome.iterations

    def residual(self, x: np.ndarray) -> float:
        """Scaled equilibrium residual of state ``x`` (uncounted evaluation)."""
        return self.model.residual(self.model.force(x))

    def at_equilibrium(self, residual: float) -> bool:
        return residual < self.tolerance

    def full_model(self) -> Model:
        """:attr:`model` (its registration) with every penalty at its full value (continuation
        scales back to 1): the model a result must be an equilibrium of."""
        model = self.model
        lowered = {k: 1.0 for k, scale in enumerate(model.term_scales) if scale != 1.0}
        return model.with_term_scales(lowered) if lowered else model

    def verification_force(self, model: Model, x: np.ndarray) -> np.ndarray:
        """The force whose vanishing is this integrator's equilibrium, evaluated afresh on
        ``model`` at ``x`` from ``x`` alone (no state of the run): F(x) here."""
        return model.force(x)

    def verified_residual(self, x: np.ndarray) -> tuple[float, float]:
        """The common stopping test of the returned state ``x`` on :meth:`full_model`,
        evaluated afresh (:meth:`verification_force`): (the scaled force residual of
        :meth:`Model.residual`, the correction residual of :func:`correction_residual`, whose
        meaning and round-off floor do not depend on N). :meth:`solve` fails a run whose own
        test passed but this one does not (:meth:`verified`)."""
        model = self.full_model()
        force = self.verification_force(model, x)
        if not np.all(np.isfinite(force)):
            return float("inf"), float("inf")
        return model.residual(force), correction_residual(model, x, force)

    def verified(self, residuals: tuple[float, float]) -> bool:
        """Whether :meth:`verified_residual`'s pair passes: the force residual below the
        tolerance, the correction residual below it or :data:`CORRECTION_TOLERANCE`."""
        force, correction = residuals
        return (self.at_equilibrium(force)
                and correction < max(self.tolerance, CORRECTION_TOLERANCE))

    def reregister(self, x: np.ndarray, exact: bool = False) -> bool:
        """Apply the tendon registration rule at ``x`` (``exact``: without hysteresis);
        True when a parent changed and :attr:`model` was replaced (new pattern)."""
        if not self.model.has_registration:
            return False
        moved = self.model.reregistered(x, exact)
        if moved is None:
            return False
        self.model = moved
        return True

    def settled(self, x: np.ndarray) -> bool:
        """Whether an equilibrium ``x`` may end the run: its registration needs no change
        without hysteresis (:meth:`Model.reregistered` with ``exact``). False means a parent
        changed and the integrator must go on from ``x`` (the pattern changed too)."""
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

    def stability(self, x: np.ndarray) -> Stability:
        """The stability verdict at the equilibrium ``x`` of :attr:`model`
        (rodsim/core/stability.py),
        computed once per (model, state): the Newton finish asks before the result does."""
        cached = self._stability
        if cached is not None and cached[0] is self.model and cached[1] is x:
            return cached[2]
        verdict = assess(self.model, x)
        self._stability = (self.model, x, verdict)
        return verdict

    def elapsed(self) -> float:
        return time.perf_counter() - self._start

    def check_budget(self, where: str) -> None:
        """Raise SolverFailure once the wall-time budget is spent, before ``where``."""
        if time.perf_counter() - self._budget_start > self.max_wall_time:
            raise SolverFailure(
                f"wall-time budget of {self.max_wall_time:g} s spent before {where}",
                f"try raising solver.max_wall_time, or {self.advice().removeprefix('try ')}")

    def iteration_check(self, where: str) -> Callable[[], None]:
        """A callback for long inner loops (each Newton iteration): checks the wall-time
        budget and reports progress, naming ``where`` and the iteration."""
        count = itertools.count(1)

        def check() -> None:
            iteration = next(count)
            self.check_budget(f"Newton iteration {iteration} at {where}")
            if self.reporting:
                self.report(None, f"{self.name}: {where}, Newton iteration {iteration}")

        return check

    def report(self, fraction: float | None, status: str) -> None:
        if self._progress is not None:
            self._progress(fraction, status)

    # ------------------------------------------------------------ template
    @abstractmethod
    def advance(self) -> Outcome:
        """Run the method from :attr:`start_state` (the rest state ``model.x0`` unless a warm
        start was given) toward equilibrium (see the module docstring)."""

    def advice(self) -> str:
        """What to try when this integrator fails (shown in the failure message)."""
        return ("try another integrator (static, cvode, ida or paper) or a looser "
                "solver.tolerance")

    def solve(self) -> Result:
        """Run the integrator to equilibrium and return a Result (never raises on failure)."""
        self._start = time.perf_counter()
        if self._budget_start is None:
            self._budget_start = self._start
        floor = self.model.residual_floor
        advice = None
        try:
            self.check_budget("the first step (model assembly took it)")
            if floor > MAX_RESIDUAL_FLOOR:
                raise SolverFailure(
                    f"the loads are below the round-off of the internal forces (residual "
                    f"floor {floor:.3g} > {MAX_RESIDUAL_FLOOR:g}): no equilibrium can be told "
                    "apart from the rest state in double precision",
                    "lower K_P, N or the stretch stiffness, or raise the load")
            with np.errstate(all="ignore"):
                outcome = self.advance()
        except SolverFailure as exc:
            outcome = Outcome(self.state, False, str(exc))
            advice = exc.advice
        wall = self.elapsed()
        x = outcome.x
        finite = bool(np.all(np.isfinite(x)))
        residual = self.residual(x) if finite else float("nan")
        success = outcome.success and finite and self.at_equilibrium(residual)
        message = outcome.message
        verified = (float("nan"), float("nan"))
        if success:
            # The integrator's own test is not the last word: the common stopping test on the
            # full-penalty model, evaluated afresh at the returned state, is.
            verified = self.verified_residual(x)
            if not self.verified(verified):
                success = False
                advice = advice or self.advice()
        if success and self.note:
            message = f"{message}; {self.note}"
        if not success:
            if outcome.success and not finite:
                message = "final state is not finite"
            elif outcome.success and self.at_equilibrium(residual):
                message = (f"the state it returned is not an equilibrium: evaluated afresh on "
                           f"the full-penalty model, its force residual is {verified[0]:.3g} "
                           f"(tolerance {self.tolerance:.3g}; its own test found "
                           f"{residual:.3g}) and its correction residual (distance to the "
                           f"equilibrium / the load's displacement) {verified[1]:.3g} "
                           f"(tolerance {max(self.tolerance, CORRECTION_TOLERANCE):.3g})")
                residual = verified[0]
            elif outcome.success:
                message = (f"stopped with residual {residual:.3g} above the tolerance "
                           f"{self.tolerance:.3g}")
            where = self.where() if callable(self.where) else self.where
            message = (f"{self.name} integrator failed at {where}: {message} "
                       f"(residual {residual:.3g}, tolerance {self.tolerance:.3g}); "
                       f"{advice or self.advice()}")
        stats = {**self.counts, "wall_time": wall, "effective_tolerance": self.tolerance}
        return Result.from_model(
            self.model, x if finite else self.state, integrator=self.name,
            options=dataclasses.asdict(self.options), success=success, message=message,
            residual=residual,
            stats=stats, history=self.history.data, history_time=self.history_time,
            stability=self.stability(x) if success else None)
