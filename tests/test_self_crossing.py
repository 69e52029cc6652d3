"""A state whose rod passes through itself is flagged (rodsim/core/self_crossing.py): rodsim
has no self-contact, and CVODE returned a 3 mm rod folded with two nodes 0.1 mm apart as an
equilibrium (issue 37, item 3f). Checked on hand-made shapes and on the closed-form coil of
a rod under a tip moment M: a circle of radius E I / M, which passes through itself past
one turn."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rodsim
from rodsim.app.contact_report import contact_warnings
from rodsim.core.scene import Scene
from rodsim.core.self_crossing import _segment_distances, self_crossing
from rodsim.io.run_dataset import run_content

E, R, L = 3e7, 0.0015, 0.1


def test_segment_distance_is_the_brute_force_minimum():
    rng = np.random.default_rng(7)
    a0, a1, b0, b1 = (rng.normal(size=(100, 3)) for _ in range(4))
    exact = _segment_distances(a0, a1, b0, b1)
    t = np.linspace(0.0, 1.0, 401)
    for k in range(100):
        pa = a0[k] + t[:, None] * (a1[k] - a0[k])
        pb = b0[k] + t[:, None] * (b1[k] - b0[k])
        brute = np.min(np.linalg.norm(pa[:, None] - pb[None], axis=2))
        assert exact[k] <= brute + 1e-12 and brute - exact[k] < 2e-3  # grid: 5e-3 apart


def hairpin(gap: float, bend: float = 0.0) -> np.ndarray:
    """Two straight 20 mm legs ``gap`` apart joined by a half circle (radius gap/2), 0.5 mm
    segments; ``bend`` lifts the second leg's far end out of the plane."""
    radius = gap / 2
    leg = np.arange(0.0, 0.02, 5e-4)
    first = np.stack([leg[::-1], np.zeros_like(leg), np.zeros_like(leg)], axis=1)
    angle = np.linspace(-math.pi / 2, math.pi / 2, max(int(math.pi * radius / 5e-4), 3))
    turn = np.stack([-radius * np.cos(angle), radius + radius * np.sin(angle),
                     np.zeros_like(angle)], axis=1)
    second = np.stack([leg, np.full_like(leg, gap), bend * leg / 0.02], axis=1)
    return np.concatenate([first, turn[1:-1], second])


@pytest.mark.parametrize(("gap", "flagged"), [(1e-4, True), (0.5 * R, True), (2.4 * R, False),
                                              (4 * R, False)])
def test_a_hairpin_is_flagged_only_when_its_legs_overlap(gap, flagged):
    """Legs 0.1 mm apart (the issue's fold) and half a radius apart pass through each other;
    a U-turn of bend radius 1.2 r (legs 2.4 r apart) is a shape a solid rod can take."""
    found = self_crossing(hairpin(gap), R)
    assert (found is not None) == flagged
    if flagged:
        assert found.distance == pytest.approx(gap, rel=1e-6)


def test_a_straight_or_gently_bent_rod_is_not_flagged():
    s = np.linspace(0.0, L, 201)
    assert self_crossing(np.stack([s, 0 * s, 0 * s], axis=1), R) is None
    angle = s / 0.05  # 2 rad over the rod
    arc = np.stack([0.05 * np.sin(angle), 0.05 * (1 - np.cos(angle)), 0 * s], axis=1)
    assert self_crossing(arc, R) is None


def coil(turns: float):
    bending = E * math.pi * R**4 / 4
    moment = bending * 2 * math.pi * turns / L
    scene = Scene.from_dict({"name": "coil", "rods": {"c": {
        "length": L, "radius": R, "youngs_modulus": E, "stretch_modulus": E, "density": 1100.0,
        "nodes": 61, "clamp": "frame", "terms": ["stretch", "bend_twist", "centerline",
                                                 "point_loads"],
        "point_loads": {"loads": [{"s": L, "moment": [0.0, moment, 0.0], "frame": "body"}]}}}})
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    return result


@pytest.mark.parametrize(("turns", "flagged"), [(0.9, False), (1.2, True), (1.5, True)])
def test_a_coil_past_one_turn_is_flagged_in_the_summary_and_the_archive(turns, flagged):
    result = coil(turns)
    positions = result.rods["c"].positions
    if flagged:  # the closed form: the node one circumference L / turns on is on the circle
        lap = round(60 / turns)
        assert np.linalg.norm(positions[lap] - positions[0]) < 0.25 * R  # 0.15-0.18 R, N = 61
    warnings = [line for line in contact_warnings(result) if "passes through itself" in line]
    attrs = run_content(result).attrs
    assert bool(warnings) == flagged
    assert ("self_crossing" in attrs) == flagged
    if flagged:
        assert "rod 'c' passes through itself" in attrs["self_crossing"]


@pytest.mark.parametrize("seed", range(40))
def test_the_screen_gives_the_k_d_trees_answer(seed, monkeypatch):
    """Random walks, some folded onto themselves: the screened check (rods up to
    SCREEN_SEGMENTS segments) returns exactly what the k-d tree alone returns."""
    from rodsim.core import self_crossing as module

    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 120))
    steps = rng.normal(size=(n - 1, 3))
    steps[: n // 2] *= 1.0 if seed % 2 else 0.2  # tight coils come back near themselves
    points = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
    radius = float(rng.uniform(0.05, 0.8))
    screened = module.self_crossing(points, radius)
    monkeypatch.setattr(module, "SCREEN_SEGMENTS", 0)
    assert screened == module.self_crossing(points, radius)
