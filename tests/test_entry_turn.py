"""The entry's turn of a string tendon with friction (rodsim/core/tendon_friction.py, "Split
turns"): from t_in on to chord 0, the plain angle ∠(t_in, u_0) or the split path
∠(t_in, t⁺) + ∠(t⁺, u_0) through t⁺ = (3u_0 − u_1)/2 normalised, blended by a C¹ weight
of the kink's size against the extrapolation's step and of its share out of the plane of
t_in and u_0 (``kink_weight``).

It switched between the two on |t_in · (t⁺ × u_0)| ≤ 1e-10 before: where t⁺ overshoots
t_in (a released catheter bends more at node 1 than twice the entry's turn) the split path
is longer than the plain angle by twice the overshoot, and a 1e-9 L step of node 1 or 2 out
of the plane jumped θ_0 by 1.1e-4 rad on the seeded robot below (seed 2). Checked here:
the limits (in one plane the plain angle, whatever the overshoot; a kink out of it split
whole), the weight's continuity and slope, the compiled kernel against the reference in
the blend, and that a robot's θ_0 moves by O(step) under steps of 1e-9 L.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_friction_jacobian import TENSION, robot

import rodsim
from rodsim.core.kernels.tendon_string_path import _entry_turn
from rodsim.core.scene import Scene
from rodsim.core.tendon_friction import (
    KINK_LATERAL,
    KINK_PLAIN,
    KINK_SPLIT,
    kink_weight,
    turning_angles,
)
from rodsim.core.terms.tendon_string import TendonString

AXIS = np.array([0.0, 0.0, 1.0])


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(a @ b))


def _direction(bend: float, lateral: float = 0.0) -> np.ndarray:
    """The unit vector turned by ``bend`` from the axis toward x and ``lateral`` toward y."""
    v = np.array([math.sin(bend), lateral, math.cos(bend)])
    return v / np.linalg.norm(v)


def _entry(first: np.ndarray, second: np.ndarray) -> float:
    """θ_0 of a three-point path (chords u_0 = ``first``, u_1 = ``second``, 1 mm each) from
    t_in = d3 = the z axis, by the numpy reference."""
    p = np.cumsum([np.zeros(3), 1e-3 * first, 1e-3 * second], axis=0)
    return float(turning_angles(AXIS, AXIS, p, np.zeros(3, dtype=bool))[0])


def _ahead(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    ahead = 1.5 * first - 0.5 * second
    return ahead / np.linalg.norm(ahead)


def test_the_weight_is_zero_and_one_at_its_ends_and_c1():
    """w = 0 up to kink/step = KINK_PLAIN and in the entry's plane, 1 from KINK_SPLIT with
    a share out of the plane ≥ KINK_LATERAL; between, monotone, and its slope (central
    differences) tends to 0 at each end of either ramp."""
    step = 1e-2
    assert kink_weight(KINK_PLAIN * step, step, 1.0) == 0.0
    assert kink_weight(KINK_SPLIT * step, step, 1.0) == 1.0
    assert kink_weight(50 * step, step, 0.0) == 0.0  # in the plane: the plain angle
    assert kink_weight(1e-3, 0.0, 1.0) == 1.0  # u_0 = u_1: both turns are the same
    ratios = np.linspace(KINK_PLAIN, KINK_SPLIT, 201)
    shares = np.linspace(0.0, KINK_LATERAL, 201)
    for values, weight in ((ratios, lambda r: kink_weight(r * step, step, 1.0)),
                           (shares, lambda q: kink_weight(step, step, q))):
        w = np.array([weight(v) for v in values])
        assert np.all(np.diff(w) >= 0.0)
        h = 1e-6 * (values[-1] - values[0])
        for end in (values[0], values[-1]):
            assert abs(weight(end + h) - weight(end - h)) / (2 * h) < 1e-4 / (
                values[-1] - values[0])


@pytest.mark.parametrize("side, overshoot", [("behind", 3e-4), ("behind", 5e-4),
                                             ("beyond", 3e-4)])
def test_in_one_plane_the_entry_turn_is_the_plain_angle(side, overshoot):
    """A planar path whose t⁺ lies behind t_in (node 1 turns by more than twice the entry's
    turn) or beyond u_0 (node 1 turns back) by ``overshoot``: θ_0 = ∠(d3, u_0) exactly (so
    Θ_e = ψ_e on a path turning one way in one plane), though the split path is longer by
    twice the overshoot and its kink is above KINK_SPLIT of its step."""
    bend = 0.01
    first = _direction(bend)
    turn = 2 * (bend + overshoot) if side == "behind" else -2 * overshoot
    second = _direction(bend + turn)
    ahead = _ahead(first, second)
    split = _angle(AXIS, ahead) + _angle(ahead, first)
    assert split - _angle(AXIS, first) > 1.9 * overshoot
    assert _angle(AXIS, ahead) > KINK_SPLIT * _angle(ahead, first)
    assert _entry(first, second) == _angle(AXIS, first)


def test_a_kink_out_of_the_plane_is_split_whole():
    """t⁺ 1e-3 rad off the plane of t_in and u_0 and 2e-4 rad behind t_in in it (a kink of
    the path's own: ratio 0.1, share out of the plane 0.98): the split path's length."""
    bend, kink = 0.01, np.array([-2e-4, 1e-3])
    ahead = _direction(kink[0], kink[1])
    # u_1 from t⁺ = (3u_0 − u_1)/2 normalised, with u_0 the entry's bend in the x-z plane
    first = _direction(bend)
    second = 3 * first - 2 * ahead / (ahead @ first)
    second /= np.linalg.norm(second)
    ahead = _ahead(first, second)
    expected = _angle(AXIS, ahead) + _angle(ahead, first)
    assert kink_weight(_angle(AXIS, ahead), _angle(ahead, first), 0.98) == 1.0
    assert abs(_entry(first, second) - expected) < 1e-15
    assert expected - _angle(AXIS, first) > 1e-4


def _geometries(rng: np.random.Generator, count: int):
    """Entry paths whose kink/step ratio spans the blend (0.005–0.03) and whose t⁺ lies off
    the plane by a share 0–0.02 of the kink: (u_0, u_1)."""
    for _ in range(count):
        bend = rng.uniform(2e-3, 2e-2)
        ratio = rng.uniform(0.005, 0.03)
        share = rng.uniform(0.0, 0.02)
        along = -ratio * bend * math.sqrt(1 - share**2) * rng.choice([-1.0, 1.0])
        ahead = _direction(along, ratio * bend * share)
        first = _direction(bend)
        second = 3 * first - 2 * ahead / (ahead @ first)
        yield first, second / np.linalg.norm(second)


def test_the_compiled_entry_turn_is_the_reference():
    """On 400 entry paths spanning the blend (the weight strictly between 0 and 1 on
    many), the kernel's turn (rodsim/core/kernels/tendon_string_path.py) is the numpy
    reference's to 1e-15 rad."""
    blended = 0
    for first, second in _geometries(np.random.default_rng(4), 400):
        plain = _angle(AXIS, first)
        compiled = _entry_turn(AXIS, first, second, plain)
        reference = _entry(first, second)
        assert abs(compiled - reference) < 1e-15, (compiled, reference)
        ahead = _ahead(first, second)
        blended += 1e-14 < compiled - plain < _angle(AXIS, ahead) + _angle(ahead, first) - (
            plain + 1e-14)
    assert blended > 50


def test_the_entry_turn_moves_continuously_as_the_kink_leaves_the_plane():
    """t⁺ 1.5e-4 rad behind t_in in the plane (kink/step 0.015, in the blend) lifted off it
    in 10⁴ steps of 4e-8 rad up to 4e-4: θ_0 goes from the plain angle to the split path's
    length with no step moving it by more than 500 times the lift (measured 126; before, a
    jump of 3e-4 rad, 7500 times the lift, at the first step off the plane)."""
    bend = 0.01
    first = _direction(bend)
    lifts = np.linspace(0.0, 4e-4, 10001)
    theta, split = [], 0.0
    for lift in lifts:
        ahead = _direction(-1.5e-4, lift)
        second = 3 * first - 2 * ahead / (ahead @ first)
        second /= np.linalg.norm(second)
        theta.append(_entry(first, second))
        ahead = _ahead(first, second)
        split = _angle(AXIS, ahead) + _angle(ahead, first)
    theta = np.array(theta)
    assert theta[0] == _angle(AXIS, first)
    assert abs(theta[-1] - split) < 1e-15  # the last: kink/step 0.04, share 0.94
    assert np.max(np.abs(np.diff(theta))) < 500 * 4e-8, np.max(np.abs(np.diff(theta)))


def test_a_released_robots_entry_turn_moves_by_the_order_of_a_step():
    """The seeded nitinol robot of tests/test_friction_jacobian.py (seed 2), pulled and
    released to 97 % (t⁺ 6.3e-5 rad behind t_in): every coordinate moved by ±1e-9 L (or
    1e-9 per quaternion component) moves θ_0 by less than 1e-7 rad (measured 2.0e-8;
    before, 1.3e-4 for the out-of-plane steps of node 2)."""
    data = robot(2)
    tension = data["tendons"]["a"]["tendon_string"]["tension"]
    track = rodsim.track(Scene.from_dict(data), {TENSION: [tension, 0.97 * tension]},
                         estimates=False)
    assert track.success
    model = track.last_model
    term = next(t for t in model.terms if isinstance(t, TendonString))
    x = model.state_of(track.states[-1])
    theta = term.turning_angles(model.full(x))[0]
    steps = 1e-9 * np.where(model.is_quaternion, 1.0, model.length_scale)
    moves = []
    for j, h in enumerate(steps):
        for sign in (1.0, -1.0):
            y = x.copy()
            y[j] += sign * h
            moves.append(abs(term.turning_angles(model.full(y))[0] - theta))
    assert max(moves) < 1e-7, max(moves)
