"""The integrator contract, its registry, and the template solve loop.

Every integrator is one file in ``rodsim.solvers`` defining one ``Integrator``
subclass with a unique ``name``; defining the class registers it. An integrator object holds
configuration only (options, tolerance, wall-time budget, progress callback); a run's state
is a value, a ``rodsim.solvers.run_state.RunState`` (or a subclass the integrator
names as its ``State``) made by ``Integrator.init`` and passed to ``Integrator.run``,
which returns it with the Result: a returned state can start another run (a warm start,
``Integrator.restart``). A subclass implements ``Integrator.advance``, which drives
its method from the state's start until the run's stop and returns an ``Outcome``.
The run's contract is two values on its state: when it stops
(``rodsim.solvers.stops.Stop``: at equilibrium by default, or at a time) and what it
records (``rodsim.solvers.recorder.SaveAt``). The base class and the state own
everything the integrators share: counting and checking force/Jacobian evaluations
(``RunState.force``), the wall-time budget, progress reporting, catching non-finite
states, and turning where the run ended, as its stop judges it
(``rodsim.solvers.stops.Stop.verdict``: the equilibrium test and the result check for
``rodsim.solvers.stops.Equilibrium``), into a
``rodsim.solvers.result.Result``. A failure is never raised past ``Integrator.run``:
it comes back as ``Result.success = False`` with a message saying which integrator, where,
the residual reached, and what to try. A bad argument (a start that is not a state of the
model, a stop the integrator cannot honour) is refused by ``Integrator.init`` in one
line (ValueError).
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar

import numpy as np

from rodsim.core.model import Model
from rodsim.core.schema import Parameter, register_with_options, validate_table
from rodsim.solvers.failure import SolverFailure
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.newton import NewtonProblem, newton
from rodsim.solvers.outcome import Outcome
from rodsim.solvers.recorder import SaveAt
from rodsim.solvers.result import Result
from rodsim.solvers.run_state import (
    MAX_SETTLES,
    History,
    RunState,
    checked_state,
    linear_solver_of,
    plausible_start,
)
from rodsim.solvers.stops import Equilibrium, Stop, Verdict
from rodsim.solvers.tolerance import (
    CORRECTION_TOLERANCE,
    MAX_RESIDUAL_FLOOR,
    correction_limit,
    refuse_unresolvable,
)

if TYPE_CHECKING:
    from rodsim.core.scene import Scene

__all__ = ["Integrator", "Outcome", "Progress", "RunState", "History", "SolverFailure",
           "INTEGRATORS", "MAX_RESIDUAL_FLOOR", "MAX_SETTLES",
           "CORRECTION_TOLERANCE", "LARGE_MODEL_SIZE", "Equilibrium", "SaveAt", "Stop"]

#: Every defined integrator class, by name. Filled by ``Integrator.__init_subclass__``.
INTEGRATORS: dict[str, type[Integrator[Any]]] = {}

#: Progress callback: (fraction done in [0, 1] or None, one-line status).
Progress = Callable[[float | None, str], None]

#: The state type of an integrator (:class:`RunState` or a subclass of it).
S = TypeVar("S", bound=RunState)


#: Free coordinates above which the integrators' Newton solves take their large-model paths
#: (a "large model"): CVODE's Newton finish and the paper integrator's step solves step through
#: the retraction ``static``'s default picks on any model (the frames, :meth:`Model.turned_step`,
#: unless a tendon is a rod or a rod meets an obstacle), IDA's finish through the frames where
#: they are that default (rodsim/solvers/sundials.py, ida.py, paper_euler.py); the paper's
#: steps also stop on the Newton correction (:func:`correction_size`). Linear and
#: length-keeping Newton steps lose their way on long, finely divided rods: from rest on
#: table1-50g, ``static`` through :meth:`Model.step` took 30 iterations at N = 20 000 (the
#: frames: 5), and plain x + Δx stalled on a non-descent direction after 8. Below it the
#: shipped scenes (at most 700 free coordinates) keep their stored equilibria (the frames
#: finish moved table1-50g's CVODE equilibrium by 8e-13 m).
LARGE_MODEL_SIZE = 4000


def retraction_of(model: Model, option: str) -> str:
    """The retraction ``option`` names on ``model``: "auto" is "lengths" if a tendon of the
    model is a rod (the paper's two-rod couplings: "frames" was measured no faster there) or
    a term of the model is one-sided (``Term.unilateral``: a rod meeting an obstacle; on a
    tip pushed onto a plane, the frames' first full steps took the rod where its stiffness
    is indefinite and Newton failed, 20-80 nodes, where "lengths" converged), and "frames"
    otherwise (docs/benchmark-history.md, "Solver design measurements")."""
    if option != "auto":
        return option
    rod_tendon = any(tendon.rod is not None for tendon in model.tendons.values())
    one_sided = any(term.unilateral for term in model.terms)
    return "lengths" if rod_tendon or one_sided else "frames"


def equilibrium_factor(model: Model, x: np.ndarray, linear: LinearSolver | None = None
                       ) -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray] | None]:
    """J's CSC data at ``x`` and J factored (a solve of J X = B, or None when J is
    singular): what ``correction_residual`` needs, and what the stability verdict of
    the same state reuses (``RunState.stability``, ``rodsim.core.stability.assess``).
    ``linear``: the linear solver of ``model``'s pattern, if the caller has one."""
    data = model.jacobian_data(x)
    return data, (linear or linear_solver_of(model)).factorized(data)


def options_dict(options: Any) -> dict[str, Any]:
    """An integrator's options as a dictionary, what ``dataclasses.asdict`` gives: by
    their fields where every value is a scalar (nothing to copy; asdict's recursion
    was ~5 µs of each solve), else by asdict."""
    values = {field.name: getattr(options, field.name)
              for field in dataclasses.fields(options)}
    if all(isinstance(value, (bool, int, float, str, type(None)))
           for value in values.values()):
        return values
    return dataclasses.asdict(options)


def capped_reach(reach: float) -> float:
    """The load's linearised displacement max |J⁻¹ F_load| (coordinates over their sizes,
    F_load = F(x) − F(x, load 0)) as the correction residual counts it: at most 1 (the rod's
    length), and 1 when the scene has no load (moved by its supports or obstacles alone) or
    it is not finite.

    Why the cap: near a bifurcation a soft mode (a buckled column's plane, free to turn)
    amplifies J⁻¹ F_load far beyond L — 7 700 L on a slender rod pinned and pushed along
    its axis — and with it any distance to the equilibrium: CVODE stopped that rod 2.5e-3 L
    from its equilibrium (force residual just under the tolerance) and the correction
    residual read 3e-7. A linearised displacement longer than the rod is the soft mode's,
    not the load's. Measured over the shipped scenes and the seeded robot families (static,
    CVODE and IDA), loads that displace less than L: at most 1.03 L (a user robot), so the
    cap changes no honest run's verdict by more than 3 %."""
    return reach if np.isfinite(reach) and 0.0 < reach < 1.0 else 1.0


def correction_residual(model: Model, x: np.ndarray, force: np.ndarray,
                        factor: tuple[np.ndarray, Callable[[np.ndarray], np.ndarray] | None]
                        | None = None) -> float:
    """How far ``x`` is from the equilibrium of ``model``, as a fraction of the load's effect:
    max |J⁻¹ F| / max |J⁻¹ F_load| over the coordinates scaled by their size (L_ref for
    positions, 1 for quaternions), J and the load forces F_load = F(x) − F(x, load 0) at
    ``x``, the denominator at most 1 (``capped_reach``).

    The numerator is the Newton correction: the distance to the equilibrium to first order.
    The denominator is the displacement the whole load makes, linearised there. So a residual
    imbalance that is a fraction ε of the load, however it is spread over the N nodes, reads
    ε; the max-norm force residual reads ε/N for an imbalance spread smoothly over the rod
    (what let IDA stop 1.4 % L off at N = 40 000 with a force residual 4.7e-6). Its round-off
    floor is that of the positions (the force round-off, ∝ N, lands in stiff directions that
    J⁻¹ maps to displacements of order eps L). 0 when it cannot be told: J singular (the
    stability verdict speaks then). ``factor``: ``equilibrium_factor`` of ``model`` at
    ``x``, if already made."""
    _, solve = factor if factor is not None else equilibrium_factor(model, x)
    if solve is None:
        return 0.0
    loads = model.force(x, 1.0) - model.force(x, 0.0)
    both = solve(np.column_stack([force, loads]))
    size = np.where(model.is_quaternion, 1.0, model.length_scale)
    correction = float((np.abs(both[:, 0]) / size).max())  # methods: no numpy wrappers
    if not np.isfinite(correction):
        return 0.0
    return correction / capped_reach(float((np.abs(both[:, 1]) / size).max()))


def correction_size(model: Model, x: np.ndarray | None = None
                    ) -> Callable[[np.ndarray], float] | None:
    """The size of a Newton correction dx as ``correction_residual`` measures it —
    max |dx| over the load's linearised displacement (``capped_reach``), each coordinate
    over its size (L_ref, or 1 for quaternions) — with the load's displacement taken once
    at ``x`` (default: the rest state): a stopping test for Newton solves
    (``NewtonProblem`` ``correction``) whose meaning does not depend on N. None when J
    is singular there."""
    x = model.x0 if x is None else x
    _, solve = equilibrium_factor(model, x)
    if solve is None:
        return None
    size = np.where(model.is_quaternion, 1.0, model.length_scale)
    reach = float(np.max(np.abs(solve(model.force(x, 1.0) - model.force(x, 0.0))) / size))
    scale = 1.0 / (size * capped_reach(reach))

    def correction(dx: np.ndarray) -> float:
        return float(np.max(np.abs(dx) * scale))
    return correction


#: The power p of the fade (1 − λ)^p F₀ of an unbalanced rest state's force along
#: ``static``'s load continuation (:meth:`Integrator.newton_equilibrium`). The rest force of a
#: rod started inside an obstacle is a penalty force, orders of magnitude above the scene's
#: loads: faded linearly it was still far above them at λ = 0.9999, and the last load steps
#: failed below ``min_load_step``. Measured with ``static`` at its defaults on 30 seeded
#: catheters in straight and arc vessels and the tests' two inclined-plane cantilevers that
#: start through their plane (docs/contact.md, "A rod that starts inside an obstacle"):
#: converged 21 of 32 without the fade, 16 with p = 1, 28 with 3, 30 with 4, 29 with 6.
IMBALANCE_FADE_POWER = 4


class Integrator(ABC, Generic[S]):
    """Base class of the integrators: configuration only; see the module docstring.

    Parameters
    ----------
    options
        Validated options of this integrator, an ``Options`` instance (``options_of``).
    tolerance
        Equilibrium residual tolerance (``solver.tolerance``), see ``Model.force_residual``.
        A run raises a tolerance below its model's round-off floor
        (``Model.residual_floor``) to it (``RunState.tolerance``); the result
        records the tolerance actually used.
    max_wall_time
        Wall-time budget [s] of a run; exceeding it is a failure.
    progress
        Optional callback for progress on long runs.

    A run: ``state = integrator.init(model)`` (or with ``initial_state``: a warm start from a
    nearby equilibrium, the loads in full from the start, ``model`` carrying the registration
    of that state), then ``result, state = integrator.run(state)``; ``solve`` does both.
    ``restart`` starts a new run from a returned state on a nearby model.
    """

    name: ClassVar[str]
    #: One line for ``--help``: the method and the paper's equation it implements.
    summary: ClassVar[str]
    #: How the integrator keeps the quaternions at unit norm.
    quaternion_norm: ClassVar[str]
    #: The options' declarations (``[solver.<name>]``): made from the fields of
    #: :attr:`Options` when the class is defined (``rodsim.core.schema.option``), each option
    #: written once there; never written in the class.
    parameters: ClassVar[tuple[Parameter, ...]] = ()
    #: Units and meaning of the history's ``time`` (recorded once per step).
    history_time: ClassVar[tuple[str, str]] = ("s", "pseudo-time after each step")
    #: The class of this integrator's run state.
    State: ClassVar[type[RunState]] = RunState
    #: The stops a run of this integrator honours (:mod:`rodsim.solvers.stops`; it reads
    #: ``run.stop`` in :meth:`advance`).
    stops: ClassVar[tuple[type[Stop], ...]] = (Equilibrium,)
    #: Whether :meth:`advance` reports each step's dense output to the recorder
    #: (:meth:`Recorder.dense`), so that a run can record at requested times
    #: (``SaveAt.times``) without forcing steps.
    dense_output: ClassVar[bool] = False
    #: Whether a continuation step benefits from a predicted start (the secant predictor of
    #: rodsim/app/inverse/track.py): a Newton solve does; a pseudo-dynamics run from a
    #: predicted state was not measured, and starts from the last equilibrium.
    takes_predictor: ClassVar[bool] = False
    #: Whether a model whose residual floor exceeds ``MAX_RESIDUAL_FLOOR`` is tried rather
    #: than refused at the start (``rodsim.solvers.tolerance``). Newton (static) is: the
    #: floor bounds how well the force residual can be read, not how close the state is,
    #: and its result is then held to the correction residual alone
    #: (``CORRECTION_TOLERANCE``, not loosened by the floor; :meth:`verified`). A
    #: pseudo-dynamics run is refused: measured on steel and nitinol wires of L/r 5 000 to
    #: 8 400, IDA stalled for 14–477 s and then failed on every one.
    resolves_below_floor: ClassVar[bool] = False

    #: The frozen dataclass of this integrator's options, declared beside the class: one
    #: typed field per option, each declared once by ``rodsim.core.schema.option`` (its
    #: default, unit, doc and range), from which :attr:`parameters` is made.
    Options: ClassVar[type]

    @classmethod
    def options_of(cls, scene: Scene) -> Any:
        """This integrator's options in ``scene`` (its ``[solver.<name>]`` table), validated,
        with every default filled in, as an ``Options`` instance (SceneError on a bad
        value)."""
        return cls.Options(**validate_table(scene.data["solver"].get(cls.name, {}),
                                            cls.parameters, f"solver.{cls.name}"))

    @classmethod
    def for_scene(cls, scene: Scene, progress: Progress | None = None,
                  max_wall_time: float | None = None) -> Integrator[Any]:
        """This integrator configured by ``scene`` (its options, tolerance and wall-time
        budget, or ``max_wall_time``)."""
        solver = scene.solver
        return cls(cls.options_of(scene), float(solver.tolerance),
                   float(solver.max_wall_time if max_wall_time is None else max_wall_time),
                   progress)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        register_with_options(cls, INTEGRATORS, "integrator")

    def __init__(self, options: Any, tolerance: float, max_wall_time: float = 600.0,
                 progress: Progress | None = None) -> None:
        self.options = options
        #: The requested tolerance (a run raises it to its model's round-off floor).
        self.tolerance = tolerance
        self.max_wall_time = max_wall_time
        self._progress = progress

    # ------------------------------------------------------------ the state
    def init(self, model: Model, initial_state: np.ndarray | None = None,
             budget_start: float | None = None, *, stop: Stop | None = None,
             save: SaveAt | None = None) -> S:
        """A new run's state on ``model``, from its rest state or ``initial_state`` (a warm
        start: free coordinates of ``model``, ValueError on anything else,
        ``rodsim.solvers.run_state.checked_state``); ``budget_start``:
        ``time.perf_counter()`` at which the wall-time budget started (default: now;
        ``rodsim.app.api.solve`` passes the time before the model was assembled, so the
        budget covers the assembly too). ``stop``: when the run stops (default: at
        equilibrium, ``rodsim.solvers.stops.Equilibrium``; one of ``stops``);
        ``save``: what it records (default: what the stop asks for,
        ``rodsim.solvers.recorder.SaveAt``). ValueError, one line, on a stop or
        output times this integrator cannot honour."""
        stop = Equilibrium() if stop is None else stop
        if not isinstance(stop, self.stops):
            raise ValueError(f"the {self.name} integrator cannot stop by "
                             f"{type(stop).__name__}; it stops by "
                             + ", ".join(kind.__name__ for kind in self.stops))
        save = stop.save() if save is None else save
        if save.times and not (self.dense_output and not stop.at_rest):
            raise ValueError(f"output times (SaveAt.times) need an integrator with dense "
                             f"output and a stop at a time (Until); {self.name} stopping by "
                             f"{type(stop).__name__} records steps only")
        state = self.State.new(model, self.tolerance, initial_state, budget_start, stop,
                               save, **self.state_fields(model, initial_state is not None))
        self.prepare(state)  # type: ignore[arg-type]
        return state  # type: ignore[return-value]

    def restart(self, previous: RunState | None, model: Model,
                x: np.ndarray | None = None, budget_start: float | None = None) -> S:
        """A continuation step's state: a warm start on ``model`` (nearby the model of
        ``previous``, carrying its registration) from ``x`` (default: the equilibrium
        ``previous.x``), marked ``continued`` and carrying what ``carry`` keeps of
        ``previous`` (None: nothing, e.g. after a cold run of another integrator)."""
        if x is None:
            assert previous is not None, "restart needs a previous state or a start"
            x = previous.x
        state = self.init(model, x, budget_start)
        state.continued = True
        if previous is not None:
            self.carry(previous, state)
        return state

    def carry(self, previous: RunState, state: S) -> None:
        """Keep what a continuation step reuses of the state a run returned (default:
        nothing; ``static`` keeps its linear solver)."""

    def predicted(self, model: Model, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """The start a continuation step on ``model`` takes from the predictor ``x + dx``
        (``x`` the last equilibrium, ``dx`` the path's last chord scaled to the step; only
        for an integrator that ``takes_predictor``): ``x + dx`` here."""
        return x + dx

    @classmethod
    def work(cls, stats: dict[str, float]) -> int:
        """The work of a run, from its statistics, as track reports it per step: steps
        here (Newton iterations for ``static``)."""
        return int(stats["steps"])

    def state_fields(self, model: Model, warm: bool) -> dict[str, Any]:
        """The fields of this integrator's own ``State`` (beyond ``RunState``'s) for
        a new run on ``model`` (``warm``: from a given state); default: none."""
        return {}

    def prepare(self, state: S) -> None:
        """Complete a new run's state (its own counters; default: nothing)."""

    @property
    def reporting(self) -> bool:
        """Whether a progress callback listens (status lines are formatted only then)."""
        return self._progress is not None

    # ----------------------------------------------------- shared services
    def newton_equilibrium(self, run: S, x: np.ndarray, load: float, max_iterations: int,
                           where: str, polish: bool = True,
                           retraction: str | None = None,
                           imbalance: np.ndarray | None = None
                           ) -> tuple[bool, np.ndarray, int]:
        """Newton on F(x) = 0 of ``run.model`` at a fixed load fraction from ``x`` (analytic
        Jacobian, energy line search when the model is conservative); returns (converged, x,
        iterations), which the caller counts. ``polish``: see
        ``rodsim.solvers.newton.newton``; ``retraction``: how a step moves the rods —
        ``None``: x + Δx; ``"lengths"``: ``Model.step`` (segment lengths kept);
        ``"frames"``: ``Model.turned_step`` (segments turned as rigid frames);
        ``"auto"``: one of the two by the model's content (``retraction_of``).
        ``imbalance``: the force F₀ of the unloaded rest state when it is not an equilibrium
        (a rod that starts inside an obstacle): Newton then solves
        F(x) = (1 − load)^``IMBALANCE_FADE_POWER`` F₀, whose root at load 0 is the rest
        state (``static``'s load continuation, ``rodsim.solvers.static.rest_imbalance``)."""
        model = run.model
        retraction = retraction_of(model, retraction) if retraction == "auto" else retraction
        if imbalance is None or load >= 1.0:
            def force(y: np.ndarray) -> np.ndarray:
                return run.force(y, load)

            def potential(y: np.ndarray) -> float:
                return model.energy(y, load)
        else:
            shift = (1.0 - load) ** IMBALANCE_FADE_POWER * imbalance

            def force(y: np.ndarray) -> np.ndarray:
                return run.force(y, load) - shift

            def potential(y: np.ndarray) -> float:  # F − s = −∇(E + s·y)
                return model.energy(y, load) + float(shift @ y)
        def prepare(y: np.ndarray) -> None:
            model.evaluate(y, load)  # F and J kept: the counted calls below take them

        problem = NewtonProblem(
            force=force,
            jacobian=lambda y: run.jacobian_data(y, load),
            linear=run.linear_solver(),
            force_residual=model.force_residual,
            weight=model.residual_weight,
            potential=potential if model.conservative else None,
            step={None: None, "lengths": model.step,
                  "frames": model.turned_step}[retraction],
            # J kept by the memo; compiled only (a tiered model's charges stay as they were)
            prepare=prepare if model.keeps_jacobians else None,
        )
        outcome = newton(problem, x, run.tolerance, max_iterations, polish=polish,
                         check=self.iteration_check(run, where))
        return outcome.converged, outcome.x, outcome.iterations

    def residual_at(self, run: S, x: np.ndarray) -> float:
        """The scaled force residual at the state ``x`` by this integrator's own
        equilibrium (uncounted): of F(x) on ``run.model`` here (``RunState.residual_at``;
        IDA: of its constrained force)."""
        return run.residual_at(x)

    def verification_force(self, run: S, model: Model, x: np.ndarray) -> np.ndarray:
        """The force whose vanishing is this integrator's equilibrium, evaluated afresh on
        ``model`` at ``x`` from ``x`` alone (nothing else of the run): F(x) here."""
        return model.force(x)

    def verified_residual(self, run: S, x: np.ndarray) -> tuple[float, float]:
        """The common stopping test of the returned state ``x`` on
        ``RunState.full_model``, evaluated afresh (``verification_force``): (the
        scaled force residual of ``Model.force_residual``, the correction residual of
        ``correction_residual``, whose meaning and round-off floor do not depend on N).
        ``run`` fails a run whose own test passed but this one does not
        (``verified``)."""
        model = run.full_model()
        force = self.verification_force(run, model, x)
        if not np.isfinite(force).all():
            return float("inf"), float("inf")
        factor = equilibrium_factor(model, x,
                                    run.linear_solver() if model is run.model else None)
        run.factored = model, x.copy(), factor  # the verdict of the same state reuses it
        return model.force_residual(force), correction_residual(model, x, force, factor)

    @staticmethod
    def verified(run: RunState, residuals: tuple[float, float]) -> bool:
        """Whether ``verified_residual``'s pair passes: the force residual below the
        tolerance, the correction residual below it or ``CORRECTION_TOLERANCE``."""
        force, correction = residuals
        return (run.at_equilibrium(force)
                and correction < correction_limit(run.full_model(), run.tolerance))

    def budget_spent(self, run: S) -> bool:
        """Whether ``run``'s wall-time budget is spent."""
        return time.perf_counter() - run.budget_start > self.max_wall_time

    def check_budget(self, run: S, where: str) -> None:
        """Raise SolverFailure once the wall-time budget is spent, before ``where``."""
        if self.budget_spent(run):
            raise SolverFailure(
                f"wall-time budget of {self.max_wall_time:g} s spent before {where}",
                f"try raising solver.max_wall_time, or "
                f"{self.advice(run).removeprefix('try ')}")

    def iteration_check(self, run: S, where: str) -> Callable[[], None]:
        """A callback for long inner loops (each Newton iteration): checks the wall-time
        budget and reports progress, naming ``where`` and the iteration."""
        count = itertools.count(1)

        def check() -> None:
            iteration = next(count)
            if self.budget_spent(run):  # the message is made only then
                self.check_budget(run, f"Newton iteration {iteration} at {where}")
            if self.reporting:
                self.report(None, f"{self.name}: {where}, Newton iteration {iteration}")

        return check

    def report(self, fraction: float | None, status: str) -> None:
        if self._progress is not None:
            self._progress(fraction, status)

    # ------------------------------------------------------------ template
    @abstractmethod
    def advance(self, run: S) -> Outcome:
        """Run the method from ``run.start`` (the rest state ``model.x0`` unless a warm
        start was given) toward equilibrium (see the module docstring), updating ``run``."""

    def advice(self, run: S | None = None) -> str:
        """What to try when this integrator fails (shown in the failure message)."""
        return ("try another integrator (" + ", ".join(INTEGRATORS) + ") or a looser "
                "solver.tolerance")

    def solve(self, model: Model, initial_state: np.ndarray | None = None,
              budget_start: float | None = None) -> Result:
        """Run the integrator on ``model`` to equilibrium and return a Result (never raises
        on failure): ``init`` then ``run``; a start that no run reaches (a force
        passed as a state, ``plausible_start``) is refused in one line."""
        if initial_state is not None:
            plausible_start(model, checked_state(model, initial_state))
        return self.run(self.init(model, initial_state, budget_start))[0]

    def run(self, run: S, verdict: bool = True) -> tuple[Result, S]:
        """Run the integrator from the state ``run`` until ``run.stop`` (default: to
        equilibrium): the Result (never raises on failure) and the state reached (its model
        carries the registration reached). The stop judges where ``advance`` ended
        (``Stop.verdict``). ``verdict``: give a
        successful equilibrium its stability verdict (a caller assessing the equilibrium
        itself says False). TypeError, one line, on anything but a run's state (a vector
        of coordinates or forces: ``init`` makes the state, ``solve`` does both)."""
        if not isinstance(run, RunState):
            raise TypeError(f"{type(self).__name__}.run takes a run's state (from "
                            f"init(model, x)), not a {type(run).__name__}; solve(model, x) "
                            "runs from a vector")
        judged, x, stats = self.settle(run)
        result = Result.from_model(
            run.model, x, integrator=self.name,
            options=options_dict(self.options), success=judged.success,
            message=judged.message, residual=judged.residual,
            stats=stats, history=run.history.data, history_time=self.history_time,
            stability=(run.stability(x) if judged.success and verdict and run.stop.at_rest
                       else None),
            trajectory=run.recorder.trajectory(run.model, self.history_time))
        return result, run

    def settle(self, run: S) -> tuple[Verdict, np.ndarray, dict[str, float]]:
        """``run`` without its Result: the stop's verdict where ``advance`` ended, the
        state (that one where finite, else the run's last) and the statistics — what a
        continuation step reads (rodsim/app/inverse/continuation.py), without the rods'
        shapes and the tendons' tensions a Result assembles. ``run`` judges the same."""
        if not isinstance(run, RunState):
            raise TypeError(f"{type(self).__name__}.settle takes a run's state (from "
                            f"init(model, x)), not a {type(run).__name__}")
        ended = self.ended(run)
        wall = run.elapsed()
        judged = run.stop.verdict(self, run, ended)
        x = ended.x
        if judged.success:
            run.x = x
        stats = {**run.counts, "wall_time": wall, "effective_tolerance": run.tolerance}
        return judged, x if judged.finite else run.x, stats

    def ended(self, run: S) -> Outcome:
        """``advance`` on ``run`` from a fresh clock, its failures caught: where it
        ended. A ``SolverFailure`` ends at the last checkpoint with the failure's
        advice; so does a division by zero in the model (a state outside its domain: a
        quaternion of zero length), which would otherwise escape the run."""
        run.clock_start = time.perf_counter()
        try:
            self.check_budget(run, "the first step (model assembly took it)")
            if not self.resolves_below_floor:
                refuse_unresolvable(run.model)
            with np.errstate(all="ignore"):
                outcome = self.advance(run)
        except SolverFailure as exc:
            return Outcome(run.x, False, str(exc), exc.advice)
        except ZeroDivisionError:
            return Outcome(run.x, False, "the model could not be evaluated at a state "
                           "(division by zero: a quaternion of zero length)")
        return outcome
