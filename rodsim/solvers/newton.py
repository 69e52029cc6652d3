"""Globalised Newton iteration shared by the ``static`` and ``paper`` integrators.

Both solve a nonlinear system g(y) = 0 whose Jacobian is the model's analytic sparse one:
``static`` solves F(x) = 0 (and so does the Newton finish of CVODE/IDA); ``paper`` solves
Eq. (19), g(y) = M(p − y) + h² F(y), which is
−∇ of the incremental potential Φ(y) = ½ (y − p)ᵀ M (y − p) + h² E(y). When the model is
conservative, Φ (or E) is the line-search merit — Newton on a potential with an Armijo
backtracking line search is robust even for the stiff penalty terms, where the raw Newton
step overshoots by orders of magnitude. Otherwise the merit is ½ |W g|², and a full step
that raises it is still taken, watched (Chamberlain's watchdog): if the merit has not fallen
below its value at the watched point within ``WATCHDOG_STEPS`` full steps, the iteration
returns there and backtracks. On the paper's tendon coupling the exact Newton step first
raises |W g| tenfold and then converges quadratically; backtracking on every such step cut
it to linear convergence (measured on table3-catheter1 with ``static``: 7 iterations per
load step with full steps against 14–30 with backtracking).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from rodsim.solvers.failure import SolverFailure
from rodsim.solvers.linear import LinearSolver

__all__ = ["NewtonProblem", "NewtonResult", "newton", "JACOBIAN_REUSE"]

#: Jacobian policies of :func:`newton`: a fresh Jacobian every iteration (the default, what
#: every integrator uses); ``chord``: one Jacobian and one factorisation reused throughout;
#: ``lagged``: the factorisation is reused while each iteration at least halves the residual
#: and refreshed otherwise. Either reuse refreshes it when its step is not a descent
#: direction. (Measured by ``rodsim bench skip-work``, docs/benchmarks.md.)
JACOBIAN_REUSE = ("fresh", "chord", "lagged")


@dataclass(frozen=True)
class NewtonProblem:
    """g(y) (a generalised force), its Jacobian ∂g/∂y (CSC data of ``linear``'s pattern),
    the solver of the linear systems, and optionally Φ with g = −∇Φ.

    ``residual(g)`` is the scaled residual that decides convergence. ``step(y, dy)``, if
    given, is the state a Newton step ``dy`` from ``y`` reaches in place of ``y + dy`` (a
    retraction that keeps stiff lengths to first order, ``rodsim.core.model.Model.step``);
    it must agree with ``y + dy`` to first order in ``dy``.

    ``correction(dy)``, if given, is the size of a Newton correction ``dy`` that the stopping
    test must also find below ``correction_tolerance`` (``newton``): a test whose meaning
    does not depend on N, where the max-norm residual reads an imbalance spread over the N
    nodes as 1/N of it (``rodsim.solvers.base.correction_residual``).
    """

    force: Callable[[np.ndarray], np.ndarray]
    jacobian: Callable[[np.ndarray], np.ndarray]
    linear: LinearSolver
    residual: Callable[[np.ndarray], float]
    weight: np.ndarray
    potential: Callable[[np.ndarray], float] | None = None
    step: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    correction: Callable[[np.ndarray], float] | None = None
    correction_tolerance: float = 0.0


#: Extra iterations a converged, polishing Newton solve may take (each must halve the residual).
POLISH_ITERATIONS = 2
#: Full steps a non-conservative solve may take past a merit increase before it must be back
#: below the merit of the point it left (else it returns there and backtracks).
WATCHDOG_STEPS = 4


@dataclass(frozen=True)
class NewtonResult:
    x: np.ndarray
    converged: bool
    iterations: int
    residual: float
    message: str


#: A direction whose Jacobi-scaled stiffness (module :func:`_neutral`) is below this, in
#: magnitude, is neutral: its sign is round-off.
NEUTRAL_STIFFNESS = 1e-12


def _neutral(problem: NewtonProblem, jacobian: np.ndarray, dx: np.ndarray, slope: float) -> bool:
    """Whether the stiffness along the Newton step ``dx`` is neutral: its Rayleigh quotient
    dx·J·dx = slope (J dx = −g) over dx·|diag J|·dx, the same quotient with the diagonal's
    magnitudes, below ``NEUTRAL_STIFFNESS``. The Jacobi scaling makes it independent
    of the coordinates' units (metres, quaternion components). Measured: a ball joint's
    free rotation at rest (tests/test_stability_neutral.py) 1e-17 to 1.3e-15; the ascent
    steps of reach's inner solves on table1's unstable equilibrium
    (tests/test_inverse_hardening.py) 3e-14 to 4e-5, mostly above 1e-8."""
    diagonal = np.abs(problem.linear.diagonal(jacobian))
    scale = float(dx @ (diagonal * dx))
    return scale > 0.0 and abs(slope) < NEUTRAL_STIFFNESS * scale


def newton(problem: NewtonProblem, x: np.ndarray, tolerance: float,
           max_iterations: int, polish: bool = True,
           check: Callable[[], None] | None = None,
           reuse: str = "fresh") -> NewtonResult:
    """Newton iterations from ``x`` until ``residual(g) < tolerance``.

    With ``polish``, takes up to ``POLISH_ITERATIONS`` more iterations once below the
    tolerance, while each still halves the residual, so a converged result is the root to
    round-off (quadratic convergence gets there in one or two). Returns (never raises) with
    ``converged = False`` and a reason when the iteration stalls or the linear system is
    singular. ``check`` is called once per iteration (the caller's wall-time budget and
    progress); whatever it raises ends the iteration. ``reuse`` is the Jacobian policy, one
    of ``JACOBIAN_REUSE`` (``problem.linear`` then needs ``factorized``).

    With ``problem.correction``, converged means the residual below ``tolerance`` *and* the
    Newton correction at that point below ``problem.correction_tolerance`` (x is returned,
    the correction not taken); until then every iteration is an ordinary Newton step, and
    there is no residual polishing (a step that does not halve the max-norm residual may
    still be the step to the root: on table1-50g at N = 20 000 a state with residual
    5.8e-6 lay 3.6e-3 L from the equilibrium, and the step there raised the residual to
    6.8e-5 while coming 200× closer).
    """
    if reuse not in JACOBIAN_REUSE:
        raise ValueError(f"reuse = {reuse!r}: expected one of {', '.join(JACOBIAN_REUSE)}")
    factor: Callable[[np.ndarray], np.ndarray] | None = None  # a reused factorisation
    previous = np.inf  # the residual before the last iteration (the lagged policy)

    def merit(y: np.ndarray, g: np.ndarray) -> float:
        if problem.potential is not None:
            return problem.potential(y)
        wg = g * problem.weight
        return 0.5 * float(wg @ wg)

    def evaluate(y: np.ndarray) -> tuple[np.ndarray, float]:
        try:
            g = problem.force(y)
            return g, merit(y, g)
        except SolverFailure:
            return np.full_like(y, np.nan), np.inf

    def advance(y: np.ndarray, dy: np.ndarray) -> np.ndarray:
        return y + dy if problem.step is None else problem.step(y, dy)

    g = problem.force(x)
    residual = problem.residual(g)
    value = merit(x, g)
    polishing = POLISH_ITERATIONS if polish else 0
    #: (x, g, residual, merit, full steps left) of the point a watched full step left.
    watched: tuple[np.ndarray, np.ndarray, float, float, int] | None = None
    may_watch = problem.potential is None
    backtrack = False  # set after a failed watch: the next step must backtrack
    #: The Jacobian of this iteration's step (and, reused, of the factorisation's state).
    jacobian: np.ndarray | None = None
    for iteration in range(max_iterations):
        if check is not None:
            check()
        if problem.correction is None and residual < tolerance:
            if polishing == 0:
                return NewtonResult(x, True, iteration, residual, "converged")
            polishing -= 1
        if reuse == "fresh":
            jacobian = problem.jacobian(x)
            dx = problem.linear.solve(jacobian, -g)
        else:
            stale = factor is not None and (reuse == "chord" or residual < 0.5 * previous)
            if not stale:
                jacobian = problem.jacobian(x)
                factor = problem.linear.factorized(jacobian)
            dx = factor(-g) if factor is not None else np.full_like(x, np.nan)
            if stale and not -float(g @ dx) < 0.0 and problem.potential is not None:
                jacobian = problem.jacobian(x)  # a stale step that does not descend: refresh
                factor = problem.linear.factorized(jacobian)
                dx = factor(-g) if factor is not None else np.full_like(x, np.nan)
            previous = residual
        if not np.all(np.isfinite(dx)):
            return NewtonResult(x, False, iteration + 1, residual, "singular Jacobian")
        # Near the root: the residual below the tolerance and, with a correction test, the
        # correction too (converged: x itself, the correction being negligible); a residual
        # below the tolerance with a correction above it is an ordinary Newton step.
        near = residual < tolerance
        if problem.correction is not None:
            if near and problem.correction(dx) < problem.correction_tolerance:
                return NewtonResult(x, True, iteration + 1, residual, "converged")
            near = False
        # Directional derivative of the merit along dx.
        slope = -float(g @ dx) if problem.potential is not None else -2.0 * value
        if slope > 0.0 and problem.potential is not None and near is False and (
                problem.correction is None) and jacobian is not None and _neutral(
                    problem, jacobian, dx, slope):
            # An ascent direction along a neutral one (a free rotation at rest, whose
            # exact zero the offset state keeps; round-off gives it either sign): the
            # reverse step descends Φ as steeply (−g·(−dx) = −slope) and the line search
            # shortens it. An ascent along a clearly negative stiffness (an unstable
            # equilibrium that reach's inner solves must reach) is not reversed.
            dx, slope = -dx, -slope
        if slope >= 0.0 and problem.potential is not None:
            # Not a descent direction (an inexact — finite-difference — Jacobian, or a state
            # off a stable branch): fall back to a diagonally scaled gradient step on Φ.
            assert jacobian is not None  # evaluated at the first iteration at the latest
            diagonal = np.abs(problem.linear.diagonal(jacobian))
            dx = g / np.where(diagonal > 0.0, diagonal, 1.0)
            slope = -float(g @ dx)
        if reuse == "fresh":
            # Not needed any more: a large model's next Jacobian may then be accumulated in
            # its array instead of fresh memory (rodsim/core/model_evaluation.py, _jacobian_zeros).
            jacobian = None
        if slope >= 0.0:
            if near:
                return NewtonResult(x, True, iteration + 1, residual, "converged")
            return NewtonResult(x, False, iteration + 1, residual,
                                "Newton direction is not a descent direction (unstable state)")
        alpha = 1.0
        trial = advance(x, dx)
        trial_g, trial_value = evaluate(trial)
        full_step_watched = (may_watch and not backtrack and np.isfinite(trial_value)
                             and not near)
        backtrack = False
        if not full_step_watched:
            while True:
                if trial_value <= value + 1e-4 * alpha * slope:
                    break
                # Near the root the merit's change drowns in round-off; a full step that
                # halves the residual is then accepted on the residual alone.
                if alpha == 1.0 and np.isfinite(trial_value) and (
                        problem.residual(trial_g) < 0.5 * residual):
                    break
                if near:
                    # Polishing: a shorter step would be kept only if it halved the
                    # residual, which a step the full one overshoots does not do at
                    # round-off: the state is the root already.
                    return NewtonResult(x, True, iteration + 1, residual, "converged")
                alpha *= 0.5
                if alpha < 1e-10:
                    if near:
                        return NewtonResult(x, True, iteration + 1, residual, "converged")
                    return NewtonResult(x, False, iteration + 1, residual,
                                        "line search failed")
                if check is not None:  # a long backtracking costs force evaluations too
                    check()
                trial = advance(x, alpha * dx)
                trial_g, trial_value = evaluate(trial)
        elif watched is None and trial_value > value + 1e-4 * slope:
            watched = (x, g, residual, value, WATCHDOG_STEPS)
        trial_residual = problem.residual(trial_g)
        if near and not trial_residual < 0.5 * residual:
            return NewtonResult(x, True, iteration + 1, residual, "converged")  # round-off
        x, g, residual, value = trial, trial_g, trial_residual, trial_value
        if watched is not None:
            start_x, start_g, start_residual, start_value, left = watched
            if value <= start_value * (1.0 - 2e-4):  # Armijo against the watched point
                watched = None
            elif left > 1:
                watched = (start_x, start_g, start_residual, start_value, left - 1)
            else:  # no progress: back to the watched point, and backtrack from there
                x, g, residual, value = start_x, start_g, start_residual, start_value
                watched, backtrack = None, True
    converged = residual < tolerance and problem.correction is None
    return NewtonResult(x, converged, max_iterations, residual,
                        "converged" if converged else
                        f"no convergence in {max_iterations} Newton iterations")
