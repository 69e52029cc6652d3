"""The hostile-command harness of ``rodsim bench hostile`` (benchmarks/rodsim_bench/hostile.py):
its outcome rules and the scene files it writes. The tries themselves run in the benchmark
(each its own process, minutes in all), not here."""

from __future__ import annotations

import numpy as np
import pytest

from rodsim.core.scene import Scene
from rodsim.core.scene_file import parse_toml
from rodsim_bench import hostile


@pytest.mark.parametrize(("code", "stderr", "outcome"), [
    (None, "", "hang"),
    (1, "Traceback (most recent call last):\n  File ...\nValueError: x", "traceback"),
    (2, "rodsim: rods.rod.nodes = 1: allowed ...\n", "refused"),
    (2, "rodsim: warning: something\nrodsim: bad value\n", "refused"),
    (2, "rodsim: bad value\nmore detail\n", "multi-line"),
    (1, "rodsim: solver failure: ...\n", "failed"),
    (0, "", "solved"),
    (-11, "", "crash"),
])
def test_outcomes_follow_the_exit_code_and_stderr(code, stderr, outcome):
    assert hostile.classify(code, stderr) == outcome


@pytest.mark.parametrize("surface", hostile.SURFACES)
def test_every_generated_scene_file_is_the_dict_it_was_written_from(surface):
    """Each surface's files are TOML that writes back to the same text (nested tables,
    arrays of tables, numbers kept to the last digit)."""
    for seed in range(3):
        _, arguments, files = surface(np.random.default_rng(seed))
        assert arguments[0] in ("run", "track")
        for text in files.values():
            table = parse_toml(text, "generated")
            assert hostile.toml_text(table) == text


def test_a_written_scene_loads_as_the_scene_of_its_dict():
    scene = {"name": "x", "rods": {"rod": {
        "length": 0.1, "radius": 1e-3, "youngs_modulus": 1e8, "density": 1000.0,
        "nodes": 6, "terms": ["stretch", "bend_twist", "centerline"],
        "sections": [{"start": 0.0, "end": 0.05, "youngs_modulus": 2e8},
                     {"start": 0.05, "end": 0.1, "radius": 2e-3}]}}}
    assert Scene.from_dict(parse_toml(hostile.toml_text(scene), "generated")).data == (
        Scene.from_dict(scene).data)


def test_the_vessel_tries_lay_the_guidewire_through_the_wall(tmp_path):
    """The vessel family (issue 37's guidewire: cvode's folded exit 0) writes a scene that
    loads, whose straight rest shape crosses its vessel's wall: what it claims to try. Its
    csv is the user's vessel90.csv to the printed digits."""
    from pathlib import Path

    from rodsim.core.contact_depth import rest_crossings
    from rodsim.core.model import Model

    user_csv = Path(__file__).parent / "data" / "vessel90.csv"
    written = hostile.vessel_csv().splitlines()[1:]
    assert written == [line for line in user_csv.read_text().splitlines()
                       if line and line[0].isdigit()]
    rng = np.random.default_rng(hostile.VESSEL_SEED)
    integrators = set()
    for _ in range(hostile.VESSEL_TRIES["full"]):
        surface, arguments, files = hostile._vessel_through_rest(rng)
        assert surface == "obstacles through the rest state"
        integrators.add(arguments[arguments.index("--integrator") + 1])
        for name, text in files.items():
            (tmp_path / name).write_text(text)
        scene = Scene.load(tmp_path / "scene.toml")
        assert rest_crossings(Model(scene)), arguments
    assert integrators == {"static", "cvode", "ida"}
