"""The ``tiered`` evaluation path (rodsim/core/kernel_tier.py): numpy evaluations until their
nominal cost passes the budget, the compiled kernels after, and the same numbers either way;
the move comes after the same evaluations on every run, whatever the clock says.

Most tests here charge a fixed nominal cost per numpy evaluation, so that where the move
happens is simple to state; the tests at the end use the real nominal costs."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import pytest

import rodsim
from rodsim.core import model_evaluation, model_scales
from rodsim.core.kernel_tier import PROCESS_TIER, nominal_cost
from rodsim.core.model import Model


@pytest.fixture
def tier(monkeypatch):
    """The process's account, reset, with each numpy evaluation charged 0.01 s."""
    PROCESS_TIER.reset()
    for charged in (model_evaluation, model_scales):  # the evaluations and the rest diagonal
        monkeypatch.setattr(charged, "nominal_cost", lambda *_, **__: 0.01)
    monkeypatch.setattr(PROCESS_TIER, "budget", 0.035)
    yield PROCESS_TIER
    PROCESS_TIER.reset()


def _tiered(name: str) -> rodsim.Scene:
    return rodsim.load_scene(name).with_values({"solver.kernels": "tiered"})


def test_auto_is_compiled_for_a_model_and_refuses_unknown_paths():
    scene = rodsim.load_scene("table1-50g")
    assert scene.solver.kernels == "auto"
    assert Model(scene).kernels == "compiled"
    with pytest.raises(ValueError, match="allowed"):
        Model(scene, kernels="fortran")


@pytest.mark.parametrize("name", ["table1-50g", "tdcr-two-segment", "four-tendons"])
def test_the_move_happens_once_the_budget_is_spent_and_keeps_the_numbers(tier, name):
    """Four numpy evaluations (0.04 s > 0.035 s; the first is the build's ∂F/∂x at rest),
    then compiled; every evaluation equals the numpy reference's to round-off, and those
    after the move are the compiled path's bit for bit."""
    scene = _tiered(name)
    model = Model(scene)
    assert tier.numpy_evaluations == 1 and not tier.compiled
    reference, compiled = Model(scene, kernels="numpy"), Model(scene, kernels="compiled")
    rng = np.random.default_rng(7)
    x0 = model.x0
    for k in range(8):
        x = x0 + 1e-4 * rng.standard_normal(x0.size)
        moved = tier.compiled
        f, j = model.evaluate(x)
        f_ref, j_ref = reference.evaluate(x)
        f_c, j_c = compiled.evaluate(x)
        scale_f, scale_j = np.abs(f_ref).max() + 1e-300, np.abs(j_ref).max()
        assert np.abs(f - f_ref).max() <= 1e-11 * scale_f
        assert np.abs(j - j_ref).max() <= 1e-11 * scale_j
        assert moved == (k >= 3)
        if moved:
            assert np.array_equal(f, f_c) and np.array_equal(j, j_c)
    assert tier.compiled and tier.numpy_evaluations == 4
    assert "first 4 evaluations" in tier.describe()


def test_energy_counts_toward_the_budget(tier):
    model = Model(_tiered("table1-50g"))  # one numpy evaluation: ∂F/∂x at rest
    energies = [model.energy(model.x0) for _ in range(4)]
    assert tier.compiled and tier.numpy_evaluations == 4
    assert energies[-1] == pytest.approx(energies[0], rel=1e-12, abs=1e-18)


def test_a_model_built_after_the_move_starts_compiled(tier):
    first = Model(_tiered("table1-50g"))
    for k in range(3):
        first.force(first.x0 + k * 1e-6)
    assert tier.compiled
    second = Model(_tiered("table3-catheter1"))
    second.force(second.x0)
    assert tier.numpy_evaluations == 4  # the second model's evaluation was compiled


@pytest.mark.parametrize("name, budget", [("table1-50g", 0.1), ("table3-catheter1", 0.5),
                                          ("tdcr-two-segment", 0.1)])
def test_a_solve_that_moves_midway_reaches_the_compiled_equilibrium(tier, name, budget):
    """The move in the middle of a solve (after budget/0.01 evaluations) changes the
    equilibrium only within the solver's tolerance."""
    tier.budget = budget
    scene = _tiered(name)
    moved = rodsim.solve(scene, "static")
    assert moved.success and tier.compiled
    assert 0 < tier.numpy_evaluations <= budget / 0.01 + 1
    plain = rodsim.solve(scene.with_values({"solver.kernels": "compiled"}), "static")
    length = max(shape.s[-1] for shape in plain.rods.values())
    difference = max(np.abs(moved.rods[rod].positions - plain.rods[rod].positions).max()
                     for rod in plain.rods)
    assert difference <= 1e-8 * length


def test_rodsim_run_stays_on_numpy_and_never_imports_numba(tmp_path):
    """`rodsim run` of the default scene (``auto``: tiered) in a fresh process: the archive
    and the summary say numpy, and numba was never imported."""
    output = tmp_path / "run.nc"
    code = ("import sys\nfrom rodsim.app.cli import main\n"
            f"status = main(['run', '-o', {str(output)!r}])\n"
            "print('numba imported:', 'numba' in sys.modules)\nsys.exit(status)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    assert "numba imported: False" in done.stdout
    assert "kernels     numpy (" in done.stdout
    from rodsim.io.archive import read_dataset

    dataset = read_dataset(output)
    assert dataset.attrs["kernels"].startswith("numpy (")
    assert json.loads(dataset.attrs["scene_json"])["solver"]["kernels"] == "tiered"


def test_user_robots_reach_the_compiled_equilibrium_when_the_move_comes_midway(tier):
    """The seeded family of user-like robots (tests/test_user_robot.py): a static solve that
    moves to the compiled kernels after ten numpy evaluations ends within 1e-8 L of the
    compiled path's equilibrium."""
    from test_user_robot import family

    tier.budget = 0.1
    for robot, _ in family()[:8]:
        tier.reset()
        tiered = rodsim.solve({**robot, "solver": {**robot["solver"], "kernels": "tiered"}},
                              "static")
        plain = rodsim.solve({**robot, "solver": {**robot["solver"], "kernels": "compiled"}},
                             "static")
        assert tiered.success == plain.success, robot["name"]
        if plain.success:
            assert tier.compiled, robot["name"]
            length = robot["rods"]["catheter"]["length"]
            difference = np.abs(tiered.positions("catheter") - plain.positions("catheter"))
            assert difference.max() <= 1e-8 * length, robot["name"]


def test_the_nominal_cost_is_a_function_of_the_terms_sizes():
    """A Jacobian costs more than a force (d² entries an element against d), a conserving
    lumen more than a paper one of the same size (its numpy_cost_factor), and the cost grows
    with the number of nodes."""
    small = Model(rodsim.load_scene("table1-50g"), kernels="numpy")
    large = Model(rodsim.load_scene("table1-50g", ["nodes=200"]), kernels="numpy")
    for model in (small, large):
        assert 0 < nominal_cost(model.terms, force=True, jacobian=False) \
            < nominal_cost(model.terms, force=False, jacobian=True)
    assert nominal_cost(large.terms, force=True, jacobian=True) \
        > 2 * nominal_cost(small.terms, force=True, jacobian=True)
    conserving = rodsim.load_scene("table3-catheter1", ["coupling=conserving"])
    paper = Model(rodsim.load_scene("table3-catheter1"), kernels="numpy")
    lumen = {type(term).__name__: term for term in Model(conserving, kernels="numpy").terms}
    paper_lumen = {type(term).__name__: term for term in paper.terms}["Lumen"]
    assert nominal_cost([lumen["ConservingLumen"]], force=False, jacobian=True) > 5 * \
        nominal_cost([paper_lumen], force=False, jacobian=True)


def test_the_move_does_not_read_the_clock(monkeypatch):
    """A clock that runs a thousand times faster moves nothing: the same evaluations are
    numpy, the same state is reached bit for bit. The solve's wall-time budget does read the
    clock, as it should: it is raised so that the fast clock cannot spend it (under load, a
    real 0.6 s read a thousand times faster spent the default 600 s)."""
    scene = _tiered("tip-on-tissue").with_values({"solver.max_wall_time": 1e6})

    def tiered_solve() -> tuple[int, np.ndarray]:
        PROCESS_TIER.reset()
        result = rodsim.solve(scene, "static")
        assert result.success and PROCESS_TIER.compiled, result.message
        return PROCESS_TIER.numpy_evaluations, result.positions()

    try:
        evaluations, positions = tiered_solve()
        real = time.process_time
        monkeypatch.setattr(time, "process_time", lambda: 1000.0 * real())
        monkeypatch.setattr(time, "perf_counter", lambda: 1000.0 * real())
        # (a clock the account held, as it did until 2026-12, runs fast too)
        monkeypatch.setattr(PROCESS_TIER, "clock", lambda: 1000.0 * real(), raising=False)
        again, moved = tiered_solve()
    finally:
        PROCESS_TIER.reset()
    assert again == evaluations
    assert np.array_equal(moved, positions)


_RUN_TIERED = """
import hashlib, sys
import rodsim
from rodsim.core.kernel_tier import PROCESS_TIER
scene = rodsim.load_scene("tip-on-tissue").with_values({"solver.kernels": "tiered"})
result = rodsim.solve(scene, "cvode")
digest = hashlib.sha256(result.positions().tobytes()).hexdigest()
print(result.success, PROCESS_TIER.numpy_evaluations, PROCESS_TIER.compiled, digest)
"""


@pytest.mark.slow
def test_a_contact_scene_gives_the_same_state_five_times_under_load():
    """tip-on-tissue under CVODE moves to the compiled kernels mid-run (after ~700 numpy
    evaluations). Run five times in fresh processes, all at once so that each loads the CPU
    for the others (five busy processes on the suite's two cores), it moves after the same
    evaluations and reaches the same state, bit for bit. (With the CPU clock charged, the
    same test — then one run after another beside a busy loop — gave five different
    states, the move after 353 to 551 evaluations.)"""
    runs = [subprocess.Popen([sys.executable, "-c", _RUN_TIERED], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True) for _ in range(5)]
    try:
        done = [run.communicate(timeout=600) for run in runs]
    finally:
        for run in runs:
            run.kill()
            run.wait()
    assert all(run.returncode == 0 for run in runs), [err[-1500:] for _, err in done]
    outputs = [out.split() for out, _ in done]
    assert all(output[0] == "True" and output[2] == "True" for output in outputs), outputs
    assert len({tuple(output) for output in outputs}) == 1, outputs
