"""Damping set from the command line (``--set``) on a scene that has no
``[rods.<rod>.damping]`` table: every rod's damping values are keys a scene may take
(rodsim/core/scene.py), read only by ``simulate`` and ``modes`` (docs/dynamics.md)."""

from __future__ import annotations

import pytest

import rodsim
from rodsim.core.schema import SceneError


@pytest.mark.parametrize("key", ["damping.retardation_time", "retardation_time",
                                 "rods.catheter.damping.retardation_time"])
def test_damping_is_set_on_a_scene_without_its_table(key):
    plain = rodsim.load_scene("table1-50g", ["nodes=11"])
    assert "damping" not in plain.data["rods"]["catheter"]
    scene = rodsim.load_scene("table1-50g", ["nodes=11", f"{key}=1e-3"])
    assert scene.data["rods"]["catheter"]["damping"] == {"retardation_time": 1e-3,
                                                         "drag": 0.0}
    damped = rodsim.simulate(scene, 0.01)
    undamped = rodsim.simulate(plain, 0.01)
    assert damped.success and undamped.success
    assert damped.dissipated_energy[-1] > 0.0 == undamped.dissipated_energy[-1]


def test_an_ambiguous_or_bad_damping_key_is_one_line():
    with pytest.raises(SceneError, match="ambiguous") as caught:
        rodsim.load_scene("table3-catheter1", ["damping.drag=0.1"])
    assert "rods.catheter.damping.drag" in str(caught.value) and "\n" not in str(caught.value)
    with pytest.raises(SceneError, match="out of range"):
        rodsim.load_scene("table1-50g", ["damping.drag=-1"])
    scene = rodsim.load_scene("table3-catheter1", ["rods.tendon.damping.drag=0.1"])
    assert scene.data["rods"]["tendon"]["damping"]["drag"] == 0.1
