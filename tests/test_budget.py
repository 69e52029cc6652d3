"""The wall-time budget (issue 15, item 4): it covers the model's assembly, it is checked in
every Newton iteration of ``static`` and ``paper`` (not only between Newton solves), and
long Newton solves report progress.

The slow phases are made slow on purpose (a sleep in the force or in the assembly) so that
the tests are short and do not depend on the machine's speed.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
import scipy.sparse as sp

import rodsim
import rodsim.app.api
from rodsim.core.model import Model
from rodsim.solvers.base import SolverFailure
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.newton import NewtonProblem, newton

SLEEP = 0.05  # s added to every force evaluation
BUDGET = 0.3  # s


def slow_model(scene) -> Model:
    """The scene's model with SLEEP added to each force evaluation."""
    model = Model(scene)
    force = model.force

    def slow(x, load=1.0):
        time.sleep(SLEEP)
        return force(x, load)

    model.force = slow
    return model


@pytest.mark.parametrize(("integrator", "options"), [
    ("static", ["solver.static.first_load_step=1.0", "solver.static.max_newton=10000"]),
    ("paper", ["solver.paper.max_newton=10000", "solver.paper.h=10"]),
])
def test_the_budget_stops_a_long_newton_solve(integrator, options):
    """Before, the budget was checked between Newton solves only: one slow solve of the
    whole load (static) or one step (paper) ran to its end, far past the budget."""
    scene = rodsim.load_scene("table1-50g", ["nodes=10", f"max_wall_time={BUDGET}",
                                             *options])
    lines: list[str] = []
    start = time.perf_counter()
    result = rodsim.solve(scene, integrator, model=slow_model(scene),
                          progress=lambda fraction, line: lines.append(line))
    elapsed = time.perf_counter() - start
    assert not result.success
    assert "wall-time budget" in result.message and "Newton iteration" in result.message
    # Stopped within a few force evaluations of the budget (each Newton iteration makes one
    # or two, and the final residual one more).
    assert elapsed < BUDGET + 8 * SLEEP, elapsed
    assert any("Newton iteration" in line for line in lines), lines


def test_the_budget_covers_the_model_assembly(monkeypatch):
    """An assembly longer than the budget fails the run at once: the clock starts in
    rodsim.solve, before the model is built."""

    def slow_assembly(scene):
        time.sleep(BUDGET + 0.1)
        return Model(scene)

    monkeypatch.setattr(rodsim.app.api, "Model", slow_assembly)
    result = rodsim.solve(rodsim.load_scene("table1-50g", ["nodes=6",
                                                           f"max_wall_time={BUDGET}"]),
                          "static")
    assert not result.success
    assert "wall-time budget" in result.message and "model assembly" in result.message
    assert result.stats["newton_iters"] == 0


def test_a_tiny_budget_at_moderate_n_exits_1_through_the_cli(tmp_path, cli, capsys):
    """The issue's case, scaled down: N = 5000 with a 10 ms budget is a solver failure
    naming the budget, and writes nothing."""
    output = tmp_path / "big.nc"
    code = cli(["run", "--integrator", "static", "--set", "nodes=5000", "--set",
                "max_wall_time=0.01", "-o", str(output)])
    err = capsys.readouterr().err
    assert code == 1 and "wall-time budget of 0.01 s" in err, err
    assert not output.exists()
    # The budget cut the run short: fewer Newton iterations than the full solve needs.
    scene = rodsim.load_scene("table1-50g", ["nodes=5000"])
    cut = rodsim.solve(scene, "static", overrides=["max_wall_time=0.01"])
    full = rodsim.solve(scene, "static")
    assert not cut.success and full.success
    assert cut.stats["newton_iters"] < full.stats["newton_iters"]


def test_newton_calls_check_once_per_iteration_and_stops_when_it_raises():
    """The hook in rodsim/solvers/newton.py: a check that raises ends the iteration."""
    calls = []

    def check():
        calls.append(len(calls))
        if len(calls) == 3:
            raise SolverFailure("stop")

    # g(y) = -(y - 1)^3 converges linearly from 0: many iterations without the check.
    one = np.zeros(1, dtype=int)
    linear = LinearSolver(sp.csc_matrix(np.ones((1, 1))), one, one, (0, 0), symmetric=False)
    problem = NewtonProblem(force=lambda y: -(y - 1.0) ** 3,
                            jacobian=lambda y: -3.0 * (y - 1.0) ** 2,
                            linear=linear,
                            residual=lambda g: float(np.max(np.abs(g))),
                            weight=np.ones(1))
    with pytest.raises(SolverFailure, match="stop"):
        newton(problem, np.zeros(1), 1e-30, 100, check=check)
    assert calls == [0, 1, 2]
    assert newton(problem, np.zeros(1), 1e-6, 100).iterations > 3  # it needed more
