"""The continuation of track, fit and reach (rodsim/app/inverse/continuation.py): a walk that
fails leaves the continuation at the equilibrium it started from, even when some of its
sub-steps succeeded, so that a fit or a reach goes on from the values it holds."""

from __future__ import annotations

import numpy as np

import rodsim
from rodsim.app.inverse.continuation import Continuation, StepOutcome
from rodsim.app.inverse.parameter_keys import numeric_keys
from rodsim.core.model import Model


def test_a_failed_walk_goes_back_to_where_it_started(monkeypatch):
    scene = rodsim.load_scene("table1-50g", ["nodes=10"])
    first = rodsim.solve(scene, "static")
    keys = numeric_keys(scene, ["tip_load.mass"])
    continuation = Continuation(Model(scene), first.state)
    start_x, start_model = continuation.x.copy(), continuation.model
    solve = Continuation.solve

    def solve_below(self, there, start=None):  # no equilibrium above 0.07 kg
        if there.get("rods.catheter.tip_load.mass") > 0.07:
            return StepOutcome(False, self.x, np.nan, 0, "refused by the test")
        return solve(self, there, start)

    monkeypatch.setattr(Continuation, "solve", solve_below)
    ok, _, failures, message = continuation.walk(scene, keys, np.array([0.05]),
                                                 np.array([0.09]))
    assert not ok and message == "refused by the test" and failures > 1
    # Sub-steps toward 0.07 kg succeeded on the way; the walk went back to 0.05 kg.
    np.testing.assert_array_equal(continuation.x, start_x)
    assert continuation.model is start_model
    assert continuation.model.scene.get("rods.catheter.tip_load.mass") == 0.05
