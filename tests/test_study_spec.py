"""The study spec is a frozen dataclass (rodsim.app.study.StudySpec) whose JSON is byte for
byte what study archives and parts folders have always stored (``spec_json``, the parts
folder's spec.json): archives written before it, such as the committed
benchmarks/results/stress-full.nc (schema 1), still load, re-run and resume."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
import xarray as xr

from rodsim.app.api import load_scene
from rodsim.app.study import (
    StudyError,
    StudySpec,
    SweepSpec,
    available_studies,
    grid_points,
    grid_shape,
    point_scene,
)
from rodsim.app.study_parts import spec_differences

REPO = Path(__file__).resolve().parents[1]
OLD_ARCHIVE = REPO / "benchmarks" / "results" / "stress-full.nc"


def legacy_spec(study, size: str) -> dict:
    """The spec dict as rodsim built it before StudySpec (Study.spec returned this dict and
    archives stored ``json.dumps(spec, sort_keys=True)``)."""
    scene = load_scene(study.scene, study.overrides)
    return {
        "name": study.name, "title": study.title, "paper": study.paper, "size": size,
        "integrator": study.integrator, "reference": study.reference, "plot": study.plot,
        "history": study.history, "sigma_points": study.sigma_points,
        "base_scene_json": scene.to_json(), "base_scene_toml": scene.source,
        "sweeps": [dataclasses.asdict(s) | {
            "key": s.key if isinstance(s.key, str) else list(s.key),
            "values": [v if not isinstance(v, tuple) else list(v) for v in s.values],
            "labels": None if s.labels is None else list(s.labels)}
            for s in study.sweeps[size]],
    }


@pytest.mark.parametrize("name", sorted(available_studies()))
def test_spec_json_is_byte_for_byte_the_legacy_dicts(name):
    study = available_studies()[name]
    for size in ("small", "full"):
        spec = study.spec(size)
        legacy = legacy_spec(study, size)
        assert spec.to_json() == json.dumps(legacy, sort_keys=True)
        assert StudySpec.from_json(spec.to_json()) == spec
        assert spec_differences(json.loads(json.dumps(legacy)), spec.to_dict()) == []


def test_a_committed_old_archive_spec_still_loads():
    """stress-full.nc was written by an earlier rodsim (schema 1) from a dict spec."""
    with xr.open_dataset(OLD_ARCHIVE) as ds:
        text = ds.attrs["spec_json"]
        sizes = {s["name"]: ds.sizes[s["name"]] for s in json.loads(text)["sweeps"]}
    spec = StudySpec.from_json(text)
    assert spec.to_json() == text  # byte-compatible both ways
    assert spec.name == "stress" and spec.size == "full"
    assert all(isinstance(s, SweepSpec) for s in spec.sweeps)
    assert grid_shape(spec) == tuple(sizes[s.name] for s in spec.sweeps)
    first = grid_points(spec)[0]
    scene = point_scene(spec, first)
    assert scene.name == spec.base_scene().name
    assert spec.rod_names == list(json.loads(spec.base_scene_json)["rods"])


def test_a_spec_without_the_scene_text_loads():
    spec = available_studies()["fig6"].spec("small")
    data = spec.to_dict()
    del data["base_scene_toml"]
    loaded = StudySpec.from_dict(data)
    assert loaded.base_scene_toml == ""
    assert point_scene(loaded, grid_points(loaded)[0]).data == point_scene(
        spec, grid_points(spec)[0]).data


@pytest.mark.parametrize("text", ["[]", "{", '{"name": "x"}', '{"sweeps": 3}'])
def test_what_is_not_a_spec_is_a_study_error(text):
    with pytest.raises(StudyError):
        StudySpec.from_json(text)


def test_the_spec_is_frozen():
    spec = available_studies()["fig6"].spec("small")
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.size = "full"  # type: ignore[misc]
