"""The Tracker's verdict at every step through a stability limit (issue 35 item 3): the same
flags as ``track``'s verdicts of the same ramp, and as independent references — Euler's
critical load π² E I / (4 L²) of a clamped–free column (conservative K: the symmetric
verdict), and the dense eigenvalues of K at each step (table3-catheter1 pushed along its
axis: a non-symmetric K whose double real eigenvalue crosses zero, which the sign of det K
does not see). Its states are the track's (other predictors, the same straight branch:
measured 3.2e-14 m on the column and 7.9e-15 m on the catheter, both bounded here by 1e-10
of the rod's length)."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with
from rodsim.app.inverse.sensitivity import registered_model
from rodsim.app.inverse.track import track
from rodsim.core.model import Model
from tests.test_stability import euler_load

PUSHED = ["tendons.tendon.tendon_actuation.force=0",
          'rods.catheter.terms=["stretch", "bend_twist", "centerline", "tip_load"]',
          "rods.catheter.tip_load.force=[0, 0, 0]"]


def tracked(scene, key: str, values: np.ndarray) -> tuple[list, rodsim.Tracker]:
    """The Tracker built at ``values[0]``, stepped through the others."""
    keys = numeric_keys(scene, [key])
    tracker = rodsim.Tracker(scene_with(scene, keys, values[:1]), [key])
    steps = [tracker.step([value]) for value in values[1:]]
    assert all(step.success for step in steps), [step.message for step in steps]
    return steps, tracker


def full_states(tracker: rodsim.Tracker, steps: list) -> np.ndarray:
    return np.array([tracker.continuation.model.full(step.state) for step in steps])


def test_a_column_past_its_euler_load_is_flagged_at_the_same_steps_as_track():
    base = rodsim.load_scene("table1-50g", ["nodes=20", "mass=0"])
    fractions = np.array([0.0, 0.3, 0.6, 0.85, 1.15, 1.4, 1.7])
    forces = -fractions * euler_load(base)
    key = "tip_load.force[0]"
    steps, tracker = tracked(base, key, forces)
    flags = [step.stability.stable for step in steps]
    assert flags == [bool(f < 1.0) for f in fractions[1:]]
    path = track(base, {key: forces}, allow_unstable=True)
    assert path.success
    assert flags == path.stable[1:]
    unstable = [k for k, step in enumerate(steps) if not step.stability.stable]
    assert np.allclose([steps[k].stability.min_eigenvalue for k in unstable],
                       np.array(path.min_eigenvalues)[1:][unstable], rtol=1e-6)
    length = base.data["rods"][next(iter(base.data["rods"]))]["length"]
    assert np.abs(full_states(tracker, steps) - np.array(path.states[1:])).max() <= 1e-10 * length


def test_a_double_crossing_of_a_non_symmetric_stiffness_is_flagged_at_the_same_steps():
    scene = rodsim.load_scene("table3-catheter1", PUSHED)
    forces = np.linspace(0.0, -1.5, 8)
    key = "rods.catheter.tip_load.force[0]"
    steps, tracker = tracked(scene, key, forces)
    path = track(scene, {key: forces}, allow_unstable=True)
    assert path.success and 0 < len(path.unstable_steps) < len(forces) - 1
    flags = [step.stability.stable for step in steps]
    assert flags == path.stable[1:]
    for step, force in zip(steps, forces[1:], strict=True):
        model = Model(rodsim.load_scene("table3-catheter1", [
            *PUSHED[:2], f"rods.catheter.tip_load.force=[{float(force)!r}, 0, 0]"]))
        model = registered_model(model, step.state)
        smallest = float(np.min(np.linalg.eigvals(-model.jacobian(step.state).toarray()).real))
        assert step.stability.stable == (smallest > 0.0)
        if not step.stability.stable:
            assert step.stability.min_eigenvalue == pytest.approx(smallest, rel=1e-6)
    length = scene.data["rods"]["catheter"]["length"]
    assert np.abs(full_states(tracker, steps) - np.array(path.states[1:])).max() <= 1e-10 * length


def test_the_tendon_ramp_of_the_tracking_benchmark_is_the_tracks():
    """table3-catheter1's tendon force 0 → 4 N in 21 steps (the benchmark's ramp, coarser):
    every step stable, as in track, and the same equilibria to the solver's tolerance (the
    Tracker's second-order predictor starts elsewhere; measured 2.1e-10 m on the
    benchmark's small size)."""
    scene = rodsim.load_scene("table3-catheter1")
    key = "tendons.tendon.tendon_actuation.force"
    forces = np.linspace(0.0, 4.0, 21)
    steps, tracker = tracked(scene, key, forces)
    path = track(scene, {key: forces})
    assert path.success and all(path.stable)
    assert [step.stability.stable for step in steps] == path.stable[1:]
    length = scene.data["rods"]["catheter"]["length"]
    assert np.abs(full_states(tracker, steps) - np.array(path.states[1:])).max() <= 1e-7 * length
