"""A study's points share the assembled model of their base scene where only swept values
of terms or solver settings differ (rodsim/app/study.py, point_model): every record equals
the one a freshly built model gives (wall times aside), and a point that changes the layout
gets a model of its own."""

from __future__ import annotations

import pytest

from rodsim.app import study, study_points
from rodsim.app.study import evaluate_point, grid_points, load_study, point_model, point_scene
from rodsim.core.model import Model


def _records(spec) -> tuple[list[dict], int]:
    """Every point's record (wall time removed) and how many base models were assembled."""
    study_points._POINT_MODELS.clear()
    out, assembled = [], {}  # id -> model: held, so that no id is reused
    for index in grid_points(spec):
        record = evaluate_point(spec, index)
        record.get("stats", {}).pop("wall_time", None)
        out.append(record)
        model = study_points._POINT_MODELS[spec.base_scene_json]
        assembled[id(model)] = model
    return out, len(assembled)


@pytest.mark.parametrize("name", ["fig7a", "fig16", "fig8"])
def test_shared_models_give_the_records_of_fresh_ones(name, monkeypatch):
    spec = load_study(name).spec("small")
    shared, assembled = _records(spec)
    assert assembled == 1 < len(grid_points(spec))  # one assembly for the whole grid
    monkeypatch.setattr(Model, "with_values", lambda self, scene, fallback=True: None)
    fresh, assembled = _records(spec)
    assert assembled == len(grid_points(spec))
    assert shared == fresh
    assert all(r["status"] == study.STATUS["ok"] for r in shared)


def test_a_point_with_another_layout_gets_its_own_model():
    spec = load_study("fig7b").spec("small")
    study_points._POINT_MODELS.clear()
    first, second = (point_model(spec, point_scene(spec, index))
                     for index in grid_points(spec)[:2])
    assert first.n != second.n
