"""The globalised Newton iteration shared by ``static`` and ``paper``
(rodsim/solvers/newton.py): the watchdog on non-conservative problems."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp
from kernel_passes import counting_passes

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
                         force_residual=lambda g: float(np.max(np.abs(g))),
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

        problem = NewtonProblem(model.force, jacobian, linear, model.force_residual,
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
                            force_residual=lambda g: float(np.max(np.abs(g))), weight=np.ones(1),
                            potential=lambda y: 1.0 / (1.0 + float(y @ y)))
    result = newton(problem, np.array([1e-3]), 1.0, 10)
    assert result.converged and result.x[0] == 1e-3
    assert len(calls) == 2  # the start and the rejected full step


def test_the_correction_test_sees_an_imbalance_spread_over_many_nodes():
    """g(y) = −A(y − y*) + c (y − y*)³ (c = 1e-5) with A the stiffness of a chain of 2 000
    springs held at one end, from y* + a smooth displacement of 1 % of the chain's span:
    every node's force is far below the tolerance (|A δ| ≈ 5e-9; a unit load per node reaches
    max |A⁻¹ 1| ≈ 2e6), so the max-norm test alone stops at once, 1e-2 from the root; with
    the correction test (|Δy| over that reach below 1e-12) Newton goes on to the root."""
    n = 2000
    main = np.full(n, 2.0)
    main[-1] = 1.0
    stiffness = sp.diags([main, -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1], format="csc")
    coo = stiffness.tocoo()
    order = np.lexsort((coo.row, coo.col))
    rows, cols = coo.row[order], coo.col[order]
    data = -coo.data[order]
    linear = LinearSolver(sp.csc_matrix(stiffness), rows, cols, (1, 1), symmetric=True)
    root = np.linspace(0.0, 1.0, n)
    cube = 1e-5

    def force(y: np.ndarray) -> np.ndarray:
        return -(stiffness @ (y - root)) + cube * (y - root) ** 3

    def jacobian(y: np.ndarray) -> np.ndarray:
        values = data.copy()
        values[rows == cols] += 3.0 * cube * (y - root)[cols[rows == cols]] ** 2
        return values

    reach = float(np.max(np.abs(linear.solve(-data, np.ones(n)))))
    start = root + 1e-2 * np.sin(0.5 * np.pi * np.arange(1, n + 1) / n)
    problem = NewtonProblem(force=force, jacobian=jacobian, linear=linear,
                            force_residual=lambda g: float(np.max(np.abs(g))), weight=np.ones(n))
    assert problem.force_residual(force(start)) < 1e-5
    alone = newton(problem, start, 1e-5, 20, polish=False)
    assert alone.converged and np.max(np.abs(alone.x - root)) > 5e-3
    corrected = newton(replace(problem, correction=lambda dy: float(np.max(np.abs(dy))) / reach,
                               correction_tolerance=1e-12), start, 1e-5, 20, polish=False)
    assert corrected.converged, corrected.message
    assert np.max(np.abs(corrected.x - root)) < 1e-9


def test_states_evaluated_in_one_pass_give_the_same_solve(monkeypatch):
    """static's Newton evaluates F and J in one pass (``prepare``, the model's memo) at its
    first state and at each full step's state short of the root, where it evaluated F,
    then J: the same equilibrium and counts, bit for bit; every J made is one the solve
    takes, once (tdcr-two-segment, measured: 5 one-pass evaluations, 4 of F alone and 1 of
    J alone against 9 of F and 6 of J)."""
    scene = rodsim.load_scene("tdcr-two-segment")
    calls = counting_passes(monkeypatch)
    one_pass = rodsim.solve(scene, "static")
    with_prepare = list(calls)
    calls.clear()
    import rodsim.solvers.base as base

    monkeypatch.setattr(base, "NewtonProblem",
                        lambda **fields: NewtonProblem(**{**fields, "prepare": None}))
    two_passes = rodsim.solve(scene, "static")
    assert one_pass.success and two_passes.success
    for name in one_pass.rods:
        assert np.array_equal(one_pass.rods[name].positions, two_passes.rods[name].positions)
    assert np.array_equal(one_pass.state, two_passes.state)
    assert ({k: v for k, v in one_pass.stats.items() if k != "wall_time"}
            == {k: v for k, v in two_passes.stats.items() if k != "wall_time"})
    assert (True, True) in with_prepare and (True, True) not in calls
    assert (with_prepare.count((True, True)) + with_prepare.count((False, True))
            == calls.count((False, True)))
    assert len(with_prepare) < len(calls)
