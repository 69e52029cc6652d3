"""Gravity in any direction (``[rods.<rod>.gravity] direction``; issue 33 item 1): a steel
cantilever (along +x) under its own weight against the closed forms of a uniform load —
the transverse tip deflection w = q L⁴/(8 E I) along the load's transverse part for a
direction tilted out of every axis, the axial stretch ρ g L²/(2 E_s) along the rod — and
against its own −y solution turned about the rod's axis, in statics and in physical time.
The default (0, −1, 0) gives the earlier −y weight bit for bit; a zero direction is
refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from user_robots import KINDS, user_rod

import rodsim
from rodsim.app.cli.main import main
from rodsim.core.model import Model
from rodsim.core.schema import SceneError

STEEL = {"length": 0.4, "radius": 1.2e-3, "youngs_modulus": 207e9, "density": 8000.0,
         "poisson_ratio": 0.3}
AREA = math.pi * STEEL["radius"] ** 2
SECOND_MOMENT = math.pi * STEEL["radius"] ** 4 / 4.0


def cantilever(nodes: int, direction: list[float] | None, gravity: float = 9.81) -> dict:
    """The steel rod clamped at the origin along +x under its own weight."""
    table: dict = {"gravity": gravity}
    if direction is not None:
        table["direction"] = direction
    rod = {**STEEL, "nodes": nodes, "terms": ["stretch", "bend_twist", "centerline",
                                               "gravity"], "gravity": table}
    return {"name": "cantilever", "rods": {"rod": rod}}


def positions(scene: dict) -> np.ndarray:
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    return result.rods["rod"].positions


def turned(points: np.ndarray, angle: float) -> np.ndarray:
    """``points`` turned by ``angle`` about +x, from −y towards +z."""
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def test_the_default_is_the_earlier_weight_bit_for_bit():
    """No direction: each node's force is exactly (0, −m_i g, 0), as before the key."""
    model = Model(rodsim.load_scene(cantilever(11, None)))
    (term,) = [t for t in model.terms if t.name == "gravity"]
    masses = model.rods["rod"].node_masses()
    expected = np.zeros((11, 3))
    expected[:, 1] = -masses * 9.81
    np.testing.assert_array_equal(term.element_forces(np.zeros(0)), expected)
    scene = rodsim.load_scene(cantilever(11, None))
    assert scene.get("gravity.direction") == [0.0, -1.0, 0.0]


@pytest.mark.parametrize("direction", [[0.0, 0.0, 1.0], [0.0, 0.0, -2.0],
                                       [0.0, 0.6, -0.8], [0.0, -3.0, 4.0]])
def test_a_direction_across_the_rod_is_the_minus_y_solution_turned(direction):
    """Gravity across the rod in any direction (normalised): the −y cantilever turned about
    the rod's axis onto it, to round-off (measured 1e-16 m)."""
    reference = positions(cantilever(21, None))
    angle = math.atan2(direction[2], -direction[1])  # from −y towards +z
    np.testing.assert_allclose(positions(cantilever(21, direction)), turned(reference, angle),
                               rtol=0.0, atol=1e-12)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_gravity_along_the_rod_stretches_it_as_the_closed_form(sign):
    """Along ±x the weight stretches (or compresses) the rod: the tip moves by
    ρ g L²/(2 E_s) (measured to 1e-9 relative), the rod stays straight."""
    points = positions(cantilever(21, [sign * 5.0, 0.0, 0.0]))
    expected = sign * STEEL["density"] * 9.81 * STEEL["length"] ** 2 / (
        2.0 * STEEL["youngs_modulus"])
    assert points[-1, 0] - STEEL["length"] == pytest.approx(expected, rel=1e-6)
    assert np.max(np.abs(points[:, 1:])) < 1e-20


def test_uniform_load_cantilever_in_an_arbitrary_direction():
    """Gravity along (0.3, −0.8, 0.5)/|·| at a tenth of Earth's (a small deflection, 8e-5 L,
    in the linear regime): the tip's transverse deflection points along the load's
    transverse part and is q⊥ L⁴/(8 E I), q⊥ = ρ A g |ĝ⊥| (measured +3.6e-4 at N = 41,
    −1.1e-4 at N = 81; at Earth's g the rod's own tension and the geometry move it by
    −2.5e-3)."""
    direction = np.array([0.3, -0.8, 0.5])
    unit = direction / np.linalg.norm(direction)
    g = 0.981
    tip = positions(cantilever(41, list(direction), g))[-1]
    across = np.array([0.0, unit[1], unit[2]])
    load = STEEL["density"] * AREA * g * np.linalg.norm(across)
    expected = load * STEEL["length"] ** 4 / (8.0 * STEEL["youngs_modulus"] * SECOND_MOMENT)
    deflection = np.array([0.0, tip[1], tip[2]])
    assert abs(np.linalg.norm(deflection) / expected - 1.0) < 1e-3
    np.testing.assert_allclose(deflection / np.linalg.norm(deflection),
                               across / np.linalg.norm(across), rtol=0.0, atol=1e-9)


def test_physical_time_falls_along_the_direction():
    """The rod let go from rest under its weight along +z moves as the −y run turned onto
    +z (the same steps, to round-off)."""
    runs = [rodsim.simulate(cantilever(11, direction), 0.02, step=1e-3, output_dt=5e-3)
            for direction in (None, [0.0, 0.0, 1.0])]
    for run in runs:
        assert run.success, run.message
    assert np.max(np.abs(runs[0].positions[-1, :, 1])) > 1e-5  # it does fall
    expected = np.stack([turned(p, 0.5 * math.pi) for p in runs[0].positions])
    np.testing.assert_allclose(runs[1].positions, expected, rtol=0.0, atol=1e-12)


def test_a_zero_direction_is_refused_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SceneError, match="zero vector") as error:
        rodsim.load_scene(cantilever(11, [0.0, 0.0, 0.0]))
    assert "\n" not in str(error.value) and "gravity.direction" in str(error.value)
    with pytest.raises(SceneError, match="direction"):
        rodsim.load_scene(cantilever(11, [0.0, -1.0]))
    code = main(["run", "--set", "terms=[\"stretch\",\"bend_twist\",\"centerline\","
                 "\"gravity\"]", "--set", "gravity.direction=[0,0,0]"])
    captured = capsys.readouterr()
    assert code == 2 and "zero vector" in captured.err
    assert len(captured.err.strip().splitlines()) == 1 and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("seed", range(6))
def test_family_of_user_robots(seed):
    """Seeded robots (steel and nitinol wires, soft polymer catheters that bend far under
    their weight) with gravity across the rod in a random direction and of a random
    strength: the −y equilibrium turned onto it."""
    rng = np.random.default_rng(400 + seed)
    kind = KINDS[seed % 3]
    rod = user_rod(rng, kind, polymer_length=(0.05, 0.2))
    g = float(rng.uniform(1.0, 20.0))
    angle = float(rng.uniform(-math.pi, math.pi))
    scale = float(rng.uniform(0.1, 10.0))
    direction = [0.0, -scale * math.cos(angle), scale * math.sin(angle)]

    def scene(direction: list[float] | None) -> dict:
        table = {**rod, "nodes": 21, "terms": ["stretch", "bend_twist", "centerline",
                                                "gravity"], "gravity": {"gravity": g}}
        if direction is not None:
            table["gravity"]["direction"] = direction
        return {"name": "robot", "rods": {"rod": table}}

    reference = positions(scene(None))
    np.testing.assert_allclose(positions(scene(direction)), turned(reference, angle),
                               rtol=0.0, atol=1e-9 * rod["length"])


@pytest.mark.parametrize("direction", [[0.0, 0.0, 1.0], [0.0, 0.6, -0.8]])
def test_a_hanging_mass_hangs_along_its_direction_with_the_weight(direction):
    """A tip mass given the rod's gravity direction: the −y solution (weight and mass) turned
    about the rod's axis onto it, to round-off; the default stays −y."""
    def loaded(direction: list[float] | None, mass_direction: list[float] | None) -> dict:
        scene = cantilever(21, direction)
        rod = scene["rods"]["rod"]
        rod["terms"] = [*rod["terms"], "tip_load"]
        rod["tip_load"] = {"mass": 0.05} | (
            {"direction": mass_direction} if mass_direction else {})
        return scene

    reference = positions(loaded(None, None))
    angle = math.atan2(direction[2], -direction[1])
    np.testing.assert_allclose(positions(loaded(direction, direction)),
                               turned(reference, angle), rtol=0.0, atol=1e-12)
    with pytest.raises(SceneError, match="tip_load.direction = .*zero vector"):
        rodsim.load_scene(loaded(None, [0.0, 0.0, 0.0]))
