"""Scene validation in one call (issue 21): every door through which the app takes a scene
gives a fully validated one — ``rodsim.load_scene`` (a file, a shipped name, a dict, a Scene)
and an archive's stored scene (``rodsim.io.archive.scene_of``) — with the ``[solver.<name>]``
tables checked by the integrators, which the core's ``Scene.load`` / ``Scene.from_dict`` /
``Scene.from_json`` cannot do (the core does not know the integrators)."""

from __future__ import annotations

import pytest
import xarray as xr

import rodsim
from rodsim.core.scene import Scene, SceneError, scene_paths
from rodsim.io.archive import scene_of

#: A shipped scene with an option no integrator declares.
BAD_TABLE = "\n[solver.static]\nbogus = 1\n"


@pytest.fixture
def bad_file(tmp_path):
    text = scene_paths()["table1-50g"].read_text(encoding="utf-8")
    assert "[solver.static]" not in text
    path = tmp_path / "bad.toml"
    path.write_text(text + BAD_TABLE, encoding="utf-8")
    return path


def test_the_core_alone_leaves_the_solver_tables_to_the_integrators(bad_file):
    """Why the one call is needed: the core's own validation accepts the bogus option."""
    assert Scene.load(bad_file).data["solver"]["static"] == {"bogus": 1}


def test_load_scene_checks_the_solver_tables_from_every_source(bad_file):
    raw = Scene.load(bad_file)
    for source in (bad_file, str(bad_file), raw, raw.data):
        with pytest.raises(SceneError, match="solver.static.bogus"):
            rodsim.load_scene(source)


def test_an_archives_scene_is_validated_as_load_scene_validates(bad_file):
    """An archive whose stored scene carries the bogus option: scene_of refuses it with the
    same error load_scene gives, and accepts the same scene without it."""
    raw = Scene.load(bad_file)
    dataset = xr.Dataset(attrs={"scene_json": raw.to_json(), "scene_toml": raw.source})
    with pytest.raises(SceneError, match="solver.static.bogus") as caught:
        scene_of(dataset)
    with pytest.raises(SceneError) as direct:
        rodsim.load_scene(raw)
    assert str(caught.value) == str(direct.value)
    good = rodsim.load_scene("table1-50g")
    stored = scene_of(xr.Dataset(attrs={"scene_json": good.to_json(),
                                        "scene_toml": good.source}))
    assert stored.to_json() == good.to_json()
