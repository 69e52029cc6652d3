"""``rodsim.Tracker`` (issue 35 item 3): the equilibrium at each step's actuation values,
warm-started from the last, with the tip's pose and its Jacobian from the step's own
factorisation. Checked against independent computations: every step's equilibrium against
a cold static solve of the same values (``rodsim.solve``, its own model), the tip Jacobian
against central differences of such cold solves, on tdcr-two-segment and on user robots
written from docs/scenes.md.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from kernel_passes import counting_passes

import rodsim
from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with
from rodsim.core.schema import SceneError

TDCR_KEYS = ["s1a.tendon_string.tension", "s2b.tendon_string.tension"]
TENSION = "tendons.s1a.tendon_string.tension"


def cold(scene: object, keys: list[str], values: np.ndarray, rod: str) -> np.ndarray:
    """The tip of ``rod`` solved from rest at ``values``, by itself."""
    result = rodsim.solve(scene_with(scene, numeric_keys(scene, keys), values), "static")
    assert result.success, result.message
    return result.tip(rod)


def finite_difference(scene, keys, values, rod, steps) -> np.ndarray:
    """d(tip)/d(values) (3, P) by central differences of cold solves."""
    columns = []
    for column, h in enumerate(steps):
        up, down = values.copy(), values.copy()
        up[column] += h
        down[column] -= h
        columns.append((cold(scene, keys, up, rod) - cold(scene, keys, down, rod)) / (2 * h))
    return np.column_stack(columns)


def check_path(scene, keys, path: np.ndarray, rod: str, length: float, every: int) -> None:
    tracker = rodsim.Tracker(scene, keys, rod=rod)
    for index, values in enumerate(path):
        step = tracker.step(values)
        assert step.success, step.message
        assert step.stability is not None and step.stability.stable
        assert np.array_equal(step.tip, step.positions[-1])
        assert abs(np.linalg.norm(step.tip_quaternion) - 1.0) < 1e-6
        if index % every:
            continue
        # The same equilibrium as a cold solve, to the solver's tolerance (measured on
        # tdcr-two-segment: 2e-9 L).
        assert np.linalg.norm(step.tip - cold(tracker.scene, keys, values, rod)) <= 1e-7 * length
        # The Jacobian against central differences of cold solves, h = 1e-3 of each value's
        # scale (truncation O(h²); measured on tdcr-two-segment: 3e-8 relative).
        scale = np.maximum(np.abs(values), 1e-3 * np.abs(path).max())
        reference = finite_difference(tracker.scene, keys, values, rod, 1e-3 * scale)
        size = np.abs(reference).max()
        assert size > 0
        assert np.abs(step.tip_jacobian - reference).max() <= 1e-4 * size


def test_tdcr_tracker_matches_cold_solves_and_finite_differences():
    path = np.column_stack([np.linspace(3.0, 3.6, 13), np.linspace(2.0, 0.8, 13)])
    check_path("tdcr-two-segment", TDCR_KEYS, path, "backbone", 0.4, every=6)


def test_a_step_of_the_scene_values_stays_put_and_a_far_step_halves():
    """A step to the scene's own values is the first equilibrium; a step far along (10 N
    on s1a at once) converges by halving if it must, and is the cold solve there."""
    tracker = rodsim.Tracker("tdcr-two-segment", TDCR_KEYS)
    same = tracker.step([3.0, 2.0])
    assert same.success
    far = tracker.step([10.0, 2.0])
    assert far.success, far.message
    tip = cold(tracker.scene, TDCR_KEYS, np.array([10.0, 2.0]), "backbone")
    assert np.linalg.norm(far.tip - tip) <= 1e-7 * 0.4


def test_bad_values_are_refused_and_the_tracker_stays():
    tracker = rodsim.Tracker("tdcr-two-segment", TDCR_KEYS)
    first = tracker.step([3.2, 1.9])
    with pytest.raises(SceneError, match="out of range"):
        tracker.step([-1.0, 2.0])
    with pytest.raises(SceneError, match="2 finite values"):
        tracker.step([1.0])
    with pytest.raises(SceneError, match="2 finite values"):
        tracker.step([math.nan, 1.0])
    assert np.array_equal(tracker.values, [3.2, 1.9])
    again = tracker.step([3.2, 1.9])
    assert np.linalg.norm(again.tip - first.tip) <= 1e-9


def user_catheter(rng: np.random.Generator, index: int) -> tuple[dict, float, float]:
    """A soft polymer catheter with two string tendons at 90°, written from docs/scenes.md
    (no coupling, no penalty), and the tension of a one-radian bend."""
    length = rng.uniform(0.1, 0.4)
    radius = rng.uniform(1e-3, 4e-3)
    young = 10.0 ** rng.uniform(6.5, 8.5)
    offset = 0.6 * radius
    pull = young * math.pi * radius**4 / 4 / (offset * length)
    robot = {"name": f"catheter-{index}", "rods": {"catheter": {
        "length": length, "radius": radius, "youngs_modulus": young, "density": 1200.0,
        "nodes": int(rng.integers(15, 30))}}, "tendons": {
        "left": {"catheter": "catheter", "offset": offset, "direction": [1.0, 0.0],
                 "tendon_actuation": {"force": 0.5 * pull}},
        "up": {"catheter": "catheter", "offset": offset, "direction": [0.0, 1.0],
               "tendon_actuation": {"force": 0.2 * pull}}}}
    return robot, length, pull


def test_seeded_user_catheters():
    rng = np.random.default_rng(353)
    keys = ["left.tendon_string.tension", "up.tendon_string.tension"]
    for index in range(3):
        robot, length, pull = user_catheter(rng, index)
        path = np.column_stack([np.linspace(0.5, 1.2, 8), np.linspace(0.2, 0.9, 8)]) * pull
        check_path(robot, keys, path, "catheter", length, every=7)


def test_a_steps_start_is_evaluated_in_one_pass_with_the_same_equilibria(monkeypatch):
    """A Tracker step's J at the start it keeps is its J₀ or its verification's: F and J
    there come from one pass (Continuation._weighed at the start the last step kept, or
    the chord iterations' start where no alternative was weighed; the model's memo). Along
    a tension ramp of tdcr-two-segment the states are the same bits as with the pass
    split, and F alone is evaluated once less a step (measured over 200 steps: 1.91
    against 2.91; table3-catheter1, which keeps the curved start, J alone 2.04 → 1.04)."""
    from rodsim.core.model_evaluation import ModelEvaluation

    def ramp() -> tuple[np.ndarray, list[tuple[bool, bool]]]:
        scene = rodsim.load_scene("tdcr-two-segment")
        keys = numeric_keys(scene, [TENSION])
        tracker = rodsim.Tracker(scene_with(scene, keys, [0.0]), [TENSION])
        calls = counting_passes(monkeypatch)
        states = [tracker.step([v]).state for v in np.linspace(0.0, 3.0, 21)[1:]]
        return np.array(states), list(calls)

    together, one_pass = ramp()
    # no model's memo keeps J: the pass split
    monkeypatch.setattr(ModelEvaluation, "keeps_jacobians", property(lambda self: False))
    apart, split = ramp()
    assert np.array_equal(together, apart)
    assert (True, True) in one_pass and (True, True) not in split
    assert one_pass.count((True, False)) < split.count((True, False))
    assert len(one_pass) < len(split)
