"""Equilibria of nearby parameter values, each solved from the previous one (a warm start).

Tracking (rodsim/app/inverse/track.py), fitting (fit.py) and inverse kinematics (reach.py)
solve many equilibria whose parameters differ a little. ``Continuation`` is the
continuation policy alone: it keeps the last equilibrium — the run state an integrator
returned, whose model carries its tendon registration — and solves the next scene from it
with any registered integrator, through the integrator contract
(``Integrator.restart``, a continuation step, then ``Integrator.run``;
rodsim/solvers/base.py). The next model is ``Model.with_values`` of the last (only the
terms whose options changed are rebuilt; any other change falls back to
``Model.with_scene``: same free-coordinate order, same registration, the Jacobian pattern
reused when the elements keep their coordinates); the step starts from the last state or a
given predictor — or, when a base support moves (insertion, rotation), the last state
carried rigidly with it (``Model.carried``). How the integrator solves a continuation
step is its own (``static``: chord iterations with a kept factorisation, then Newton,
rodsim/solvers/static.py; the pseudo-dynamic ones: a run from that state, the loads in full
from the start).

A solve that fails leaves the continuation where it was. ``Continuation.walk`` moves
between two sets of parameter values and retries a failed solve with half the increment,
halved again on each failure and doubled after an easy sub-step, up to
``MAX_HALVINGS`` failed attempts. ``ScaledEquilibria`` wraps a continuation as the
function of (scaled) parameter values that a fit or a reach minimises over.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey, scene_with
from rodsim.app.inverse.sensitivity import equilibrium_sensitivity, registered_model
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.solvers import DEFAULT_INTEGRATOR, integrator_named, registered_integrators
from rodsim.solvers.base import Integrator, RunState
from rodsim.solvers.result import Result
from rodsim.solvers.tolerance import effective_tolerance

__all__ = ["Continuation", "StepOutcome", "ScaledEquilibria", "EquilibriumFailure",
           "BudgetSpent", "MAX_HALVINGS", "EASY_ITERATIONS"]

#: Failed attempts (each halving the increment) after which :meth:`Continuation.walk` fails.
MAX_HALVINGS = 10
#: A sub-step that converged within this many iterations doubles the increment again.
EASY_ITERATIONS = 6

#: Most re-solves of one step for points of a string tendon that broke loose (stiction,
#: rodsim/core/tendon_friction.py): each frees at least one routing point.
MAX_BREAKAWAYS = 1000
#: Scaled distance from a bound within which a fit's or a reach's value is set to the bound.
BOUND_SNAP = 1e-5


#: Another predicted start of a step (``Continuation.solve``): the start, a function making
#: it (or None) where it is needed, or None.
Alternative = np.ndarray | Callable[[], np.ndarray | None] | None


class EquilibriumFailure(RuntimeError):
    """An equilibrium needed by a fit or a reach could not be solved."""


class BudgetSpent(EquilibriumFailure):
    """The wall-time budget (``solver.max_wall_time``) of a track, fit or reach is spent."""


@dataclass(frozen=True)
class StepOutcome:
    """One warm solve: success, the equilibrium (free coordinates), the scaled residual,
    the integrator's work (``Integrator.work``: Newton and chord iterations for
    ``static``, steps for the others), and a message on failure."""

    success: bool
    x: np.ndarray
    residual: float
    iterations: int
    message: str


class Continuation:
    """Solves equilibria one after another, each warm-started from the last.

    Parameters
    ----------
    model
        The model of the first equilibrium's scene.
    x
        That equilibrium (free coordinates); its registration is applied to ``model``.
    integrator
        The name of a registered integrator (default
        ``rodsim.solvers.base.DEFAULT_INTEGRATOR``).
    deadline
        ``time.perf_counter()`` after which no solve starts (``walk`` fails) and an
        integrator's solve stops; None: none.
    """

    def __init__(self, model: Model, x: np.ndarray, integrator: str = DEFAULT_INTEGRATOR,
                 deadline: float | None = None) -> None:
        self.model = registered_model(model, x)
        self.x = np.array(x, dtype=float)
        self.integrator = integrator
        self.kind = integrator_named(integrator)
        self.deadline = deadline
        #: The state the last attempted step returned, successful or not: what its
        #: integrator carries on to the next (static: the factorisation as the attempt left
        #: it, refreshed or dropped).
        self.state: RunState | None = None
        #: (a scene's solver table, the integrator's options and tolerance in it): the
        #: steps of one path share the table (``scene_with``), read and validated once.
        self._settings: tuple[object, Any, float, float] | None = None
        #: Whether the last step weighed an alternative start and kept it (``_weighed``).
        self._alternative_kept = False

    def factorisation(self) -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray] | None
                                     ] | None:
        """(J's CSC data, J factored) at the last equilibrium, if its solve's verification
        made them (``RunState.factorisation_at``), for its stability verdict."""
        if self.state is None:
            return None
        return self.state.factorisation_at(self.model, self.x)

    @property
    def takes_predictor(self) -> bool:
        """Whether the integrator's continuation step starts from a predictor."""
        return self.kind.takes_predictor

    def predicted(self, scene: Scene, dx: np.ndarray) -> np.ndarray:
        """The start of the next step from the predictor ``x + dx`` (``x`` the last
        equilibrium), as the integrator configured by ``scene`` takes it
        (``Integrator.predicted``)."""
        return self._integrator(scene).predicted(self.model, self.x, dx)

    def _integrator(self, scene: Scene, max_wall_time: float | None = None
                    ) -> Integrator[Any]:
        """The integrator configured by ``scene`` as ``Integrator.for_scene`` makes it
        (``max_wall_time`` default: the scene's), its options read from ``scene``'s solver
        table once for the steps that share it (~15-25 us a step)."""
        table = scene.data["solver"]
        settings = self._settings
        if settings is None or settings[0] is not table:
            solver = scene.solver
            settings = self._settings = (table, self.kind.options_of(scene),
                                         float(solver.tolerance), float(solver.max_wall_time))
        return self.kind(settings[1], settings[2],
                         settings[3] if max_wall_time is None else max_wall_time)

    def solve(self, scene: Scene, start: np.ndarray | None = None,
              alternative: Alternative = None) -> StepOutcome:
        """The equilibrium of ``scene`` (same discretisation) from ``start`` (default: the
        last equilibrium) — or from ``alternative``, another predicted start, where
        ``start`` is not at the equilibrium already (its force residual on the step's model
        at the tolerance) and the residual is smaller at ``alternative`` (one evaluation
        of F each, which the solve's own first one then finds made); on success it becomes
        the last equilibrium. ``alternative`` may be a function making that start (or
        None): it is then made only where ``start`` is not at the equilibrium.

        Friction (contact, rodsim/core/terms/contact.py; tendons,
        rodsim/core/tendon_friction.py) is anchored at the last equilibrium
        (``Model.anchored``): it opposes the slip of this step. The model kept with the
        new equilibrium is the one that solved it (its forces, the contact forces a track
        records, are those of the equilibrium)."""
        model = self.model.anchored(self.x).with_values(scene)
        # A base that moves (insertion, rotation) carries the last equilibrium with it; that
        # rigid motion is exact where a chord predictor only linearises a rotation, so it
        # replaces the predictor.
        carried = model.carried(self.x, self.model)
        x = carried if start is None or carried is not self.x else start
        if alternative is not None and x is start:
            x = self._weighed(model, scene, start, alternative)
        budget = None  # the scene's, or with a deadline what is left of ours
        if self.deadline is not None:
            budget = min(float(scene.solver.max_wall_time),
                         max(self.deadline - time.perf_counter(), 0.0))
        integrator = self._integrator(scene, budget)
        # The run's verdict, state and statistics alone (``Integrator.settle``: no Result
        # to assemble, its rods' shapes and tendons' tensions unread here).
        state = integrator.restart(self.state, model, x)
        judged, reached, stats = integrator.settle(state)
        work = self.kind.work(stats)
        # Stiction: a point that broke loose in this step slides at its kinetic μ; the step
        # is solved again with it until nothing more breaks (rodsim/core/tendon_friction.py,
        # "Stiction"; at most once per routing point).
        for _ in range(MAX_BREAKAWAYS):
            freed = model.freed(reached) if judged.success else None
            if freed is None:
                break
            model = freed
            state = integrator.restart(state, model, reached)
            judged, reached, stats = integrator.settle(state)
            work += self.kind.work(stats)
        self.state = state
        if not judged.success:
            return StepOutcome(False, x, judged.residual, work, judged.message)
        self.model = (state.model if state.registered_exactly(reached)
                      else registered_model(state.model, reached))
        self.x = np.array(reached, dtype=float)
        return StepOutcome(True, self.x, judged.residual, work, "converged")

    def _weighed(self, model: Model, scene: Scene, start: np.ndarray,
                 alternative: Alternative) -> np.ndarray:
        """``start``, or ``alternative`` where ``start`` is not at the equilibrium already
        and the residual is smaller there (``solve``). The step takes J at the start it
        keeps (its J₀, or its verification's), so F and J are evaluated there in one pass
        (the model's memo keeps both), F alone at the other: at the start the last weighing
        kept (tdcr-two-segment's tension ramp keeps the linear predictor's, table3-catheter1's
        the curved one's: the first weighing guesses the linear one)."""
        one_pass = model.keeps_jacobians
        if one_pass and not self._alternative_kept:
            model.evaluate(start)
        first = model.force_residual(model.force(start))
        if first < effective_tolerance(model, float(scene.solver.tolerance)):
            self._alternative_kept = False
            return start
        other = alternative() if callable(alternative) else alternative
        if other is None:
            return start
        if one_pass and self._alternative_kept:
            model.evaluate(other)
        self._alternative_kept = model.force_residual(model.force(other)) < first
        return other if self._alternative_kept else start

    def walk(self, scene: Scene, keys: Sequence[NumericKey], start: np.ndarray,
             stop: np.ndarray, predictor: np.ndarray | None = None,
             alternative: Alternative = None, stop_scene: Scene | None = None
             ) -> tuple[bool, int, int, str]:
        """Move from the equilibrium at the values ``start`` of ``keys`` (in ``scene``) to
        the one at ``stop``, from ``predictor`` if given (for the whole step only; or from
        ``alternative`` where the residual is smaller there, ``solve``; ``stop_scene``:
        ``scene_with(scene, keys, stop)`` if the caller made it already), halving
        the increment on each failure and doubling it again (up to the rest of the step)
        after a sub-step that took at most ``EASY_ITERATIONS`` iterations; fails at the
        ``MAX_HALVINGS``-th failed attempt — and then leaves the continuation at the
        equilibrium of ``start``, where it was, though sub-steps had moved it part of the way
        (a fit or a reach goes on from the values it holds). Returns (success, iterations,
        failed attempts, last failure message)."""
        start, stop = np.asarray(start, dtype=float), np.asarray(stop, dtype=float)
        before = self.model, self.x, self.state
        done, fraction, failures, iterations = 0.0, 1.0, 0, 0
        message = ""
        while done < 1.0:
            if self.deadline is not None and time.perf_counter() > self.deadline:
                self.model, self.x, self.state = before
                return False, iterations, failures, (
                    "the wall-time budget (solver.max_wall_time) is spent")
            fraction = min(fraction, 1.0 - done)
            whole = done == 0.0 and fraction == 1.0
            final = done + fraction >= 1.0
            there = stop if final else start + (done + fraction) * (stop - start)
            step_scene = (stop_scene if final and stop_scene is not None
                          else scene_with(scene, keys, there))
            outcome = (self.solve(step_scene, predictor, alternative)
                       if whole and alternative is not None
                       else self.solve(step_scene, predictor if whole else None))
            iterations += outcome.iterations
            if outcome.success:
                done = 1.0 if final else done + fraction
                if outcome.iterations <= EASY_ITERATIONS:
                    fraction *= 2.0
                continue
            message = outcome.message
            failures += 1
            fraction *= 0.5
            if failures >= MAX_HALVINGS:
                # The sub-steps that succeeded moved the continuation part of the way; the
                # caller still holds the values at ``start``, so go back there.
                self.model, self.x, self.state = before
                return False, iterations, failures, message
        return True, iterations, failures, message


class ScaledEquilibria:
    """Equilibria as a function of scaled parameter values u = p / ``scale`` (the
    unknowns of a fit or a reach), each warm-started from the last (``Continuation.walk``
    from the last values), with the nodes of ``rod`` and their sensitivities; counts the
    equilibria and sensitivities computed."""

    def __init__(self, scene: Scene, keys: Sequence[NumericKey], scale: np.ndarray,
                 result: Result, rod: str, integrator: str = DEFAULT_INTEGRATOR) -> None:
        self.scene, self.keys, self.scale, self.rod = scene, list(keys), scale, rod
        self.continuation = Continuation(Model(result.scene), result.state, integrator)
        self.values = np.array([k.value(scene) for k in keys])
        #: The scaled scene values, where a fit or a reach starts: ±1 for a non-zero value
        #: (its sign), 0 for a zero one.
        self.start = self.values / scale
        self.evaluations = 0
        self.jacobians = 0
        #: Evaluations whose equilibrium could not be solved (see :meth:`residual_or_none`).
        self.failures = 0
        self.last_failure = ""
        #: The values of every equilibrium the continuation stood at, in order, from the
        #: scene's own (its cold solve): the history its friction carries
        #: (rodsim/app/inverse/path_record.py).
        self.path = [self.values.copy()]

    @classmethod
    def at_scene_values(cls, scene: Scene, keys: Sequence[NumericKey], rod: str,
                        integrator: str = DEFAULT_INTEGRATOR
                        ) -> tuple[ScaledEquilibria, np.ndarray, np.ndarray]:
        """The problem started at the scene's own values, each parameter scaled by its
        magnitude (1 where it is 0), from a cold equilibrium by ``integrator``, which solves
        every later one too (EquilibriumFailure if there is none); with the scaled lower and
        upper bounds of the parameters."""
        from rodsim.app.api import solve

        initial = np.array([k.value(scene) for k in keys])
        for key, value in zip(keys, initial, strict=True):  # before any work
            low, high = key.bounds()
            if not low <= value <= high:
                raise SceneError(f"{key.name} = {value:g}: the scene's value, where the search "
                                 f"starts, is outside the range it may take; allowed: "
                                 f"{key.allowed}")
        scale = np.where(initial != 0.0, np.abs(initial), 1.0)
        lower, upper = np.array([k.bounds() for k in keys]).T / scale
        started = time.perf_counter()
        first = solve(scene, integrator)
        if not first.success:
            raise EquilibriumFailure(f"the scene's own values have no equilibrium: "
                                     f"{first.message}")
        problem = cls(scene, keys, scale, first, rod, integrator)
        problem.continuation.deadline = started + float(scene.solver.max_wall_time)
        return problem, lower, upper

    def values_of(self, u: np.ndarray) -> np.ndarray:
        """The parameter values of u, those within ``BOUND_SNAP`` × scale of a bound
        set to the bound: least_squares' trust-region reflective iterates stay strictly
        inside the bounds, and a tendon tension of a few µN (the bound is 0) puts the loads
        below the round-off of the internal forces, which no solver accepts."""
        values = np.asarray(u, dtype=float) * self.scale
        for column, key in enumerate(self.keys):
            for bound in key.bounds():
                if abs(values[column] - bound) < BOUND_SNAP * self.scale[column]:
                    values[column] = bound
        return values

    def at(self, u: np.ndarray) -> None:
        """Move the equilibrium to the parameters u (EquilibriumFailure if it cannot)."""
        values = self.values_of(u)
        if np.array_equal(values, self.values):
            return
        ok, _, _, message = self.continuation.walk(self.scene, self.keys, self.values, values)
        if not ok and "wall-time budget" in message:
            raise BudgetSpent(f"{message} after {self.evaluations} equilibria")
        if not ok:
            raise EquilibriumFailure(
                "no equilibrium at " + ", ".join(f"{k.name} = {v:.6g}" for k, v in
                                                 zip(self.keys, values, strict=True))
                + f": {message}")
        self.values = values
        self.path.append(values.copy())
        self.evaluations += 1

    def reached(self, u: np.ndarray) -> bool:
        """Move to u like ``at``, but report an equilibrium that cannot be solved by
        returning False (and staying at the last equilibrium) instead of raising: a
        least-squares step into parameters without a solvable equilibrium is then given a
        large residual and rejected, and the trust region shrinks."""
        try:
            self.at(u)
        except BudgetSpent:
            raise
        except EquilibriumFailure as exc:
            self.failures += 1
            self.last_failure = str(exc)
            return False
        return True

    def result(self, what: str) -> Result:
        """The current equilibrium — the one the optimiser measured, not a cold re-solve
        that could land on another branch — as a ``Result`` of the continuation's
        integrator with its stability verdict; ``what`` names it in the message."""
        import dataclasses

        from rodsim.core.stability import assess

        model, x = self.continuation.model, self.continuation.x
        name = self.continuation.integrator
        options = registered_integrators()[name].options_of(model.scene)
        force = model.force(x)
        return Result.from_model(
            model, x, integrator=name, options=dataclasses.asdict(options), success=True,
            message=f"converged ({what}: warm-started equilibrium)",
            residual=float(model.force_residual(force)),
            stats={"effective_tolerance": effective_tolerance(model,
                                                              model.scene.solver.tolerance),
                   "force_evals": float(self.evaluations)},
            history={}, stability=assess(model, x))

    def nodes(self) -> np.ndarray:
        model = self.continuation.model
        return model.positions(self.continuation.x, self.rod)

    def tip_quaternion(self) -> np.ndarray:
        """The quaternion of the rod's last segment at the current equilibrium."""
        model = self.continuation.model
        full = model.full(self.continuation.x)
        return full[model.rods[self.rod].layout.quaternion_index][-1]

    def tip_sensitivity(self) -> tuple[np.ndarray, np.ndarray]:
        """d(tip)/du (P, 3) and d(last quaternion)/du (P, 4) at the current equilibrium."""
        self.jacobians += 1
        model = self.continuation.model
        _, full = equilibrium_sensitivity(model, self.continuation.x, self.keys)
        layout = model.rods[self.rod].layout
        position = full[layout.position_index][-1].T * self.scale[:, None]
        quaternion = full[layout.quaternion_index][-1].T * self.scale[:, None]
        return position, quaternion

    def node_sensitivity(self) -> np.ndarray:
        """d(nodes of the rod)/du at the current equilibrium, (P, N, 3)."""
        self.jacobians += 1
        model = self.continuation.model
        _, full = equilibrium_sensitivity(model, self.continuation.x, self.keys)
        index = model.rods[self.rod].layout.position_index
        return np.moveaxis(full[index], -1, 0) * self.scale[:, None, None]
