"""A static friction coefficient along the arc length (``tendon_string.static_friction_profile``
at ``friction_profile_s``; issue 34) against the closed form of the stick/slip law
(docs/tendon.md, "Stiction" and "Stiction along the arc length").

Rigid helix (tests/test_tendon_stiction.py: turns θ_j from the helix's geometry alone),
pulled in from slack to T_max (every point sliding in, chord e at T_max e^{−W_e},
W_e = Σ_{j≤e} μ̄_j θ_j) and released in one step to T_1. Point e has to break loose
outward; the points before it that did slide at μ_k, so it slides out iff

    T_1 e^{W_{e−1} + μ̄_s,e θ_e} < T_max e^{−W_e}  ⟺  T_1 < T_max e^{−2W_e − Δ_e θ_e},

Δ_e = μ̄_s,e − μ̄_e its static excess, while that edge falls along e (then the slipped points
are a prefix). μ̄ and μ̄_s are the means of the piecewise-linear profiles over the point's
cell between its chords' midpoints (μ(s_0), μ_s(s_0) at the entry), integrated here by
quadrature. The termination holds (the backlash dead zone) down to
T_max e^{−2W_last − Δ_last θ_last}; as N grows the static part Δ_last θ_last = O(h)
vanishes and the edge tends to the continuum's T_max e^{−2W(L)},
W(L) = μ(0) α + (a φ′²/c) ∫_0^L μ ds, at first order.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from test_tendon_stiction import (
    HELIX_PITCH,
    HELIX_RADIUS,
    ROD_LENGTH,
    TENSION,
    helix_scene,
    helix_turns,
    string_term,
)

import rodsim
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError

T_MAX = 1e-3
#: μ_k(s) and μ_s(s) at the same knots; the knot at 0.0437 m lies inside a point's cell at
#: every N below (not on a node or a midpoint), where the static excess turns.
KNOTS = [0.0, 0.0437, 0.1]
KINETIC = [0.1, 0.3, 0.2]
STATIC = [0.15, 0.4, 0.9]


def _mean(values: list[float], a: float, b: float) -> float:
    """The mean of the piecewise-linear profile through (KNOTS, values) over [a, b]."""
    mu = lambda u: float(np.interp(u, KNOTS, values))  # noqa: E731
    inside = [k for k in KNOTS if a < k < b]
    return quad(mu, a, b, points=inside or None, epsabs=1e-15, epsrel=1e-13)[0] / (b - a)


def _cell_means(values: list[float], nodes: int) -> np.ndarray:
    """The profile's value at the entry, then its mean over each interior point's cell."""
    s = np.linspace(0.0, ROD_LENGTH, nodes)
    middles = 0.5 * (s[1:] + s[:-1])
    return np.array([values[0]] + [_mean(values, a, b) for a, b in
                                   zip(middles[:-1], middles[1:], strict=True)])


def edges(nodes: int) -> np.ndarray:
    """T_max e^{−2W_e − Δ_e θ_e} of every point e (module docstring)."""
    turns = helix_turns(nodes)
    kinetic, static = _cell_means(KINETIC, nodes), _cell_means(STATIC, nodes)
    wrap = np.cumsum(kinetic * turns)
    return T_MAX * np.exp(-2 * wrap - (static - kinetic) * turns)


def _scene(nodes: int, tension: float) -> Scene:
    return Scene.from_dict(helix_scene(nodes, tension, friction_profile=KINETIC,
                                       friction_profile_s=KNOTS,
                                       static_friction_profile=STATIC))


@pytest.mark.parametrize("nodes", [11, 21, 41])
def test_released_points_break_loose_at_their_own_static_edge(nodes):
    """Released in one step to 0.2 % either side of the edge of a point mid-way and of the
    last one (the dead zone's): every point's state is the closed form's (+1 where
    T_1 < its edge, else 0), the released chords at T_1 e^{W_e} and the held ones at their
    pulled tensions."""
    limit = edges(nodes)
    assert np.all(np.diff(limit) < 0.0)  # the slipped points are a prefix
    turns = helix_turns(nodes)
    wrap = np.cumsum(_cell_means(KINETIC, nodes) * turns)
    for point in (len(limit) // 2, len(limit) - 1):
        for factor in (1.002, 0.998):
            t_1 = limit[point] * factor
            assert np.all(np.abs(t_1 / np.delete(limit, point) - 1.0) > 1e-3)
            track = rodsim.track(_scene(nodes, T_MAX), {TENSION: [T_MAX, t_1]},
                                 estimates=False)
            assert track.success, track.message
            slid = t_1 < limit
            np.testing.assert_array_equal(track.slip[-1], np.where(slid, 1, 0))
            closed = np.where(slid, t_1 * np.exp(wrap), T_MAX * np.exp(-wrap))
            assert np.max(np.abs(track.tension[-1] - closed)) < 1e-7 * T_MAX


def test_the_dead_zone_edge_tends_to_the_continuum_one_at_first_order():
    """The termination's edge T_max e^{−2W_last − Δ_last θ_last} (solved within 0.2 % at
    N = 11, 21, 41 above) against the continuum's T_max e^{−2W(L)}: the static profile's
    part Δ_last θ_last is 0.121, 0.073, 0.039, 0.020, 0.010 at N = 11 … 161 (order 1: the
    point's turn is κ h), the kinetic part 2 (W(L) − W_last) 0.156, 0.052, 0.019, 0.0077,
    0.0034 (the half chord past the last point, order 1, and the polygon's O(h²)); their
    difference, the ln of the edges' ratio, −0.021, −0.020, −0.012, −0.0067 from N = 21.
    So a μ_s along a lumen widens the dead zone by a factor e^{O(h)}: stiction on a
    continuous lumen tends to the kinetic model (docs/tendon.md, "Stiction")."""
    rate = 2 * math.pi / HELIX_PITCH
    a = HELIX_RADIUS
    curvature = a * rate**2 / math.sqrt(1 + (a * rate) ** 2)
    continuum = KINETIC[0] * math.atan(a * rate) + curvature * _mean(KINETIC, 0.0,
                                                                      ROD_LENGTH) * ROD_LENGTH
    gaps, statics = [], []
    for nodes in (11, 21, 41, 81, 161):
        gaps.append(math.log(edges(nodes)[-1] / (T_MAX * math.exp(-2 * continuum))))
        turns = helix_turns(nodes)
        statics.append(float((_cell_means(STATIC, nodes) - _cell_means(KINETIC, nodes))[-1]
                             * turns[-1]))
    orders = np.log2(np.asarray(statics[:-1]) / np.asarray(statics[1:]))
    assert np.all((orders > 0.7) & (orders < 1.1)), (statics, orders)
    assert orders[-1] > 0.95
    assert np.all(np.diff(np.abs(gaps[1:])) < 0.0) and abs(gaps[-1]) < 0.01, gaps


def test_the_points_take_the_static_profile_s_cell_means():
    """The term's μ_s per point is the quadrature's cell mean of μ_s(s) (the kinetic
    profile's mapping), and equal profiles give the kinetic model: no stick/slip state."""
    nodes = 21
    term = string_term(Model(_scene(nodes, T_MAX)))
    np.testing.assert_allclose(term.static, _cell_means(STATIC, nodes), rtol=1e-12)
    np.testing.assert_allclose(term.kinetic, _cell_means(KINETIC, nodes), rtol=1e-12)
    assert term.sticky
    same = helix_scene(nodes, T_MAX, friction_profile=KINETIC, friction_profile_s=KNOTS,
                       static_friction_profile=KINETIC)
    assert not string_term(Model(Scene.from_dict(same))).sticky


@pytest.mark.parametrize("values, message", [
    ({"static_friction_profile": [0.4, 0.25, 0.9]},
     r"static_friction_profile\[1\] = 0.25: smaller than friction_profile\[1\] = 0.3 at "
     "friction_profile_s = 0.0437"),
    ({"static_friction_profile": [0.4, 0.9]}, "has 2 values and friction_profile 3"),
    ({"static_friction_profile": STATIC, "static_friction": 0.9}, "both set"),
    ({"static_friction_profile": [0.4, 0.5, -0.1]}, "out of range"),
])
def test_bad_static_profiles_are_one_line(values, message):
    data = helix_scene(11, T_MAX, friction_profile=KINETIC, friction_profile_s=KNOTS)
    data["tendons"]["a"]["tendon_string"] |= values
    with pytest.raises(SceneError, match=message) as info:
        Model(Scene.from_dict(data))
    assert "\n" not in str(info.value)


def test_a_static_profile_needs_a_kinetic_one():
    data = helix_scene(11, T_MAX, friction=0.2, friction_profile_s=KNOTS,
                       static_friction_profile=STATIC)
    with pytest.raises(SceneError, match="without friction_profile") as info:
        Model(Scene.from_dict(data))
    assert "\n" not in str(info.value)
