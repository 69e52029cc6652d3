"""A string tendon under displacement control (rodsim/core/terms/tendon_string_displacement.py):
an elastic string pulled in by d. Checked against the tension-controlled string (a separate
term and kernel: chords as elements, no global coupling) at the tension the pulled one ends
with, across the integrators, and for slack; bad input is one line."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

import rodsim
from rodsim.app.cli import main
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.io.archive import read_dataset

LENGTH = 0.4  # m, tdcr-two-segment's backbone
PULL = {"control": "displacement", "displacement": 0.004, "stiffness": 6e3}


def pulled(values: dict | None = None, nodes: int | None = None) -> Scene:
    data = copy.deepcopy(rodsim.load_scene("tdcr-two-segment").data)
    data["tendons"]["s1a"]["tendon_string"].update(values if values is not None else PULL)
    if nodes is not None:
        data["rods"]["backbone"]["nodes"] = nodes
    return Scene.from_dict(data)


def tension_and_lengths(scene: Scene, state: np.ndarray) -> tuple[float, float, float]:
    model = rodsim.build_model(scene)
    term = next(t for t in model.terms if t.name == "tendon_string_displacement")
    full = model.full(state)
    return term.tension(full), term.path_length(full), term.free_length


def test_a_pulled_tendon_is_the_string_at_the_tension_it_ends_with():
    """The equilibrium of the pulled tendon is the tension-controlled string's at the
    tension T = (E A / ℓ*)(ℓ − ℓ*) it ends with, to the solvers' tolerance; the tendon
    is stretched by T ℓ* / (E A) and the robot bends."""
    scene = pulled()
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    tension, length, free = tension_and_lengths(scene, result.state)
    assert 0.5 < tension < 20.0
    assert length - free == pytest.approx(tension * free / PULL["stiffness"], rel=1e-12)
    data = copy.deepcopy(rodsim.load_scene("tdcr-two-segment").data)
    data["tendons"]["s1a"]["tendon_string"]["tension"] = tension
    controlled = rodsim.solve(Scene.from_dict(data), "static")
    assert controlled.success, controlled.message
    gap = np.abs(result.rods["backbone"].positions - controlled.rods["backbone"].positions)
    print(f"\npulled 4 mm: T = {tension:.6g} N, largest difference {gap.max():.2e} m")
    assert gap.max() < 1e-9 * LENGTH
    assert abs(result.rods["backbone"].positions[-1, 1]) > 0.05 * LENGTH


@pytest.mark.parametrize("integrator", ["cvode", "ida", "paper"])
def test_every_integrator_finds_the_same_pulled_equilibrium(integrator):
    scene = pulled()
    reference = rodsim.solve(scene, "static")
    result = rodsim.solve(scene, integrator)
    assert result.success, result.message
    gap = np.abs(result.rods["backbone"].positions - reference.rods["backbone"].positions)
    assert gap.max() < 1e-6 * LENGTH


def test_a_stiffer_tendon_converges_to_the_inextensible_one():
    """Ten times E A: the stretch ℓ − ℓ* falls about tenfold while the tension settles (the
    inextensible tendon's)."""
    tensions, stretches = [], []
    for stiffness in (6e3, 6e4, 6e5):
        scene = pulled({**PULL, "stiffness": stiffness})
        result = rodsim.solve(scene, "static")
        assert result.success, result.message
        tension, length, free = tension_and_lengths(scene, result.state)
        tensions.append(tension)
        stretches.append(length - free)
    print(f"\ntensions {tensions}, stretches {stretches}")
    assert 8.0 < stretches[0] / stretches[1] < 12.0 and 9.0 < stretches[1] / stretches[2] < 11.0
    assert abs(tensions[2] - tensions[1]) < 0.2 * abs(tensions[1] - tensions[0])


def test_a_tendon_let_out_is_slack():
    """Let out by 3 cm the tendon is slack (T = 0): the robot takes the shape it has with
    that tendon's tension at 0. (Let out by 2 mm it is not: the other tendons bend the
    robot so that its path lengthens by more — T = 0.96 N.)"""
    scene = pulled({**PULL, "displacement": -0.03})
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    tension, _, _ = tension_and_lengths(scene, result.state)
    assert tension == 0.0
    data = copy.deepcopy(rodsim.load_scene("tdcr-two-segment").data)
    data["tendons"]["s1a"]["tendon_string"]["tension"] = 0.0
    free = rodsim.solve(Scene.from_dict(data), "static")
    gap = np.abs(result.rods["backbone"].positions - free.rods["backbone"].positions)
    assert gap.max() < 1e-9 * LENGTH


@pytest.mark.parametrize(("values", "nodes", "message"), [
    ({"control": "displacement", "displacement": 0.004}, None,
     r"^tendons\.s1a\.tendon_string\.stiffness = 0\.0: control = 'displacement' needs"),
    ({"displacement": 0.004}, None,
     r"^tendons\.s1a\.tendon_string\.displacement = 0\.004: read only with control"),
    ({**PULL, "displacement": 0.25}, None,
     r"^tendons\.s1a\.tendon_string\.displacement = 0\.25: not shorter than the tendon's "
     r"rest path"),
    (PULL, 701, r"^tendons\.s1a\.tendon_string\.control = 'displacement': the tendon spans "
                r"351 nodes"),
])
def test_bad_displacement_input_is_one_line(values, nodes, message):
    with pytest.raises(SceneError, match=message) as error:
        rodsim.build_model(pulled(values, nodes))
    assert "\n" not in str(error.value)


def test_the_tension_is_reported_in_the_summary_and_the_archive(capsys, tmp_path):
    """The tension a pulled tendon ends with is an outcome: the result, the run summary and
    the archive (attribute tendon_tension) carry it; tension-controlled tendons are not
    listed (their tension is an input)."""
    result = rodsim.solve(pulled(), "static")
    tension, _, _ = tension_and_lengths(pulled(), result.state)
    assert result.tendon_tension == {"s1a": tension}
    output = tmp_path / "run.nc"
    code = main(["run", "tdcr-two-segment", "--integrator", "static", "-o", str(output),
                 *(f"--set=tendons.s1a.tendon_string.{key}={value}"
                   for key, value in PULL.items())])
    out = capsys.readouterr().out
    assert code == 0
    assert f"tension     s1a {tension:.6g} N (displacement control)" in out
    stored = json.loads(read_dataset(output).attrs["tendon_tension"])
    assert stored == pytest.approx({"s1a": tension}, rel=1e-9)


def test_bad_displacement_input_exits_2_on_the_cli(capsys, tmp_path):
    code = main(["run", "tdcr-two-segment", "--set",
                 "tendons.s1a.tendon_string.control=displacement",
                 "--set", "tendons.s1a.tendon_string.displacement=0.004",
                 "-o", str(tmp_path / "run.nc")])
    err = capsys.readouterr().err
    assert code == 2
    assert "stiffness" in err and err.count("\n") == 1
