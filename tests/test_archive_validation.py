"""Archives that are not what they claim (issue 15, items 2, 3 and 6): `rerun` treats any
NaN as a difference and refuses a NaN tolerance; `rerun` and `plot` validate an archive
against its contract first, so a tampered one is one line and exit 2; and a run whose tip
load is beyond the analytic references still writes its archive and exits 0."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
import xarray as xr

from rodsim.app.study import Study, Sweep
from rodsim.app.study_runner import run_study
from rodsim.io.archive import read_dataset, write_dataset

TINY = Study(name="validation_test", title="two points", paper="tests only",
             scene="table1-50g", integrator="static", reference=None,
             sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (6, 7), "1", "N")]})

DEEP = "[" * 100_000 + "]" * 100_000


@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    """A run archive (static, N = 6) and a two-point study archive, written once."""
    from rodsim.app.cli import main

    folder = tmp_path_factory.mktemp("archives")
    run = folder / "run.nc"
    assert main(["run", "--integrator", "static", "--set", "nodes=6", "-o", str(run)]) == 0
    study = folder / "study.nc"
    run_study(TINY, "small", study, workers=1)
    return {"run": read_dataset(run), "study": read_dataset(study)}


def tampered(archives, kind: str, path, change) -> str:
    """Write a copy of the ``kind`` archive changed by ``change(ds)`` (which may return a
    new Dataset) to ``path``; returns the path as text."""
    ds = archives[kind].copy(deep=True)
    changed = change(ds)
    write_dataset(changed if isinstance(changed, xr.Dataset) else ds, path)
    return str(path)


def one_line(capsys, prefix: str = "rodsim: error: ") -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(prefix), captured.err
    assert "Traceback" not in captured.err
    return lines[0]


def difference(out: str) -> float:
    match = re.search(r"largest difference from the stored \w+: (\S+) m", out)
    assert match, out
    return float(match[1])


# Item 2: NaN is a difference ------------------------------------------------------------


def shift_with_nan(ds: xr.Dataset, variable: str, everywhere: bool = False) -> None:
    values = ds[variable].values
    values += 1.0
    if everywhere:
        values[...] = np.nan
    else:
        values.reshape(-1)[-1] = np.nan


@pytest.mark.parametrize("everywhere", [False, True])
def test_rerun_of_a_run_with_nan_positions_differs(everywhere, archives, tmp_path, cli,
                                                   capsys):
    path = tampered(archives, "run", tmp_path / "nan.nc",
                    lambda ds: shift_with_nan(ds, "position", everywhere))
    assert cli(["rerun", path]) == 1
    captured = capsys.readouterr()
    assert math.isinf(difference(captured.out))
    assert "differs" in captured.err


def test_rerun_of_a_study_with_a_nan_centerline_differs(archives, tmp_path, cli, capsys):
    """`max(0.0, nan)` kept 0.0: the study reported 0 m."""

    def change(ds):
        ds["centerline"].values[0] += 1.0
        ds["centerline"].values[0, 0, 3, 1] = np.nan

    path = tampered(archives, "study", tmp_path / "nan-study.nc", change)
    assert cli(["rerun", path]) == 1
    assert math.isinf(difference(capsys.readouterr().out))


def test_rerun_of_an_untouched_archive_still_passes(archives, tmp_path, cli, capsys):
    """The other side of item 2: an intact archive reproduces (difference 0, exit 0)."""
    for kind in ("run", "study"):
        path = tampered(archives, kind, tmp_path / f"{kind}.nc", lambda ds: None)
        assert cli(["rerun", path]) == 0, capsys.readouterr().err
        assert difference(capsys.readouterr().out) == 0.0


@pytest.mark.parametrize("tolerance", ["nan", "-1e-9", "inf", "abc"])
def test_rerun_refuses_a_tolerance_that_is_no_tolerance(tolerance, archives, tmp_path, cli,
                                                        capsys):
    path = tampered(archives, "run", tmp_path / "run.nc", lambda ds: None)
    with pytest.raises(SystemExit) as exit_info:
        cli(["rerun", path, "--tolerance", tolerance])
    assert exit_info.value.code == 2
    assert "--tolerance" in one_line(capsys, "rodsim rerun: error: ")


# Item 6: tampered archives ---------------------------------------------------------------


def drop_attribute(name):
    return lambda ds: ds.attrs.pop(name)


def set_attribute(name, value):
    return lambda ds: ds.attrs.__setitem__(name, value)


def edit_json(attribute, edit):
    def change(ds):
        data = json.loads(ds.attrs[attribute])
        edit(data)
        ds.attrs[attribute] = json.dumps(data, sort_keys=True)
    return change


def set_nodes(data):
    data["rods"]["catheter"]["nodes"] = 7


def long_sweep(data):
    data["sweeps"][0]["values"].append(8)


def huge_sigma(data):
    data["sigma_points"] = 100_000_000_000


def no_sweeps(data):
    del data["sweeps"]


RUN_TAMPERS = {
    "no integrator": drop_attribute("integrator"),
    "unknown integrator": set_attribute("integrator", "rk4"),
    "no integrator_options": drop_attribute("integrator_options"),
    "no position": lambda ds: ds.drop_vars("position"),
    "no rod": lambda ds: ds.drop_vars("rod"),
    "nodes edited": edit_json("scene_json", set_nodes),
    "scene name edited to a path": edit_json("scene_json",
                                             lambda d: d.__setitem__("name", "../x")),
    "study attribute on a run": set_attribute("study", "fig7b"),
    **{f"scene_json {label}": set_attribute("scene_json", text) for label, text in
       (("not JSON", "{not json"), ("null", "null"), ("42", "42"), ("[]", "[]"),
        ("deep", DEEP))},
    **{f"integrator_options {label}": set_attribute("integrator_options", text)
       for label, text in (("not JSON", "{"), ("null", "null"), ("42", "42"), ("[]", "[]"),
                           ("deep", DEEP))},
}

STUDY_TAMPERS = {
    "no spec_json": drop_attribute("spec_json"),
    "no sweeps": edit_json("spec_json", no_sweeps),
    "sweep values longer than the dimension": edit_json("spec_json", long_sweep),
    "sigma_points 1e11": edit_json("spec_json", huge_sigma),
    "no centerline": lambda ds: ds.drop_vars("centerline"),
    # Found by the fuzz suite at 300-400 examples per test:
    "spec_json integrator is a list": edit_json("spec_json",
                                                lambda d: d.__setitem__("integrator", [])),
    "no axis coordinate": lambda ds: ds.drop_vars("axis"),
    "study attribute is not the spec's name": set_attribute("study", "\x1f"),
    **{f"spec_json {label}": set_attribute("spec_json", text) for label, text in
       (("not JSON", "nope"), ("null", "null"), ("42", "42"), ("[]", "[]"), ("deep", DEEP))},
}


@pytest.mark.parametrize("command", ["rerun", "plot"])
@pytest.mark.parametrize(("kind", "case"), [("run", c) for c in RUN_TAMPERS]
                         + [("study", c) for c in STUDY_TAMPERS])
def test_a_tampered_archive_is_one_line_and_exit_2(command, kind, case, archives, tmp_path,
                                                  cli, capsys):
    change = (RUN_TAMPERS if kind == "run" else STUDY_TAMPERS)[case]
    path = tampered(archives, kind, tmp_path / "tampered.nc", change)
    before = sorted(p.name for p in tmp_path.iterdir())
    assert cli([command, path]) == 2
    assert "tampered.nc" in one_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no figure, nothing else


def test_intact_archives_plot(archives, tmp_path, cli, capsys):
    """The checks accept what rodsim writes: both archives plot."""
    for kind in ("run", "study"):
        path = tampered(archives, kind, tmp_path / f"{kind}.nc", lambda ds: None)
        assert cli(["plot", path, "--format", "png"]) == 0, capsys.readouterr().err
        assert (tmp_path / f"{kind}.png").exists()


def test_positions_far_apart_differ_without_a_warning(archives, tmp_path, cli, capsys,
                                                       recwarn):
    """Found by the fuzz suite: a stored position of 1e300 overflowed the distance with a
    RuntimeWarning; the distance is infinite, and nothing but the verdict is printed."""

    def far(ds):
        ds["position"].values[-1, 0] = 1e300

    path = tampered(archives, "run", tmp_path / "far.nc", far)
    assert cli(["rerun", path]) == 1
    assert math.isinf(difference(capsys.readouterr().out))
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


# Item 3: the analytic reference fails soft ----------------------------------------------


def test_a_load_beyond_the_analytic_references_still_succeeds(tmp_path, cli, capsys):
    """α = 117 613: the paper's model cannot resolve φ0; the summary says n/a, the archive is
    written and the exit code is 0 (it was a traceback and exit 1 after the write)."""
    output = tmp_path / "heavy.nc"
    assert cli(["run", "--integrator", "static", "--set", "nodes=6", "--set", "mass=1e4",
                "-o", str(output)]) == 0
    captured = capsys.readouterr()
    # stderr holds at most the progress lines a solve longer than a second prints
    assert "analytic references n/a" in captured.out
    assert all(line.startswith("[") for line in captured.err.splitlines()), captured.err
    assert read_dataset(output).attrs["success"] == 1


def test_a_point_selection_with_a_newline_is_one_line(archives, tmp_path, cli, capsys):
    path = tampered(archives, "study", tmp_path / "study.nc", lambda ds: None)
    assert cli(["rerun", path, "--point", "no\nsuch=1"]) == 2
    assert "not a swept parameter" in one_line(capsys)
