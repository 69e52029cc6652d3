"""Continuation shared by the integrators: in the loads, in the penalties, by homotopy.

- ``load_continuation``: the external loads applied in increments λ ∈ (0, 1], each a
  Newton solve from the last, the increment quartered after a failure and doubled after an
  easy step (``static``);

and, for stiff penalties: a penalty term much stiffer than bending at the scale of a segment
(K_P l² / (E I) above a ratio) makes Newton from far away converge slowly or not at all
(docs/benchmark-history.md, "Solver design measurements"). The integrators then solve first with
those penalties lowered to the ratio — a model whose equilibrium is next to the full one —
and raise them back from there (``static``; the Newton finish of CVODE and IDA):

- ``penalty_scales``: the term scales that lower every such penalty to the ratio (raised
  back on the model reached, ``Model.with_term_scales``, which keeps its registration);
- ``homotopy``: F(x) = 0 solved from x by residual homotopy, F(y) − (1 − λ) F(x) = 0 for
  λ rising from 0 to 1 in steps (the SUNDIALS integrators' Newton finish).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import numpy as np

from rodsim.core.model import Model
from rodsim.solvers.base import Outcome
from rodsim.solvers.newton import NewtonProblem, newton
from rodsim.solvers.run_state import RunState

__all__ = ["DEFAULT_PENALTY_RATIO", "HOMOTOPY_FIRST_STEP", "HOMOTOPY_MIN_STEP",
           "EASY_ITERATIONS", "penalty_scales", "homotopy", "load_continuation"]

#: Default K_P l²/(E I) above which a penalty is lowered (``static``'s ``penalty_ratio``, and
#: the ratio of the SUNDIALS integrators' Newton finish).
DEFAULT_PENALTY_RATIO = 1e3

#: First homotopy step of the finish on a non-conservative model with stiff penalties, and
#: the smallest before it gives up (:func:`homotopy`).
HOMOTOPY_FIRST_STEP = 0.5
HOMOTOPY_MIN_STEP = 1e-3
#: A continuation step that converged within this many Newton iterations doubles the next.
EASY_ITERATIONS = 6

#: ``newton(x, load, polish)``: a Newton solve at a load fraction from x, counted by the
#: caller: (converged, x reached, iterations).
NewtonAt = Callable[[np.ndarray, float, bool], tuple[bool, np.ndarray, int]]


def penalty_scales(model: Model, ratio: float = DEFAULT_PENALTY_RATIO) -> dict[int, float]:
    """Scales (term index → factor) lowering every penalty term of ``model`` stiffer than
    ``ratio`` to it (empty when none is)."""
    # A penalty term carries penalty_ratio (K l²/(E I)); the term contract does not declare
    # it yet (issue 21 item 3), hence the cast.
    stiff = {k: float(cast(Any, term).penalty_ratio) for k, term in enumerate(model.terms)
             if term.penalty}
    return {k: ratio / value for k, value in stiff.items() if value > ratio}


def homotopy(run: RunState, x: np.ndarray, max_iterations: int,
             check: Callable[[float], Callable[[], None]]) -> tuple[bool, np.ndarray, int]:
    """Solve F(x) = 0 on ``run.model`` from ``x`` by residual homotopy: Newton on
    F(y) − (1 − λ) F(x) = 0 (x solves it at λ = 0) for λ rising in steps from
    ``HOMOTOPY_FIRST_STEP``, quartered after a failure and doubled after an easy step, as
    ``static``'s load continuation; every evaluation through the run's counted ones,
    ``check(λ)`` the per-iteration callback. (converged, state, iterations). The first step
    was measured: docs/benchmark-history.md, "CVODE and IDA: the Newton finish"."""
    model = run.model
    start = run.force(x)
    lam, step, total = 0.0, HOMOTOPY_FIRST_STEP, 0
    while lam < 1.0:
        target = min(1.0, lam + step)
        shift = (1.0 - target) * start

        def shifted(y: np.ndarray, shift: np.ndarray = shift) -> np.ndarray:
            return run.force(y) - shift

        problem = NewtonProblem(
            force=shifted, jacobian=run.jacobian_data,
            linear=run.linear_solver(), force_residual=model.force_residual,
            weight=model.residual_weight, step=model.step)
        outcome = newton(problem, x, run.tolerance, max_iterations, polish=False,
                         check=check(target))
        total += outcome.iterations
        if not outcome.converged:
            step *= 0.25
            if step < HOMOTOPY_MIN_STEP:
                return False, x, total
            continue
        x, lam = outcome.x, target
        if outcome.iterations <= EASY_ITERATIONS:
            step = min(1.0, 2.0 * step)
    return True, x, total


def load_continuation(run: RunState, model: Model, first_step: float, min_step: float,
                      newton_at: NewtonAt, before: Callable[[str], None],
                      after: Callable[[float], None], predict: bool = False) -> Outcome:
    """Apply the loads to ``model`` (which becomes ``run.model``) in increments from its rest
    state and registration, the first ``first_step``, quartered after a failed Newton solve
    (the run fails below ``min_step``) and doubled after an easy one; a tendon point that
    changes parent repeats the solve at the same load, and at full load the run ends once the
    registration settles (exact re-registration). Only the last solve (full load, penalties
    at their values) is polished. ``before(where)`` is called before each solve (the budget),
    ``after(load)`` after each accepted step (progress).

    ``predict``: each solve after the second starts from the secant through the last two
    equilibria, x + (x − x_prev) (λ_target − λ)/(λ − λ_prev), instead of from the last one
    (``static`` takes it on a model with contact:
    ``rodsim.solvers.static.secant_predicted``)."""
    run.model = model
    x = model.x0
    load, step = 0.0, first_step
    previous: tuple[np.ndarray, float] | None = None  # the equilibrium before x, its load
    final = bool(np.all(model.term_scales == 1.0))
    while load < 1.0 or not run.settled(x):
        target = min(1.0, load + step)
        before(f"load fraction {target:.4g}")
        start = x
        if predict and previous is not None and target > load > previous[1]:
            start = x + (x - previous[0]) * ((target - load) / (load - previous[1]))
        converged, x_new, iterations = newton_at(start, target, final and target >= 1.0)
        if not converged:
            step *= 0.25
            if step < min_step:
                return Outcome(x, False, f"Newton did not converge at load fraction "
                               f"{target:.4g} and the load step fell below min_load_step")
            continue
        if run.reregister(x_new):
            x = x_new  # a tendon point changed parent: solve again at this load
            continue
        previous = x, load
        x, load = x_new, target
        run.counts["steps"] += 1
        run.checkpoint(x, f"load fraction {load:.4g}")
        run.record(load, x, run.residual_at(x))
        after(load)
        if iterations <= EASY_ITERATIONS:
            step = min(1.0, 2.0 * step)
    return Outcome(x, True, "converged")
