"""Equilibria of nearby parameter values, each solved from the previous one (a warm start).

Tracking (rodsim/app/inverse/track.py), fitting (fit.py) and inverse kinematics (reach.py)
solve many
equilibria whose parameters differ a little. :class:`Continuation` keeps the last
equilibrium — its state x and its model, which carries its tendon registration — and solves
the next scene from it:

- ``static``: the next model is :meth:`Model.with_values` of the last (only the terms whose
  options changed are rebuilt; the assembly, pattern, scales' layout and kernels are
  shared; any other change falls back to :meth:`Model.with_scene`: same free-coordinate
  order, same registration, the Jacobian pattern reused when the elements keep their
  coordinates), and from the last state or a given predictor — or, when a base support
  moves (insertion, rotation), the last state carried rigidly with it
  (:meth:`Model.carried`) — it first tries chord
  iterations — Newton steps with a Jacobian factorised at an earlier equilibrium and kept
  while it works (each iteration halving the residual), so a step costs evaluations of F
  and band back-substitutions only — then, if they stall, Newton at full load (the analytic
  Jacobian, band solves and line search of rodsim/solvers/newton.py); either is
  repeated while the registration changes and until it settles without hysteresis. No load
  or penalty continuation, no Result: a warm step costs a few iterations.
- ``cvode``, ``ida``, ``paper``: the integrator itself, started from the last state
  (``initial_state``) on the next model, the loads in full from the start.

A solve that fails leaves the continuation where it was. :meth:`Continuation.walk` moves
between two sets of parameter values and retries a failed solve with half the increment,
halved again on each failure and doubled after an easy sub-step, up to
:data:`MAX_HALVINGS` failed attempts. :class:`ScaledEquilibria` wraps a continuation as the
function of (scaled) parameter values that a fit or a reach minimises over.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey, scene_with
from rodsim.app.inverse.sensitivity import equilibrium_sensitivity, registered_model
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.solvers.base import MAX_RESIDUAL_FLOOR, MAX_SETTLES, SolverFailure
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.newton import NewtonProblem, newton
from rodsim.solvers.result import Result

__all__ = ["Continuation", "StepOutcome", "ScaledEquilibria", "EquilibriumFailure",
           "BudgetSpent", "MAX_NEWTON", "MAX_HALVINGS", "EASY_ITERATIONS"]

#: Newton iterations a warm static step may take (per registration).
MAX_NEWTON = 30
#: Chord iterations (kept factorisation) a warm static step tries before Newton.
MAX_CHORD = 10
#: Failed attempts (each halving the increment) after which :meth:`Continuation.walk` fails.
MAX_HALVINGS = 10
#: A sub-step that converged within this many Newton iterations doubles the increment again.
EASY_ITERATIONS = 6
#: Scaled distance from a bound within which a fit's or a reach's value is set to the bound.
BOUND_SNAP = 1e-5


class EquilibriumFailure(RuntimeError):
    """An equilibrium needed by a fit or a reach could not be solved."""


class BudgetSpent(EquilibriumFailure):
    """The wall-time budget (``solver.max_wall_time``) of a track, fit or reach is spent."""


@dataclass(frozen=True)
class StepOutcome:
    """One warm solve: success, the equilibrium (free coordinates), the scaled residual,
    Newton iterations (static) or integrator steps, and a message on failure."""

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
        ``static`` (Newton, default) or ``cvode``, ``ida``, ``paper``.
    deadline
        ``time.perf_counter()`` after which no solve starts (:meth:`walk` fails) and an
        integrator's solve stops; None: none.
    """

    def __init__(self, model: Model, x: np.ndarray, integrator: str = "static",
                 deadline: float | None = None) -> None:
        self.model = registered_model(model, x)
        self.x = np.array(x, dtype=float)
        self.integrator = integrator
        self.deadline = deadline
        self._linear: tuple[object, LinearSolver] | None = None
        #: (pattern, solve) of a Jacobian factorised at an earlier state, for chord steps.
        self._factor: tuple[object, Callable[[np.ndarray], np.ndarray]] | None = None

    def _linear_solver(self, model: Model) -> LinearSolver:
        if self._linear is None or self._linear[0] is not model.pattern:
            self._linear = model.pattern, LinearSolver(
                model.pattern, model.pattern_rows, model.pattern_cols,
                (model.band.lower, model.band.upper), model.conservative)
        return self._linear[1]

    def solve(self, scene: Scene, start: np.ndarray | None = None) -> StepOutcome:
        """The equilibrium of ``scene`` (same discretisation) from ``start`` (default: the
        last equilibrium); on success it becomes the last equilibrium."""
        model = self.model.with_values(scene)
        # A base that moves (insertion, rotation) carries the last equilibrium with it; that
        # rigid motion is exact where a chord predictor only linearises a rotation, so it
        # replaces the predictor.
        carried = model.carried(self.x, self.model)
        x = carried if start is None or carried is not self.x else start
        if self.integrator == "static":
            outcome, model = self._newton(model, x)
        else:
            outcome, model = self._integrate(model, x)
        if outcome.success:
            self.model, self.x = model, outcome.x
        return outcome

    def walk(self, scene: Scene, keys: Sequence[NumericKey], start: np.ndarray,
             stop: np.ndarray, predictor: np.ndarray | None = None
             ) -> tuple[bool, int, int, str]:
        """Move from the equilibrium at the values ``start`` of ``keys`` (in ``scene``) to
        the one at ``stop``, from ``predictor`` if given (for the whole step only), halving
        the increment on each failure and doubling it again (up to the rest of the step)
        after a sub-step that took at most :data:`EASY_ITERATIONS` iterations; fails at the
        :data:`MAX_HALVINGS`-th failed attempt. Returns (success, iterations, failed
        attempts, last failure message)."""
        start, stop = np.asarray(start, dtype=float), np.asarray(stop, dtype=float)
        done, fraction, failures, iterations = 0.0, 1.0, 0, 0
        message = ""
        while done < 1.0:
            if self.deadline is not None and time.perf_counter() > self.deadline:
                return False, iterations, failures, (
                    "the wall-time budget (solver.max_wall_time) is spent")
            fraction = min(fraction, 1.0 - done)
            whole = done == 0.0 and fraction == 1.0
            final = done + fraction >= 1.0
            there = stop if final else start + (done + fraction) * (stop - start)
            outcome = self.solve(scene_with(scene, keys, there), predictor if whole else None)
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
                return False, iterations, failures, message
        return True, iterations, failures, message

    def _newton(self, model: Model, x: np.ndarray) -> tuple[StepOutcome, Model]:
        if model.residual_floor > MAX_RESIDUAL_FLOOR:  # as every integrator refuses it
            return StepOutcome(False, x, np.nan, 0, "the loads are below the round-off of "
                               f"the internal forces (residual floor {model.residual_floor:.3g}"
                               f" > {MAX_RESIDUAL_FLOOR:g})"), model
        tolerance = max(model.scene.solver.tolerance, model.residual_floor)
        total = 0
        for _ in range(MAX_SETTLES + 1):
            chord = self._chord(model, x, tolerance)
            if chord is not None:
                x, iterations, residual = chord
                total += iterations
                moved = model.reregistered(x, exact=True)
                if moved is None:
                    return StepOutcome(True, x, residual, total, "converged"), model
                model = moved
                continue

            def force(y: np.ndarray, model: Model = model) -> np.ndarray:
                f = model.force(y)
                if not np.all(np.isfinite(f)):
                    raise SolverFailure("the force became non-finite (NaN or inf)")
                return f

            problem = NewtonProblem(
                force=force, jacobian=model.jacobian_data,
                linear=self._linear_solver(model), residual=model.residual,
                weight=model.residual_weight,
                potential=model.energy if model.conservative else None)
            try:
                solved = newton(problem, x, tolerance, MAX_NEWTON, polish=False)
            except SolverFailure as exc:
                return StepOutcome(False, x, np.nan, total, str(exc)), model
            total += solved.iterations
            if not solved.converged:
                return StepOutcome(False, x, solved.residual, total,
                                   f"Newton did not converge: {solved.message}"), model
            x = solved.x
            moved = model.reregistered(x, exact=True)
            if moved is None:
                return StepOutcome(True, x, solved.residual, total, "converged"), model
            model = moved
        return StepOutcome(False, x, np.nan, total, "the tendon registration did not settle"
                           ), model

    def _chord(self, model: Model, x: np.ndarray, tolerance: float
               ) -> tuple[np.ndarray, int, float] | None:
        """Chord iterations x ← x − J₀⁻¹F(x) with a factorisation J₀ kept from an earlier
        equilibrium of the same Jacobian pattern (factored here if there is none): each
        costs an evaluation of F and a band back-substitution instead of F, J and a band
        factorisation. Returns (x, iterations, residual) once the residual is below
        ``tolerance``, or None — and drops J₀ — as soon as an iteration fails to halve it
        (J₀ too far from the current Jacobian): Newton then takes over."""
        if self._factor is None or self._factor[0] is not model.pattern:
            solve = self._linear_solver(model).factorized(model.jacobian_data(x))
            if solve is None:
                return None
            self._factor = model.pattern, solve
        solve = self._factor[1]
        previous = np.inf
        for iteration in range(MAX_CHORD):
            f = model.force(x)
            residual = model.residual(f) if np.all(np.isfinite(f)) else np.inf
            if residual < tolerance:
                return x, iteration, residual
            if not residual < 0.5 * previous:
                break
            previous = residual
            x = x - solve(f)
        self._factor = None
        return None

    def _integrate(self, model: Model, x: np.ndarray) -> tuple[StepOutcome, Model]:
        from rodsim.solvers import registered_integrators

        scene = model.scene
        budget = scene.solver.max_wall_time
        if self.deadline is not None:  # the integrator's own budget: what is left of ours
            budget = min(budget, max(self.deadline - time.perf_counter(), 0.0))
        kind = registered_integrators()[self.integrator]
        result: Result = kind.for_scene(scene, max_wall_time=budget).solve(model, x)
        steps = int(result.stats["steps"])
        if not result.success:
            return StepOutcome(False, x, result.residual, steps, result.message), model
        return (StepOutcome(True, result.state, result.residual, steps, "converged"),
                registered_model(model, result.state))


class ScaledEquilibria:
    """Equilibria as a function of scaled parameter values u = p / ``scale`` (the
    unknowns of a fit or a reach), each warm-started from the last (:meth:`Continuation.walk`
    from the last values), with the nodes of ``rod`` and their sensitivities; counts the
    equilibria and sensitivities computed."""

    def __init__(self, scene: Scene, keys: Sequence[NumericKey], scale: np.ndarray,
                 result: Result, rod: str) -> None:
        self.scene, self.keys, self.scale, self.rod = scene, list(keys), scale, rod
        self.continuation = Continuation(Model(result.scene), result.state)
        self.values = np.array([k.value(scene) for k in keys])
        #: The scaled scene values, where a fit or a reach starts: ±1 for a non-zero value
        #: (its sign), 0 for a zero one.
        self.start = self.values / scale
        self.evaluations = 0
        self.jacobians = 0
        #: Evaluations whose equilibrium could not be solved (see :meth:`residual_or_none`).
        self.failures = 0
        self.last_failure = ""

    @classmethod
    def at_scene_values(cls, scene: Scene, keys: Sequence[NumericKey],
                        rod: str) -> tuple[ScaledEquilibria, np.ndarray, np.ndarray]:
        """The problem started at the scene's own values, each parameter scaled by its
        magnitude (1 where it is 0), from a cold static equilibrium (EquilibriumFailure if
        there is none); with the scaled lower and upper bounds of the parameters."""
        from rodsim.app.api import solve

        initial = np.array([k.value(scene) for k in keys])
        scale = np.where(initial != 0.0, np.abs(initial), 1.0)
        lower, upper = np.array([k.bounds() for k in keys]).T / scale
        started = time.perf_counter()
        first = solve(scene, "static")
        if not first.success:
            raise EquilibriumFailure(f"the scene's own values have no equilibrium: "
                                     f"{first.message}")
        problem = cls(scene, keys, scale, first, rod)
        problem.continuation.deadline = started + float(scene.solver.max_wall_time)
        return problem, lower, upper

    def values_of(self, u: np.ndarray) -> np.ndarray:
        """The parameter values of u, those within :data:`BOUND_SNAP` × scale of a bound
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
        self.evaluations += 1

    def reached(self, u: np.ndarray) -> bool:
        """Move to u like :meth:`at`, but report an equilibrium that cannot be solved by
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
        that could land on another branch — as a static :class:`Result` with its stability
        verdict; ``what`` names it in the message."""
        import dataclasses

        from rodsim.core.stability import assess
        from rodsim.solvers import registered_integrators

        model, x = self.continuation.model, self.continuation.x
        options = registered_integrators()["static"].options_of(model.scene)
        force = model.force(x)
        return Result.from_model(
            model, x, integrator="static", options=dataclasses.asdict(options), success=True,
            message=f"converged ({what}: warm-started equilibrium)",
            residual=float(model.residual(force)),
            stats={"effective_tolerance": max(model.scene.solver.tolerance,
                                              model.residual_floor),
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
