"""Every archive kind (run, study, track, fit, reach) follows CF-1.8 as docs/archive.md
("Conventions and provenance") states it, read with plain netCDF4 (not xarray, which would
hide _FillValue and coordinates in its own model): the global attributes Conventions,
history, source, references, date_created and the library versions; the resolved scene as
one ``scene_json`` attribute and no ``scene.*`` attributes; no _FillValue on coordinate
variables; a ``step`` coordinate where there is a ``step`` dimension; no ragged-array claim;
since schema 3 numeric coordinate variables (text labels beside them), text as characters,
no dots in variable names, and cfchecker's verdict where it is installed. Archives of
schemas 1 and 2 are still read and re-run, and an archive saved back by xarray (which adds a
_FillValue to float coordinates) is accepted: values are what count."""

from __future__ import annotations

import json
import re
from importlib import metadata
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import scipy
import sksundae
import xarray as xr

import rodsim
from rodsim.app.inverse.fit import Points, fit
from rodsim.app.inverse.reach import reach
from rodsim.app.study import Study, Sweep
from rodsim.app.study_runner import run_study
from rodsim.io.archive import ArchiveError, read_dataset, write_dataset
from rodsim.io.provenance import git_commit
from rodsim.io.run_dataset import run_dataset
from rodsim.version import __version__

TIME = r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ"

#: The smallest study with a history (a step dimension) and a reference: 2 static points.
TINY = Study(name="cf_test_tiny", title="CF test", paper="tests only", scene="table1-50g",
             integrator="static", reference="exact", history=True,
             sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (6, 11), "1", "N")]})


def coordinate_variables(nc: netCDF4.Dataset) -> set[str]:
    """CF coordinate variables (one-dimensional, named as their dimension) and auxiliary
    coordinates (named in a variable's ``coordinates`` attribute)."""
    names = {name for name, v in nc.variables.items() if v.dimensions == (name,)}
    for variable in nc.variables.values():
        names.update(getattr(variable, "coordinates", "").split())
    return names


def check_cf(path, command: str) -> netCDF4.Dataset:
    """The checks common to every archive kind; ``command`` is what its history names."""
    nc = netCDF4.Dataset(path)
    attrs = {name: nc.getncattr(name) for name in nc.ncattrs()}
    assert attrs["Conventions"] == "CF-1.8"
    assert attrs["source"] == f"rodsim {__version__}"
    assert "Villard" in attrs["references"]
    assert "Cosserat Rods for Modeling Tendon-Driven Robotic Catheter Systems" in (
        attrs["references"])
    assert re.fullmatch(TIME, attrs["date_created"])
    assert attrs["history"] == f"{attrs['date_created']} rodsim {__version__}: {command}"
    assert attrs["rodsim_version"] == __version__
    assert str(attrs["schema_version"]) == "3"
    assert attrs["numpy_version"] == np.__version__
    assert attrs["scipy_version"] == scipy.__version__
    assert attrs["scikit_sundae_version"] == metadata.version("scikit-sundae")
    assert attrs["sundials_version"] == sksundae.SUNDIALS_VERSION
    commit = git_commit()
    if commit:  # running from a checkout, as the tests do
        assert attrs["git_commit"] == commit
        assert attrs["git_dirty"] in (0, 1)
    json.loads(attrs["scene_json"])
    assert not [name for name in attrs if name.startswith("scene.")]
    coordinates = coordinate_variables(nc)
    assert coordinates
    for name in coordinates:
        assert "_FillValue" not in nc[name].ncattrs(), f"coordinate {name} has a _FillValue"
    # Schema 3 (CF §2.2, §2.3, §5): coordinate variables are numeric, text is stored as
    # characters (cfchecker refuses netCDF strings), names are letters, digits, underscores.
    for name, variable in nc.variables.items():
        assert re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name), name
        assert variable.dtype is not str, f"{name} is a netCDF string, not characters"
        if variable.dimensions == (name,):
            assert np.dtype(variable.dtype).kind in "iuf", f"coordinate {name} is not numeric"
            label = getattr(variable, "label_variable", None)
            if label is not None:
                assert nc[label].dimensions[0] == name and label in coordinates
    if "step" in nc.dimensions:
        step = nc["step"]
        assert step.dimensions == ("step",)
        np.testing.assert_array_equal(step[:], np.arange(nc.dimensions["step"].size))
        assert step.units == "1" and step.long_name
    # The stacked rods are a node dimension labelled by `rod`, not a CF ragged array
    # (docs/archive.md): nothing may claim one.
    assert "featureType" not in attrs
    for variable in nc.variables.values():
        assert "sample_dimension" not in variable.ncattrs()
    assert "rod" in nc.variables
    return nc


def test_run_archive(tmp_path, cli, capsys):
    output = tmp_path / "run.nc"
    argv = ["run", "table1-50g", "--integrator", "static", "--set", "nodes=12", "-o",
            str(output)]
    assert cli(argv) == 0, capsys.readouterr().err
    with check_cf(output, "rodsim " + " ".join(argv)) as nc:
        assert nc["rod"].dimensions[0] == "node"  # characters: (node, string<n>)
        assert set(nc["history_tip"].dimensions) == {"step", "axis"}
        assert nc.getncattr("title").startswith("rodsim run")


def test_run_archive_from_python_names_the_call(tmp_path):
    path = write_dataset(run_dataset(rodsim.solve(rodsim.load_scene("table1-50g",
                                                                    ["nodes=8"]), "static")),
                         tmp_path / "api.nc")
    with check_cf(path, "rodsim.solve(scene 'table1-50g', integrator='static')"):
        pass


def test_study_archive(tmp_path):
    output = tmp_path / "study.nc"
    run_study(TINY, "small", output, workers=1)
    with check_cf(output, "rodsim.app.study.assemble(study 'cf_test_tiny', size 'small')") as nc:
        assert nc.getncattr("study") == "cf_test_tiny"
        assert "step" in nc.dimensions and "history_tip" in nc.variables
        assert {"nodes", "rod", "sigma", "axis", "step", "rod_label", "axis_label"} <= (
            coordinate_variables(nc))


def test_track_archive(tmp_path, cli, capsys):
    output = tmp_path / "track.nc"
    argv = ["track", "table1-50g", "--set", "nodes=8", "--ramp", "tip_load.mass=0:0.05:3",
            "-o", str(output)]
    assert cli(argv) == 0, capsys.readouterr().err
    with check_cf(output, "rodsim " + " ".join(argv)) as nc:
        assert nc.getncattr("kind") == "track"
        assert nc["position"].dimensions == ("step", "node", "axis")


def test_fit_archive(tmp_path):
    scene = rodsim.load_scene("table1-50g", ["nodes=10"])
    truth = rodsim.solve(scene.with_overrides(["youngs_modulus=5e6"]), "static")
    found = fit(scene, Points(truth.positions("catheter")[1:], None), ["youngs_modulus"])
    path = write_dataset(found.to_xarray(), tmp_path / "fit.nc")
    with check_cf(path, "rodsim.fit(scene 'table1-50g', 9 points, parameters "
                        "rods.catheter.youngs_modulus)") as nc:
        assert nc.getncattr("kind") == "fit"


def test_reach_archive(tmp_path):
    scene = rodsim.load_scene("table3-catheter1", ["catheter.nodes=10", "tendon.nodes=6"])
    key = "tendons.tendon.tendon_actuation.force"
    target = rodsim.solve(scene.with_overrides([f"{key}=1.5"]), "static").tip("catheter")
    found = reach(scene, target, [key])
    path = write_dataset(found.to_xarray(), tmp_path / "reach.nc")
    with check_cf(path, f"rodsim.reach(scene 'table3-catheter1', actuate {key})") as nc:
        assert nc.getncattr("kind") == "reach"


def _schema_1(tmp_path):
    """A run archive as rodsim wrote it with schema 1: no provenance attributes, the scene
    also as dotted ``scene.*`` attributes, no step coordinate, _FillValue on coordinates."""
    ds = run_dataset(rodsim.solve(rodsim.load_scene("table1-50g", ["nodes=8"]), "static"))
    ds = ds.drop_vars("step")
    for name in ("Conventions", "history", "source", "references", "date_created",
                 "numpy_version", "scipy_version", "scikit_sundae_version", "sundials_version",
                 "git_commit", "git_dirty"):
        ds.attrs.pop(name, None)
    ds.attrs.update({"schema_version": "1", "scene.rods.catheter.nodes": 8})
    path = tmp_path / "old.nc"
    ds.to_netcdf(path, engine="netcdf4")
    return path


def test_schema_1_archives_are_read_and_re_run(tmp_path, cli, capsys):
    path = _schema_1(tmp_path)
    with netCDF4.Dataset(path) as nc:
        assert "_FillValue" in nc["s"].ncattrs()
    ds = read_dataset(path)
    assert ds.attrs["schema_version"] == "1"
    assert cli(["rerun", str(path)]) == 0, capsys.readouterr().err


@pytest.mark.parametrize(("edit", "message"), [
    (lambda ds: ds.attrs.pop("Conventions"), "Conventions"),
    (lambda ds: ds.attrs.pop("history"), "history"),
    (lambda ds: ds.attrs.pop("sundials_version"), "sundials_version"),
    (lambda ds: ds.attrs.update(date_created="yesterday"), "date_created"),
    (lambda ds: ds.attrs.update(references=""), "references"),
])
def test_schema_2_archives_without_the_attributes_are_refused(tmp_path, edit, message):
    ds = run_dataset(rodsim.solve(rodsim.load_scene("table1-50g", ["nodes=8"]), "static"))
    edit(ds)
    path = write_dataset(ds, tmp_path / "edited.nc")
    with pytest.raises(ArchiveError, match=message):
        read_dataset(path)


@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    """A run, a track, a study, a fit, a reach and a modes archive as rodsim writes them."""
    folder = tmp_path_factory.mktemp("kinds")
    scene = rodsim.load_scene("table1-50g", ["nodes=8"])
    run = write_dataset(run_dataset(rodsim.solve(scene, "static")), folder / "run.nc")
    path = rodsim.track(scene, {"tip_load.mass": [0.0, 0.03, 0.05]})
    track = write_dataset(path.to_xarray(), folder / "track.nc")
    study = folder / "study.nc"
    run_study(TINY, "small", study, workers=1)
    truth = rodsim.solve(scene.with_overrides(["youngs_modulus=5e6"]), "static")
    found = fit(scene, Points(truth.positions("catheter")[1:], None), ["youngs_modulus"])
    fitted = write_dataset(found.to_xarray(), folder / "fit.nc")
    tendon = rodsim.load_scene("table3-catheter1", ["catheter.nodes=10", "tendon.nodes=6"])
    key = "tendons.tendon.tendon_actuation.force"
    target = rodsim.solve(tendon.with_overrides([f"{key}=1.5"]), "static").tip("catheter")
    reached = write_dataset(reach(tendon, target, [key]).to_xarray(), folder / "reach.nc")
    vibration = write_dataset(rodsim.modes(scene, count=3).to_xarray(), folder / "modes.nc")
    return {"run": run, "track": track, "study": study, "fit": fitted, "reach": reached,
            "modes": vibration}


@pytest.mark.parametrize("kind", ["run", "track", "study", "modes"])
def test_an_archive_saved_back_by_xarray_is_re_run_and_plotted(archives, kind, tmp_path, cli,
                                                               capsys):
    """Issue 22: open an archive with xarray and save it with to_netcdf — xarray puts a
    _FillValue on every float coordinate — and rerun and plot refused it. The values are
    what count: the copy reads to the same Dataset, re-runs to 0 difference and plots."""
    copy = tmp_path / f"{kind}.nc"
    with xr.open_dataset(archives[kind]) as ds:
        ds.load().to_netcdf(copy)
    with netCDF4.Dataset(copy) as nc:
        assert any("_FillValue" in nc[name].ncattrs() for name in coordinate_variables(nc))
    original, saved = read_dataset(archives[kind]), read_dataset(copy)
    xr.testing.assert_identical(original, saved)
    assert saved["axis"].values.tolist() == ["x", "y", "z"]  # labels back as coordinates
    assert cli(["rerun", str(copy)]) == 0, capsys.readouterr().err
    assert "difference from the stored" in capsys.readouterr().out
    assert cli(["plot", str(copy), "--format", "png"]) == 0, capsys.readouterr().err
    assert copy.with_suffix(".png").is_file()


def test_schema_2_archives_with_text_coordinates_are_read_and_re_run(tmp_path, cli, capsys):
    """Schema 2 stored axis, component and rod labels as text coordinate variables and the
    track's ramped keys under their dotted names; such archives are still read."""
    scene = rodsim.load_scene("table1-50g", ["nodes=8"])
    ds = rodsim.track(scene, {"tip_load.mass": [0.0, 0.05]}).to_xarray()
    ds = ds.rename({"rods_catheter_tip_load_mass": "rods.catheter.tip_load.mass"})
    ds.attrs["schema_version"] = "2"
    path = write_dataset(ds, tmp_path / "old-track.nc")  # an old schema is written as it is
    with netCDF4.Dataset(path) as nc:
        assert nc["axis"].dtype is str and "rods.catheter.tip_load.mass" in nc.variables
    assert read_dataset(path).attrs["schema_version"] == "2"
    assert cli(["rerun", str(path)]) == 0, capsys.readouterr().err
    assert cli(["plot", str(path), "--format", "png"]) == 0, capsys.readouterr().err


def test_another_schema_is_refused_naming_the_readable_ones(tmp_path):
    ds = run_dataset(rodsim.solve(rodsim.load_scene("table1-50g", ["nodes=8"]), "static"))
    path = write_dataset(ds.assign_attrs(schema_version="4"), tmp_path / "future.nc")
    with pytest.raises(ArchiveError, match="reads schemas 1, 2 and 3"):
        read_dataset(path)


TABLES = Path(__file__).resolve().parent / "data" / "cf-tables"


def _cf_checker():
    """cfchecker's checker with the local (empty) standard name, area type and region
    tables — the archives use no standard names, and the tests never go online — or a
    skip where cfchecker or the udunits2 library it loads is not installed."""
    try:
        from cfchecker.cfchecks import CFChecker
    except (ImportError, OSError) as exc:  # cfunits raises OSError without libudunits2
        pytest.skip(f"cfchecker is not usable here ({exc}): pip install cfchecker and "
                    "apt-get install libudunits2-0")
    return CFChecker(cfStandardNamesXML=str(TABLES / "standard-names.xml"),
                     cfAreaTypesXML=str(TABLES / "area-types.xml"),
                     cfRegionNamesXML=str(TABLES / "region-names.xml"), silent=True)


@pytest.mark.parametrize("kind", ["run", "track", "study", "fit", "reach", "modes"])
def test_cfchecker_finds_no_error_and_no_warning(archives, kind, capsys):
    """cfchecker (CF-1.8) on each archive kind: 0 errors, 0 warnings. It crashed on the
    text coordinate variables of schema 2 and warned about dotted names."""
    checker = _cf_checker()
    results = checker.checker(str(archives[kind]))
    counts = checker.get_counts(results)
    messages = [f"{where}: {message}" for where, found in
                [("global", results["global"]), *results["variables"].items()]
                for category in ("FATAL", "ERROR", "WARN") for message in found[category]]
    assert counts["FATAL"] == counts["ERROR"] == counts["WARN"] == 0, messages
    assert results["variables"], "cfchecker checked no variable"
