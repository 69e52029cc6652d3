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
from rodsim.core.assembly_budget import AssemblyBudget, AssemblyBudgetExceeded
from rodsim.core.model import Model
from rodsim.core.sparsity import unique_keys
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
    # Warm: a cold kernel cache would otherwise compile inside the timed solve.
    assert rodsim.solve(rodsim.load_scene("table1-50g", ["nodes=10"]), integrator).success
    lines: list[str] = []
    start = time.perf_counter()
    result = rodsim.solve(scene, integrator, model=slow_model(scene),
                          progress=lambda fraction, line: lines.append(line))
    elapsed = time.perf_counter() - start
    assert not result.success
    assert "wall-time budget" in result.message and "Newton iteration" in result.message
    # Stopped soon after the budget (each Newton iteration makes one or two force
    # evaluations, the final residual and the result check a few more), far before the
    # whole solve (10 000 iterations, each SLEEP or more: 500 s). The margin, 200 SLEEPs,
    # is wide because a machine loaded 6x over its cores made 40 SLEEPs take 4.7 s.
    assert elapsed < BUDGET + 200 * SLEEP, elapsed
    assert any("Newton iteration" in line for line in lines), lines


def test_the_budget_covers_the_model_assembly(monkeypatch):
    """An assembly longer than the budget fails the run at once: the clock starts in
    rodsim.solve, before the model is built."""

    def slow_assembly(scene, budget=None):  # the budget spent before the model is built,
        time.sleep(BUDGET + 0.1)               # and none for the assembly (see below)
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
    # Spent in the assembly or in the first Newton solve, depending on the machine's speed.
    assert code == 1 and "wall-time budget of 0.01 s" in err, err
    assert not output.exists()
    # The budget cut the run short: fewer Newton iterations than the full solve needs.
    # The model built beforehand, so that the budget is spent in the Newton solve.
    scene = rodsim.load_scene("table1-50g", ["nodes=5000", "max_wall_time=0.01"])
    cut = rodsim.solve(scene, "static", model=Model(scene))
    full = rodsim.solve(scene, "static", overrides=["max_wall_time=600"])
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
                            force_residual=lambda g: float(np.max(np.abs(g))),
                            weight=np.ones(1))
    with pytest.raises(SolverFailure, match="stop"):
        newton(problem, np.zeros(1), 1e-30, 100, check=check)
    assert calls == [0, 1, 2]
    assert newton(problem, np.zeros(1), 1e-6, 100).iterations > 3  # it needed more


# --- the assembly itself honours the budget (issue 23, item 5: N = 200 000 with a 5 s budget
# failed only after ~24 s) -------------------------------------------------------------------


def test_an_assembly_past_its_budget_stops_naming_n():
    """A budget already spent stops the assembly at its first check, with the message that
    names the time, N and the remedies."""
    scene = rodsim.load_scene("table1-50g", ["nodes=300"])
    spent = AssemblyBudget(time.perf_counter() - 1.0, 0.5, 300)
    with pytest.raises(AssemblyBudgetExceeded) as raised:
        Model(scene, budget=spent)
    text = str(raised.value)
    assert text.startswith("model assembly exceeded max_wall_time after ")
    assert "at N = 300 (wall-time budget of 0.5 s), lower nodes or raise the budget" in text


def test_the_budget_is_checked_inside_the_pattern_sort_and_changes_no_number():
    """The clock is read between the assembly's phases, between its terms and between the
    passes of the pattern's unique-key sort (one pass over 40 M entries took ~3 s at
    N = 200 000); a model built under a generous budget is the model built without one."""
    scene = rodsim.load_scene("table1-50g", ["nodes=300"])
    ticks = []

    class Counting:
        def check(self) -> None:
            ticks.append(1)

    budgeted = Model(scene, budget=Counting())
    plain = Model(scene)
    # Five phases, each term (3 rods terms built, 3 pattern keys, 3 targets), the sort's 7.
    assert len(ticks) >= 20
    assert (budgeted.pattern != plain.pattern).nnz == 0
    assert np.array_equal(budgeted._jac_targets, plain._jac_targets)
    assert budgeted.residual_floor == plain.residual_floor
    assert getattr(budgeted, "_budget", None) is None  # not carried to later copies
    keys = np.array([7, 3, 7, 12, 0, 3, 5])
    sort_ticks = []
    unique, position = unique_keys(keys, 4, lambda: sort_ticks.append(1))
    expected, inverse = np.unique(keys, return_inverse=True)
    assert np.array_equal(unique, expected) and np.array_equal(position, inverse.ravel())
    assert len(sort_ticks) >= 3


def test_solve_returns_the_assembly_overrun_as_a_failed_result(monkeypatch):
    """rodsim.solve does not raise on a solver failure, this one included: a failed result
    with the assembly's message and no shape."""
    monkeypatch.setattr(rodsim.app.api, "check_memory", lambda scene: time.sleep(BUDGET + 0.1))
    result = rodsim.solve("table1-50g", "static", overrides=["nodes=300",
                                                             f"max_wall_time={BUDGET}"])
    assert not result.success and result.rods == {} and len(result.state) == 0
    assert result.message.startswith("model assembly exceeded max_wall_time after ")
    assert f"(wall-time budget of {BUDGET:g} s)" in result.message
    assert result.stats["newton_iters"] == 0 and result.stats["wall_time"] > BUDGET


def test_a_slow_start_fails_the_assembly_through_the_cli(tmp_path, cli, capsys, monkeypatch):
    """The issue's case made machine-independent: the budget spent before the model is
    built (a sleep where the memory check runs) fails the run at the assembly's first check,
    exit 1 in one line naming N; nothing is written."""
    def slow_check(scene):
        time.sleep(BUDGET + 0.1)

    monkeypatch.setattr(rodsim.app.api, "check_memory", slow_check)
    output = tmp_path / "big.nc"
    code = cli(["run", "--integrator", "static", "--set", "nodes=2000", "--set",
                f"max_wall_time={BUDGET}", "-o", str(output)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1, err
    assert err[0].startswith("rodsim: solver failure: model assembly exceeded max_wall_time "
                             "after "), err
    assert (f"at N = 2000 (wall-time budget of {BUDGET:g} s), lower nodes or raise the budget"
            in err[0])
    assert not output.exists()
