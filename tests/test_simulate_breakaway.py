"""Stiction in physical time: when in a midpoint step a routing point breaks loose
(rodsim/solvers/physical/breakaway.py; docs/dynamics.md, "Friction in physical time").

- A rigid helix (the stiff rod of tests/test_tendon_stiction.py) pulled in from slack to
  T_max, every point sliding in with chord e at T_max e^{−μ_k Θ_e}, then let out by a
  linear ramp T(t) = T_max − r t: the points stop, and point e breaks loose outward when
  T(t) e^{μ_k Θ_{e−1} + μ_s θ_e} reaches its stored T_max e^{−μ_k Θ_e} (the points before it
  already sliding out at μ_k), at T_e = T_max e^{−2μ_kΘ_e − (μ_s−μ_k)θ_e}: at
  t_e = (T_max − T_e)/r in closed form, the turns from the helix's geometry.
- The self-bent catheter released from 3 N to 2.4 N in 0.03 s (μ_k = 0.25, μ_s = 0.5,
  damped): the tip converges at the midpoint rule's order as the step is halved.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_tendon_friction import catheter
from test_tendon_stiction import MU_K, MU_S, TENSION, helix_scene, helix_turns, string_term

import rodsim
from rodsim.app.programs import Programs
from rodsim.core.program import Table
from rodsim.core.scene import Scene


def _breakaways(monkeypatch, scene: Scene, duration: float, step: float,
                ramp: Table, start: float) -> dict[int, float]:
    """The first time each routing point of the scene's tendon reads as sliding out in the
    history a run carries (``Programs.carry_history``), point → time [s]."""
    first: dict[int, float] = {}
    carry = Programs.carry_history

    def watched(self, t, x, solved=None):
        end = carry(self, t, x, solved)
        for e in np.flatnonzero(string_term(self.model).state == 1.0):
            first.setdefault(int(e), float(t))
        return end

    monkeypatch.setattr(Programs, "carry_history", watched)
    run = rodsim.simulate(scene, duration, output_dt=duration, step=step,
                          initial={TENSION: start}, program={TENSION: ramp})
    assert run.success, run.message
    return first


@pytest.mark.parametrize("step", [1e-3, 3e-4])
def test_points_break_loose_at_the_capstan_ratio_of_a_linear_ramp(monkeypatch, step):
    """Every point's breakaway time against t_e = (T_max − T_e)/r (module docstring), T from
    1 mN down to 0.2 mN over 10 ms: measured within 9e-9 of the ramp's duration at 1 ms and
    0.25 ms steps (the rod is not quite rigid); the first point breaks at 2.87 ms, inside a
    step, where finding it at a step's end (before round 16) was up to a step late."""
    nodes, t_max, t_min, duration = 11, 1e-3, 0.2e-3, 0.01
    turns = helix_turns(nodes)
    wrap = np.cumsum(turns)
    edge = t_max * np.exp(-2 * MU_K * wrap - (MU_S - MU_K) * turns)
    closed = (t_max - edge) / ((t_max - t_min) / duration)
    assert np.all(edge > t_min) and np.all(np.diff(closed) > 0)
    scene = Scene.from_dict(helix_scene(nodes, t_max, friction=MU_K, static_friction=MU_S))
    found = _breakaways(monkeypatch, scene, duration, step,
                        Table((0.0, duration), (t_max, t_min)), t_max)
    times = np.array([found.get(e, math.nan) for e in range(len(turns))])
    assert np.max(np.abs(times - closed)) < 1e-7 * duration, (times - closed) / duration
    assert abs(closed[0] / step - round(closed[0] / step)) > 0.05  # inside a step


def _released_tip(static: float, step: float) -> np.ndarray:
    raw = catheter(11, 0.25, 3.0, static_friction=static)
    raw["rods"]["backbone"]["damping"] = {"retardation_time": 6e-3}
    out = rodsim.simulate(Scene.from_dict(raw), 0.03, output_dt=0.03, step=step,
                          initial={TENSION: 3.0}, program={TENSION: Table((0.0, 0.03),
                                                                         (3.0, 2.4))})
    assert out.success, out.message
    return out.positions[-1, -1]


@pytest.mark.slow
def test_a_release_with_stiction_converges_at_the_midpoint_rules_order():
    """The tip after 0.03 s, the step halved from 0.625 ms to 39 µs: successive differences
    4.2e-7, 8.5e-8, 2.5e-8, 5.9e-9 m, orders 2.30, 1.77, 2.08 (from 5 ms: 5.5e-6, 3.5e-6,
    1.3e-6 m before, orders 0.63, 1.49, 1.59 preasymptotic). Before round 16 a step in which
    a point broke loose was re-solved whole with it freed: orders 3.5, −0.6, 3.5 here."""
    tips = [_released_tip(0.5, 0.625e-3 / 2**k) for k in range(5)]
    differences = [float(np.linalg.norm(b - a)) for a, b in zip(tips, tips[1:], strict=False)]
    orders = [math.log2(a / b) for a, b in zip(differences, differences[1:], strict=False)]
    assert min(orders) >= 1.6, (differences, orders)
    assert differences[-1] < 1e-8
