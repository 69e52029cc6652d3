"""``static`` on the paper's tendon coupling (non-conservative): the stiff penalties are
lowered from the start (rodsim/solvers/static.py). Before: 227 Newton iterations on
table3-catheter1; after: 90. The issue's target of 40 is not reached (see the module
docstring of static.py), so the bound here is the measured count with a margin."""

from __future__ import annotations

import numpy as np

import rodsim


def test_static_on_table3_catheter1_is_cheap_and_on_the_paper_equilibrium():
    static = rodsim.solve("table3-catheter1", "static")
    assert static.success, static.message
    print(f"table3-catheter1 static: {static.stats['newton_iters']:.0f} Newton iterations, "
          f"{static.stats['steps']:.0f} steps")
    assert static.stats["newton_iters"] <= 100
    paper = rodsim.solve("table3-catheter1", "paper")
    assert paper.success, paper.message
    assert np.max(np.abs(static.positions() - paper.positions())) < 1e-6 * 0.16
