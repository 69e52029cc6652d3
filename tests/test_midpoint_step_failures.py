"""A midpoint step whose force is not finite fails with that reason (StepFailure, the
run's message then says where and what to try), wherever the non-finite entry sits: on a
node's position or on a segment's quaternion, whose part along q is projected away
(rodsim/solvers/physical/midpoint.py checks the averaged force once, not each point)."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.core.damping import Damping
from rodsim.core.model import Model
from rodsim.solvers.physical.coordinates import PhysicalCoordinates, physical_state
from rodsim.solvers.physical.fixed_step import Motion, StepFailure
from rodsim.solvers.physical.midpoint import MidpointStep


def _step_with_a_bad_force(monkeypatch, where: str, value: float, fresh: bool) -> str:
    model = Model(rodsim.load_scene("table1-50g"))
    x = physical_state(model, model.x0)
    coordinates = PhysicalCoordinates.of(model, x)
    stepper = MidpointStep(coordinates, Damping(model), 0.1)
    index = (coordinates.positions[-1] if where == "position"
             else coordinates.quaternions[-1][0])
    original = model.evaluate_fresh

    def poisoned(state, load=1.0, *, jacobian=True):
        f, j = original(state, load, jacobian=jacobian)
        f = f.copy()
        f[index] = value
        return f, j

    monkeypatch.setattr(model, "evaluate_fresh", poisoned)
    if not fresh:  # a kept Newton matrix: its attempt fails on the force alone, then the
        # step's fresh one on the force and its Jacobian
        stepper.kept.h, stepper.kept.solve = 1e-3, lambda b: np.zeros_like(b)
    start = Motion(x, np.zeros(len(coordinates.positions)),
                   np.zeros((len(coordinates.quaternions), 3)))
    with pytest.raises(StepFailure) as failure:
        stepper.step(model, start, 1e-3)
    return str(failure.value)


@pytest.mark.parametrize("where", ["position", "quaternion"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
@pytest.mark.parametrize("fresh", [True, False])
def test_a_force_that_is_not_finite_fails_the_step_with_that_reason(monkeypatch, where,
                                                                    value, fresh):
    assert "force or its Jacobian is not finite" in _step_with_a_bad_force(
        monkeypatch, where, value, fresh)
