"""netCDF archives: lossless round trip, self-description, re-running, atomic writes."""

from __future__ import annotations

import dataclasses
import functools
import json

import numpy as np
import pytest
import xarray as xr

import rodsim
from rodsim.app.api import rerun
from rodsim.core.scene import scene_paths
from rodsim.io.archive import ArchiveError, read_dataset, write_dataset
from rodsim.io.archive_schema import SCHEMA_VERSION
from rodsim.io.run_dataset import run_dataset
from rodsim.solvers import registered_integrators

OVERRIDES = ("nodes=12",)
REQUIRED_ATTRS = ("scene_json", "scene_toml", "integrator", "integrator_options",
                  "stats_steps", "stats_force_evals", "stats_jacobian_evals",
                  "stats_newton_iters", "stats_wall_time", "residual", "rodsim_version",
                  "schema_version")


@functools.cache
def run(integrator: str) -> rodsim.solvers.result.Result:
    result = rodsim.solve("table1-50g", integrator, overrides=list(OVERRIDES))
    assert result.success, result.message
    return result


@pytest.mark.parametrize("integrator", ["static", "cvode"])
def test_round_trip_is_identical(integrator, tmp_path):
    dataset = run_dataset(run(integrator))
    path = write_dataset(dataset, tmp_path / "run.nc")
    assert path == tmp_path / "run.nc"
    back = read_dataset(path)
    xr.testing.assert_identical(dataset, back)


@pytest.mark.parametrize("integrator", ["static", "cvode"])
def test_archive_is_self_describing(integrator):
    result = run(integrator)
    dataset = run_dataset(result)
    assert {"position", "quaternion"} <= set(dataset.data_vars)
    for name, variable in dataset.data_vars.items():
        assert variable.attrs.get("units"), f"{name} has no units"
        assert variable.attrs.get("long_name"), f"{name} has no long_name"
    for name, coordinate in dataset.coords.items():
        assert coordinate.attrs.get("long_name"), f"coordinate {name} has no long_name"
        if np.issubdtype(coordinate.dtype, np.number):
            assert coordinate.attrs.get("units"), f"coordinate {name} has no units"
    assert dataset["position"].attrs["units"] == "m"
    missing = [key for key in REQUIRED_ATTRS if key not in dataset.attrs]
    assert not missing, f"missing attributes: {missing}"

    attrs = dataset.attrs
    assert json.loads(attrs["scene_json"]) == result.scene.data
    assert json.loads(attrs["scene_json"])["rods"]["catheter"]["nodes"] == 12
    assert attrs["scene_toml"] == scene_paths()["table1-50g"].read_text(encoding="utf-8")
    assert attrs["integrator"] == integrator
    assert json.loads(attrs["integrator_options"]) == (
        dataclasses.asdict(registered_integrators()[integrator].options_of(result.scene)))
    assert attrs["rodsim_version"] == rodsim.__version__
    assert str(attrs["schema_version"]) == SCHEMA_VERSION
    assert attrs["residual"] == result.residual
    assert attrs["residual"] < attrs["stats_effective_tolerance"]
    for key in ("steps", "force_evals", "jacobian_evals", "newton_iters", "wall_time"):
        np.testing.assert_equal(attrs[f"stats_{key}"], result.stats[key])  # NaN: not counted
    assert attrs["stats_force_evals"] > 0 and attrs["stats_wall_time"] > 0
    assert attrs["stats_steps"] > 0
    # The stored shape is the result's.
    np.testing.assert_array_equal(dataset["position"].values, result.positions())
    assert dataset.sizes["node"] == 12 and dataset.sizes["segment"] == 11


@pytest.mark.parametrize("integrator", ["static", "cvode"])
def test_rerun_reproduces_the_stored_positions(integrator, tmp_path):
    path = write_dataset(run_dataset(run(integrator)), tmp_path / "run.nc")
    stored = read_dataset(path)
    again, difference = rerun(stored)
    assert again.success, again.message
    assert again.integrator == integrator
    assert again.scene.data == run(integrator).scene.data
    independent = float(np.max(np.linalg.norm(again.positions() - stored["position"].values,
                                              axis=1)))
    assert independent < 1e-12
    assert difference == pytest.approx(independent, abs=1e-15)


def test_failed_write_leaves_the_previous_archive_and_no_temporary(tmp_path, monkeypatch):
    path = tmp_path / "run.nc"
    write_dataset(run_dataset(run("static")), path)
    before = path.read_bytes()

    def broken_to_netcdf(self, target, *args, **kwargs):
        with open(target, "wb") as handle:
            handle.write(b"CDF\x01 partial")  # half a file, then the disk "fails"
        raise OSError("simulated failure in the middle of the write")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", broken_to_netcdf)
    with pytest.raises(ArchiveError, match="simulated failure"):
        write_dataset(run_dataset(run("cvode")), path)
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.nc"]
    stored, again = read_dataset(path), run_dataset(run("static"))
    for created in ("date_created", "history"):  # when each was built: not the same second
        assert stored.attrs.pop(created) and again.attrs.pop(created)
    xr.testing.assert_identical(stored, again)


def test_write_to_a_missing_folder_raises(tmp_path):
    with pytest.raises(ArchiveError, match="does not exist"):
        write_dataset(run_dataset(run("static")), tmp_path / "no" / "such" / "run.nc")
    assert list(tmp_path.iterdir()) == []


def test_reading_a_foreign_netcdf_raises(tmp_path):
    path = tmp_path / "foreign.nc"
    xr.Dataset({"temperature": ("time", np.arange(3.0))}).to_netcdf(path, engine="netcdf4")
    with pytest.raises(ArchiveError, match="not a rodsim archive"):
        read_dataset(path)


def test_reading_a_non_netcdf_or_missing_file_raises(tmp_path):
    garbage = tmp_path / "garbage.nc"
    garbage.write_text("this is not netCDF")
    with pytest.raises(ArchiveError):
        read_dataset(garbage)
    with pytest.raises(ArchiveError):
        read_dataset(tmp_path / "missing.nc")


def test_reading_another_schema_version_raises(tmp_path):
    dataset = run_dataset(run("static"))
    dataset.attrs["schema_version"] = "999"
    path = write_dataset(dataset, tmp_path / "future.nc")
    with pytest.raises(ArchiveError, match="schema"):
        read_dataset(path)


@pytest.mark.parametrize("name", sorted(registered_integrators()))
def test_the_history_time_is_labelled_as_its_integrator_declares(name):
    """The run archive labels the history's time with the integrator's own
    ``history_time`` (static: load fraction, units 1; the others: pseudo-time [s]), not by
    its name: a new integrator needs no edit here."""
    from rodsim.io.run_dataset import run_dataset
    from rodsim.solvers import integrator_named

    scene = rodsim.load_scene("table1-20g").with_overrides(["nodes=8"])
    ds = run_dataset(rodsim.solve(scene, name))
    units, meaning = integrator_named(name).history_time
    assert dict(ds["history_time"].attrs) == {"units": units, "long_name": meaning}
