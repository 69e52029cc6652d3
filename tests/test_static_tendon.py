"""``static`` on the paper's tendon coupling (non-conservative): the stiff penalties are
lowered from the start, Newton steps through the retraction Model.step, the load starts at
1/4 and the penalties are raised at once (rodsim/solvers/static.py). Newton iterations on
table3-catheter1: 227, then 88, now 29 (issue 11 asks ≤ 40). The bounds are the measured
counts with the margin of tests/counts.py (round-off moves a count between machines); the
exact counts are `rodsim bench iterations`'s."""

from __future__ import annotations

import numpy as np
import pytest
from counts import at_most

import rodsim


def test_static_on_table3_catheter1_is_cheap_and_on_the_paper_equilibrium():
    static = rodsim.solve("table3-catheter1", "static")
    assert static.success, static.message
    print(f"table3-catheter1 static: {static.stats['newton_iters']:.0f} Newton iterations, "
          f"{static.stats['steps']:.0f} steps")
    assert static.stats["newton_iters"] <= at_most(29)
    paper = rodsim.solve("table3-catheter1", "paper")
    assert paper.success, paper.message
    assert np.max(np.abs(static.positions() - paper.positions())) < 1e-6 * 0.16


@pytest.mark.parametrize("scene, iterations", [("table3-catheter2", 30),
                                               ("table3-catheter3", 29),
                                               ("tendon-conserving", 14)])
def test_static_iterations_on_the_other_tendon_scenes_do_not_regress(scene, iterations):
    """Measured: 86, 83, 21 before the retraction and the schedule of static.py; 29, 29, 14
    at 27422c4 (29, 30 on another machine). On the offset state (docs/model.md)
    table3-catheter2 takes 30: the extra one is a polishing iteration that now halves the
    residual (1.5e-11 → 2.9e-12) where it stalled on the positions' round-off."""
    static = rodsim.solve(scene, "static")
    assert static.success, static.message
    assert static.stats["newton_iters"] <= at_most(iterations)


@pytest.mark.parametrize("scene", ["table1-50g", "table3-catheter1", "four-tendons"])
def test_the_compiled_retraction_matches_the_numpy_reference(scene):
    """Model.step: the numba kernel (rodsim/core/kernels/_retraction.py) against the numpy code,
    and equal to x + dx to first order."""
    from rodsim.core.model import Model

    loaded = rodsim.load_scene(scene)
    compiled, reference = Model(loaded, kernels="compiled"), Model(loaded, kernels="numpy")
    rng = np.random.default_rng(3)
    x = compiled.x0 + 1e-3 * rng.normal(size=compiled.n)
    dx = 1e-3 * rng.normal(size=compiled.n)
    assert np.abs(compiled.step(x, dx) - reference.step(x, dx)).max() < 1e-15
    small = 1e-6 * dx
    assert np.abs(compiled.step(x, small) - (x + small)).max() < 1e-3 * np.abs(small).max()
