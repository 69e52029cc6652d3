"""The globalised Newton iteration shared by ``static`` and ``paper``
(rodsim/solvers/newton.py): the watchdog on non-conservative problems."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import rodsim
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.newton import NewtonProblem, newton


def arctan_problem() -> NewtonProblem:
    """g(y) = −arctan(y): Newton's full steps diverge from |y| > 1.39, so a watched full
    step never recovers and the iteration must return and backtrack."""
    one = np.zeros(1, dtype=int)
    linear = LinearSolver(sp.csc_matrix(np.ones((1, 1))), one, one, (0, 0), symmetric=False)
    return NewtonProblem(force=lambda y: -np.arctan(y),
                         jacobian=lambda y: -1.0 / (1.0 + y ** 2),
                         linear=linear,
                         residual=lambda g: float(np.max(np.abs(g))),
                         weight=np.ones(1))


def test_a_failed_watch_returns_and_backtracks_to_the_root():
    result = newton(arctan_problem(), np.array([2.0]), 1e-12, 60)
    assert result.converged, result.message
    assert abs(result.x[0]) < 1e-12


def test_full_steps_that_converge_are_kept_on_the_paper_coupling():
    """table3-catheter1's exact Newton steps first raise |W g| and then converge
    quadratically; with the watchdog ``static`` needed 228 Newton iterations (1065 when every
    such step was backtracked; 90 since the stiff penalties are lowered first on this
    non-conservative scene) and lands on the same equilibrium as the paper integrator."""
    static = rodsim.solve("table3-catheter1", "static")
    assert static.success, static.message
    assert static.stats["newton_iters"] < 500
    paper = rodsim.solve("table3-catheter1", "paper")
    assert paper.success, paper.message
    assert np.max(np.abs(static.positions() - paper.positions())) < 1e-6 * 0.16


@pytest.mark.parametrize("reuse", ["chord", "lagged"])
def test_jacobian_reuse_reaches_the_same_root(reuse):
    """Newton's ``reuse`` option with fewer Jacobian evaluations (what ``rodsim bench
    skip-work`` times): the lagged Jacobian converges on the root of the fresh iteration; the
    chord method, from rest at full load, crawls (as measured in
    benchmarks/results/skip-work-full.md) and says so."""
    from rodsim.solvers.linear import LinearSolver
    from rodsim.solvers.newton import NewtonProblem, newton

    model = rodsim.build_model(rodsim.load_scene("table1-50g", ["nodes=10"]))
    linear = LinearSolver(model.pattern, model.pattern_rows, model.pattern_cols,
                          (model.band.lower, model.band.upper), model.conservative)
    outcomes, jacobians = {}, {}
    for policy in ("fresh", reuse):
        calls = []

        def jacobian(x, calls=calls):
            calls.append(1)
            return model.jacobian_data(x)

        problem = NewtonProblem(model.force, jacobian, linear, model.residual,
                                model.residual_weight, model.energy)
        outcomes[policy] = newton(problem, model.x0, 1e-9, 400, polish=False, reuse=policy)
        jacobians[policy] = len(calls)
    assert outcomes["fresh"].converged
    assert jacobians[reuse] < jacobians["fresh"]
    if reuse == "chord":
        assert not outcomes[reuse].converged and "no convergence" in outcomes[reuse].message
        return
    assert outcomes[reuse].converged, outcomes[reuse].message
    scale = model.length_scale
    assert np.max(np.abs(outcomes[reuse].x - outcomes["fresh"].x)) < 1e-6 * scale


def test_polishing_does_not_backtrack():
    """Below the tolerance (polishing), a full step the energy test rejects and that does not
    halve the residual ends the iteration at once: backtracking could keep only a step that
    halves the residual, which a shorter one does not. Here a Jacobian twice too stiff makes
    every step exactly halve the residual (not strictly below half) and the energy grows
    toward the root; before, the iteration backtracked to alpha < 1e-10 (35 evaluations)."""
    calls = []

    def force(y):
        calls.append(y.copy())
        return -y

    one = np.zeros(1, dtype=int)
    linear = LinearSolver(sp.csc_matrix(np.ones((1, 1))), one, one, (0, 0), symmetric=False)
    problem = NewtonProblem(force=force, jacobian=lambda y: np.array([-2.0]), linear=linear,
                            residual=lambda g: float(np.max(np.abs(g))), weight=np.ones(1),
                            potential=lambda y: 1.0 / (1.0 + float(y @ y)))
    result = newton(problem, np.array([1e-3]), 1.0, 10)
    assert result.converged and result.x[0] == 1e-3
    assert len(calls) == 2  # the start and the rejected full step
