"""The globalised Newton iteration shared by ``static`` and ``paper``
(rodsim/solvers/newton.py): the watchdog on non-conservative problems."""

from __future__ import annotations

import numpy as np
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
