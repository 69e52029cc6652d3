"""Penalty lowering and residual-homotopy continuation, shared by the integrators.

A penalty term much stiffer than bending at the scale of a segment (K_P l² / (E I) above a
ratio) makes Newton from far away converge slowly or not at all (rodsim/solvers/static.py
has the measurements). The integrators then solve first with those penalties lowered to the
ratio — a model whose equilibrium is next to the full one — and raise them back from there:

- :func:`penalty_scales`: the term scales that lower every such penalty to the ratio;
- :func:`with_registration_of`: a model with other scales but the registration reached;
- :func:`homotopy`: F(x) = 0 solved from x by residual homotopy, F(y) − (1 − λ) F(x) = 0 for
  λ rising from 0 to 1 in steps (the SUNDIALS integrators' Newton finish).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import numpy as np

from rodsim.core.model import Model
from rodsim.solvers.newton import NewtonProblem, newton
from rodsim.solvers.run_state import RunState

__all__ = ["DEFAULT_PENALTY_RATIO", "HOMOTOPY_FIRST_STEP", "HOMOTOPY_MIN_STEP",
           "penalty_scales", "with_registration_of", "homotopy"]

#: Default K_P l²/(E I) above which a penalty is lowered (``static``'s ``penalty_ratio``, and
#: the ratio of the SUNDIALS integrators' Newton finish).
DEFAULT_PENALTY_RATIO = 1e3

#: First homotopy step of the finish on a non-conservative model with stiff penalties, and
#: the smallest before it gives up (:func:`homotopy`).
HOMOTOPY_FIRST_STEP = 0.5
HOMOTOPY_MIN_STEP = 1e-3


def penalty_scales(model: Model, ratio: float = DEFAULT_PENALTY_RATIO) -> dict[int, float]:
    """Scales (term index → factor) lowering every penalty term of ``model`` stiffer than
    ``ratio`` to it (empty when none is)."""
    # A penalty term carries penalty_ratio (K l²/(E I)); the term contract does not declare
    # it yet (issue 21 item 3), hence the cast.
    stiff = {k: float(cast(Any, term).penalty_ratio) for k, term in enumerate(model.terms)
             if term.penalty}
    return {k: ratio / value for k, value in stiff.items() if value > ratio}


def with_registration_of(model: Model, registered: Model) -> Model:
    """``model`` (same terms, other scales) with the registration of ``registered``."""
    terms = [current if current.dynamic else term
             for current, term in zip(registered.terms, model.terms, strict=True)]
    if all(a is b for a, b in zip(terms, model.terms, strict=True)):
        return model
    return model.with_terms(terms)


def homotopy(run: RunState, x: np.ndarray, max_iterations: int,
             check: Callable[[float], Callable[[], None]]) -> tuple[bool, np.ndarray, int]:
    """Solve F(x) = 0 on ``run.model`` from ``x`` by residual homotopy: Newton on
    F(y) − (1 − λ) F(x) = 0 (x solves it at λ = 0) for λ rising in steps from
    :data:`HOMOTOPY_FIRST_STEP`, quartered after a failure and doubled after an easy step, as
    ``static``'s load continuation; every evaluation through the run's counted ones,
    ``check(λ)`` the per-iteration callback. (converged, state, iterations). The first step
    was measured: docs/benchmarks.md, "CVODE and IDA: the Newton finish"."""
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
            linear=run.linear_solver(), residual=model.residual,
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
        if outcome.iterations <= 6:
            step = min(1.0, 2.0 * step)
    return True, x, total
