"""The netCDF4 writer without xarray (rodsim/io/netcdf_writer.py) writes the file xarray's
``to_netcdf`` writes: checked against xarray itself, for run archives of shipped scenes (one
rod with a history, two rods, a scene with obstacles) and for a content holding every kind
of value an archive may hold."""

from __future__ import annotations

import math
import subprocess
import sys

import netCDF4
import numpy as np
import pytest
import xarray as xr

import rodsim
from rodsim.io.archive import read_dataset, write_content, write_dataset
from rodsim.io.archive_content import ArchiveContent
from rodsim.io.run_dataset import run_content


def _same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind == "f" and b.dtype.kind == "f":
        return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=True))
    return a.dtype == b.dtype and a.shape == b.shape and bool(np.array_equal(a, b))


def _file(path) -> dict:
    """Everything a netCDF-4 file holds, raw (no masking, no decoding)."""
    with netCDF4.Dataset(path) as handle:
        handle.set_auto_maskandscale(False)
        return {
            "dimensions": {name: len(d) for name, d in handle.dimensions.items()},
            "attributes": {key: handle.getncattr(key) for key in handle.ncattrs()},
            "variables": {name: (v.dtype, v.dimensions, v[...].copy(),
                                 {key: v.getncattr(key) for key in v.ncattrs()},
                                 v.filters(), v.chunking())
                          for name, v in handle.variables.items()},
        }


def assert_same_files(ours, theirs) -> None:
    a, b = _file(ours), _file(theirs)
    assert a["dimensions"] == b["dimensions"]
    assert a["attributes"].keys() == b["attributes"].keys()
    for key, value in a["attributes"].items():
        assert _same(value, b["attributes"][key]), key
        assert type(value) is type(b["attributes"][key]), key
    assert a["variables"].keys() == b["variables"].keys()
    for name, (dtype, dims, values, attrs, filters, chunking) in a["variables"].items():
        other = b["variables"][name]
        assert (dtype, dims, filters, chunking) == (other[0], other[1], other[4], other[5]), name
        assert _same(values, other[2]), name
        assert attrs.keys() == other[3].keys(), name
        for key, value in attrs.items():
            assert _same(value, other[3][key]), (name, key)


@pytest.mark.parametrize(("scene", "integrator"), [
    ("table1-50g", "cvode"), ("tendon-conserving", "static"), ("vessel-insertion", "static")])
def test_a_run_archive_is_the_file_xarray_writes(tmp_path, scene, integrator):
    content = run_content(rodsim.solve(rodsim.load_scene(scene), integrator))
    ours = write_content(content, tmp_path / "ours.nc")
    theirs = write_dataset(content.to_xarray(), tmp_path / "theirs.nc")
    assert_same_files(ours, theirs)
    xr.testing.assert_identical(read_dataset(ours), read_dataset(theirs))


def test_every_kind_of_value_is_written_as_xarray_writes_it(tmp_path):
    content = ArchiveContent(
        data_vars={
            "a": (("x", "y"), np.array([[0.5, np.nan, 2.0], [1.0, 2.0, 3.0]]), {"units": "m"}),
            "flag": ("x", np.array([True, False]), {}),
            "text": ("x", np.array(["", "né"], dtype=object), {"long_name": "words"}),
            "empty": ("x", np.array(["", ""]), {}),
            "count": ("y", np.arange(3), {}),
            "scalar": ((), np.float64(4.0), {}),
        },
        coords={"x": ("x", ["p", "q"], {"long_name": "labels"}),
                "c": ("y", [1.0, 2.0, 3.0], {}),
                "loose": ("z", [5.0], {})},
        attrs={"schema_version": "3", "n": 1, "f": 2.5, "list": [1, 2], "nan": math.nan,
               "text": "é"})
    ours = write_content(content, tmp_path / "ours.nc")
    theirs = write_dataset(content.to_xarray(), tmp_path / "theirs.nc")
    assert_same_files(ours, theirs)
    xr.testing.assert_identical(xr.open_dataset(ours).load(), xr.open_dataset(theirs).load())


def test_values_an_archive_cannot_hold_are_refused(tmp_path):
    dates = ArchiveContent({"t": ("x", np.array(["2026-01-01"], dtype="datetime64[D]"), {})})
    with pytest.raises(Exception, match="cannot store values of type"):
        write_content(dates, tmp_path / "dates.nc")
    flag = ArchiveContent({"a": ("x", [1.0], {})}, attrs={"ok": True})
    with pytest.raises(Exception, match="booleans are not netCDF attributes"):
        write_content(flag, tmp_path / "flag.nc")
    assert not list(tmp_path.iterdir())  # no partial file, no temporary left behind


def test_rodsim_run_imports_neither_xarray_nor_pandas(tmp_path):
    code = ("import sys\nfrom rodsim.app.cli.main import main\n"
            f"code = main(['run', '-o', {str(tmp_path / 'run.nc')!r}])\n"
            "print(code, 'xarray' in sys.modules, 'pandas' in sys.modules)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert done.stdout.splitlines()[-1] == "0 False False", done.stdout + done.stderr
    assert read_dataset(tmp_path / "run.nc").attrs["success"] == 1
