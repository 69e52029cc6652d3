"""The ``tiered`` evaluation path (rodsim/core/kernel_tier.py): numpy evaluations until they
have cost the budget, the compiled kernels after, and the same numbers either way.

The process's CPU clock is replaced by a counter that advances a fixed amount per reading, so
where the move happens is deterministic here (no test measures time)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import rodsim
from rodsim.core.kernel_tier import PROCESS_TIER
from rodsim.core.model import Model


class TickingClock:
    """A clock that advances ``tick`` seconds at every reading: one numpy evaluation (read
    before and after) costs one tick."""

    def __init__(self, tick: float) -> None:
        self.tick, self.now = tick, 0.0

    def __call__(self) -> float:
        self.now += self.tick
        return self.now


@pytest.fixture
def tier(monkeypatch):
    """The process's account, reset, with a ticking clock: each numpy evaluation 0.01 s."""
    PROCESS_TIER.reset()
    monkeypatch.setattr(PROCESS_TIER, "clock", TickingClock(0.01))
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


@pytest.mark.parametrize("name, budget", [("table1-50g", 0.2), ("table3-catheter1", 0.5),
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
