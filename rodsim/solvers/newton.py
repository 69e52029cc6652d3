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

    ``force_residual(g)`` is the scaled residual that decides convergence. ``step(y, dy)``, if
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
    force_residual: Callable[[np.ndarray], float]
    weight: np.ndarray
    potential: Callable[[np.ndarray], float] | None = None
    step: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    correction: Callable[[np.ndarray], float] | None = None
    correction_tolerance: float = 0.0
    #: Evaluates g and its Jacobian at a state in one pass and keeps both for ``force`` and
    #: ``jacobian`` to return (the model's memo), or None: what ``newton`` does at its
    #: first state, whose Jacobian its first iteration needs.
    prepare: Callable[[np.ndarray], None] | None = None


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


def _merit(problem: NewtonProblem, y: np.ndarray, g: np.ndarray) -> float:
    """The line-search merit at ``y``: Φ(y) when the problem has one, else ½ |W g|²."""
    if problem.potential is not None:
        return problem.potential(y)
    wg = g * problem.weight
    return 0.5 * float(wg @ wg)


class _Point:
    """An iterate or a trial state: the state ``x`` and its force ``g``; the scaled residual
    of ``g`` and the line-search merit at ``x`` (``_merit``) are computed when first asked
    for, then kept. Most full Newton steps are kept because they halve the residual
    (``_accepted``), which needs no merit: the energy Φ of most states is never evaluated
    (warm tdcr-two-segment batch cases: 5.05 energies a case before, 1 after). A merit that
    cannot be evaluated (``SolverFailure``) is infinite."""

    __slots__ = ("x", "g", "_problem", "_residual", "_value")

    def __init__(self, problem: NewtonProblem, x: np.ndarray, g: np.ndarray,
                 value: float | None = None) -> None:
        self.x = x
        self.g = g
        self._problem = problem
        self._residual: float | None = None
        self._value = value

    @property
    def residual(self) -> float:
        if self._residual is None:
            self._residual = self._problem.force_residual(self.g)
        return self._residual

    @property
    def value(self) -> float:
        if self._value is None:
            try:
                self._value = _merit(self._problem, self.x, self.g)
            except SolverFailure:
                self._value = np.inf
        return self._value


def _trial(problem: NewtonProblem, x: np.ndarray, dx: np.ndarray, prepare: bool = False
           ) -> _Point:
    """The state a step ``dx`` from ``x`` reaches (``problem.step``'s retraction, else
    ``x + dx``) with its force; a force evaluation that fails there gives NaN forces and an
    infinite merit (a step the line search shortens). ``prepare``: its Jacobian too, in the
    same pass (``NewtonProblem.prepare``), for the next iteration to take."""
    y = x + dx if problem.step is None else problem.step(x, dx)
    try:
        if prepare and problem.prepare is not None:
            problem.prepare(y)
        return _Point(problem, y, problem.force(y))
    except SolverFailure:
        return _Point(problem, y, np.full_like(y, np.nan), np.inf)


class _Jacobians:
    """The Jacobian policy ``reuse`` (one of ``JACOBIAN_REUSE``): the Newton step of each
    iteration, and ``jacobian``, the Jacobian it was solved with."""

    def __init__(self, problem: NewtonProblem, reuse: str) -> None:
        if reuse not in JACOBIAN_REUSE:
            raise ValueError(f"reuse = {reuse!r}: expected one of {', '.join(JACOBIAN_REUSE)}")
        self.problem = problem
        self.reuse = reuse
        #: The Jacobian of this iteration's step (and, reused, of the factorisation's state).
        self.jacobian: np.ndarray | None = None
        self._factor: Callable[[np.ndarray], np.ndarray] | None = None  # a reused factorisation
        self._previous = np.inf  # the residual before the last iteration (the lagged policy)

    def step(self, point: _Point) -> np.ndarray:
        """The Newton step J dx = −g at ``point`` (NaN where J is singular). A reused
        factorisation is refreshed when the lagged policy's residual did not halve, or when
        its step does not descend Φ."""
        if self.reuse == "fresh":
            self.jacobian = self.problem.jacobian(point.x)
            return self.problem.linear.solve(self.jacobian, -point.g)
        stale = self._factor is not None and (
            self.reuse == "chord" or point.residual < 0.5 * self._previous)
        if not stale:
            self._factorize(point.x)
        dx = self._solve(point)
        if stale and not -float(point.g @ dx) < 0.0 and self.problem.potential is not None:
            self._factorize(point.x)  # a stale step that does not descend: refresh
            dx = self._solve(point)
        self._previous = point.residual
        return dx

    def release(self) -> None:
        """Drop a fresh Jacobian once its step is taken: a large model's next Jacobian may
        then be accumulated in its array instead of fresh memory
        (rodsim/core/model_evaluation.py, _jacobian_zeros)."""
        if self.reuse == "fresh":
            self.jacobian = None

    def _factorize(self, x: np.ndarray) -> None:
        self.jacobian = self.problem.jacobian(x)
        self._factor = self.problem.linear.factorized(self.jacobian)

    def _solve(self, point: _Point) -> np.ndarray:
        if self._factor is None:
            return np.full_like(point.x, np.nan)
        return self._factor(-point.g)


def _descent(problem: NewtonProblem, jacobian: np.ndarray | None, point: _Point,
             dx: np.ndarray, near: bool) -> tuple[np.ndarray, float]:
    """The direction of the line search and the merit's directional derivative along it.

    Without Φ the merit ½ |W g|² falls along the Newton step at the rate −2 × merit. With
    Φ the slope is −g·dx; an ascent along a neutral direction is reversed, and a step
    that still does not descend is replaced by a diagonally scaled gradient step on Φ."""
    if problem.potential is None:
        return dx, -2.0 * point.value
    assert jacobian is not None  # evaluated at the first iteration at the latest
    slope = -float(point.g @ dx)
    if slope > 0.0 and not near and problem.correction is None and _neutral(
            problem, jacobian, dx, slope):
        # An ascent direction along a neutral one (a free rotation at rest, whose exact
        # zero the offset state keeps; round-off gives it either sign): the reverse step
        # descends Φ as steeply (−g·(−dx) = −slope) and the line search shortens it. An
        # ascent along a clearly negative stiffness (an unstable equilibrium that reach's
        # inner solves must reach) is not reversed.
        dx, slope = -dx, -slope
    if slope >= 0.0:
        # Not a descent direction (an inexact — finite-difference — Jacobian, or a state off
        # a stable branch): fall back to a diagonally scaled gradient step on Φ.
        diagonal = np.abs(problem.linear.diagonal(jacobian))
        dx = point.g / np.where(diagonal > 0.0, diagonal, 1.0)
        slope = -float(point.g @ dx)
    return dx, slope


def _line_search(problem: NewtonProblem, point: _Point, dx: np.ndarray, slope: float,
                 trial: _Point, check: Callable[[], None] | None) -> _Point | None:
    """Armijo backtracking from the full step's ``trial``: the first of the steps
    α dx (α = 1, ½, ¼, …) whose merit falls by at least 1e-4 α × slope, or whose full step
    halves the residual (near the root the merit's change drowns in round-off). None when
    α falls below 1e-10."""
    alpha = 1.0
    while not _accepted(point, trial, alpha, slope):
        alpha *= 0.5
        if alpha < 1e-10:
            return None
        if check is not None:  # a long backtracking costs force evaluations too
            check()
        trial = _trial(problem, point.x, alpha * dx)
    return trial


def _accepted(point: _Point, trial: _Point, alpha: float, slope: float) -> bool:
    """Whether the line search keeps ``trial``, the step α dx along which the merit falls
    at ``slope``: a full step (α = 1) that halves the residual (its force finite), or
    Armijo's sufficient decrease. The residual is asked first: a full step it keeps needs
    neither merit."""
    if alpha == 1.0 and bool(np.isfinite(trial.residual)) and (
            trial.residual < 0.5 * point.residual):
        return True
    return trial.value <= point.value + 1e-4 * alpha * slope


class _Watchdog:
    """Chamberlain's watchdog on a non-conservative problem (no Φ): a full step that raises
    the merit is taken and watched; if the merit is not back below the watched point's
    within ``WATCHDOG_STEPS`` full steps, the iteration returns there and backtracks."""

    def __init__(self, problem: NewtonProblem) -> None:
        self.enabled = problem.potential is None
        self._watched: _Point | None = None
        self._left = 0  # full steps left to the watched point
        self._backtrack = False  # set after a failed watch: the next step must backtrack

    def takes_full_step(self, trial: _Point, near: bool) -> bool:
        """Whether this iteration's full step ``trial`` is taken as it is, watched, rather
        than line-searched: not near the root, not right after a failed watch, and only to
        a state whose force could be evaluated."""
        full = self.enabled and not self._backtrack and bool(np.isfinite(trial.value)) and (
            not near)
        self._backtrack = False
        return full

    def watch(self, point: _Point, trial_value: float, slope: float) -> None:
        """Start watching ``point`` when the full step from it fails Armijo's test (and no
        point is watched yet)."""
        if self._watched is None and trial_value > point.value + 1e-4 * slope:
            self._watched, self._left = point, WATCHDOG_STEPS

    def resume(self, point: _Point) -> _Point:
        """The point the iteration goes on from after reaching ``point``: ``point`` itself,
        or the watched point when the watch ran out without Armijo's decrease against it
        (the next step then backtracks)."""
        watched = self._watched
        if watched is None:
            return point
        if point.value <= watched.value * (1.0 - 2e-4):  # Armijo against the watched point
            self._watched = None
        elif self._left > 1:
            self._left -= 1
        else:
            self._watched, self._backtrack = None, True
            return watched
        return point


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
    jacobians = _Jacobians(problem, reuse)
    watchdog = _Watchdog(problem)
    # Every state a polishing solve keeps needs its J: the next iteration's, or the
    # verification's at the last (rodsim/solvers/base.py, equilibrium_factor). F and J in
    # one pass (tdcr-two-segment: 182 µs against 62 + 167) at the first state and at each
    # full step short of the root, which is almost always kept; a shortened step's state,
    # and a polishing step's, which round-off often refuses, take F alone.
    together = problem.prepare is not None and polish and reuse == "fresh"
    if together and max_iterations > 0:
        assert problem.prepare is not None
        problem.prepare(x)
    g = problem.force(x)
    point = _Point(problem, x, g)
    polishing = POLISH_ITERATIONS if polish else 0
    for iteration in range(max_iterations):
        if check is not None:
            check()
        if problem.correction is None and point.residual < tolerance:
            if polishing == 0:
                return NewtonResult(point.x, True, iteration, point.residual, "converged")
            polishing -= 1
        done = iteration + 1
        dx = jacobians.step(point)
        if not np.isfinite(dx).all():  # the method: no numpy wrapper
            return NewtonResult(point.x, False, done, point.residual, "singular Jacobian")
        # Near the root: the residual below the tolerance and, with a correction test, the
        # correction too (converged: x itself, the correction being negligible); a residual
        # below the tolerance with a correction above it is an ordinary Newton step.
        near = point.residual < tolerance
        if problem.correction is not None:
            if near and problem.correction(dx) < problem.correction_tolerance:
                return NewtonResult(point.x, True, done, point.residual, "converged")
            near = False
        dx, slope = _descent(problem, jacobians.jacobian, point, dx, near)
        jacobians.release()
        if slope >= 0.0:
            return NewtonResult(point.x, near, done, point.residual, "converged" if near else
                                "Newton direction is not a descent direction (unstable state)")
        full = _trial(problem, point.x, dx, together and not near)
        if watchdog.takes_full_step(full, near):
            watchdog.watch(point, full.value, slope)
            trial = full
        elif near:
            # Near the root (polishing) only a full step that halves the residual is kept;
            # one that does not ends the iteration (below): a shorter one would be kept only
            # if it halved the residual, which a step the full one overshoots does not do at
            # round-off — the state is the root already. (Armijo's test, which would keep a
            # step with no halving, would end it just the same: no merit is evaluated.)
            trial = full
        else:
            searched = _line_search(problem, point, dx, slope, full, check)
            if searched is None:
                return NewtonResult(point.x, False, done, point.residual, "line search failed")
            trial = searched
        if near and not trial.residual < 0.5 * point.residual:  # round-off
            return NewtonResult(point.x, True, done, point.residual, "converged")
        point = watchdog.resume(trial)
    converged = point.residual < tolerance and problem.correction is None
    return NewtonResult(point.x, converged, max_iterations, point.residual,
                        "converged" if converged else
                        f"no convergence in {max_iterations} Newton iterations")
