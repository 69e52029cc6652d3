"""Studies end to end: the runner (local processes, in-process, dask), resume after a kill,
failing points, the assembled archive and its provenance, study rerun and plots.

The studies here are small custom ones on the Table 1 scene (50 g), not the shipped ones,
so that every point takes tens of milliseconds (static integrator, N = 6–21) and the whole
file stays well under a minute on two cores.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import rodsim
import rodsim.studies
import rodsim.study_runner
from rodsim.api import load_scene, solve
from rodsim.archive import read_dataset, write_dataset
from rodsim.result import SCHEMA_VERSION
from rodsim.study import (
    STATUS,
    Study,
    StudyError,
    Sweep,
    evaluate_point,
    grid_points,
    load_study,
    rerun_study,
)
from rodsim.study_runner import parts_folder, run_spec, run_study

NODES = (6, 11, 21)  # 100/(N-1) is an integer: every node falls on the σ grid of 101 points
MASSES = (0.02, 0.05)

#: 6 points of 10–90 ms each (static integrator), compared with the exact elastica.
BASE = Study(
    name="runner_test",
    title="tip error against N and the tip mass",
    paper="tests only",
    scene="table1-50g",
    integrator="static",
    reference="exact",
    sweeps={
        "small": [Sweep("nodes", "rods.catheter.nodes", NODES, "1", "number of control points N"),
                  Sweep("mass", "rods.catheter.tip_load.mass", MASSES, "kg", "tip mass")],
        "full": [Sweep("nodes", "rods.catheter.nodes", (6, 11, 21, 41), "1",
                       "number of control points N"),
                 Sweep("mass", "rods.catheter.tip_load.mass", MASSES, "kg", "tip mass")],
    },
)

#: Points that fail: N = 2 is not a valid scene (status "error"), and one Newton iteration
#: with load steps of at least 0.5 cannot reach equilibrium (status "solver_failure").
FAILING = Study(
    name="zz_runner_test_failing",
    title="failing points",
    paper="tests only",
    scene="table1-50g",
    integrator="static",
    reference="exact",
    plot="error_vs_parameter",
    overrides=("solver.static.min_load_step=0.5",),
    sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (2, 8, 12), "1", "N"),
                      Sweep("max_newton", "solver.static.max_newton", (1, 30), "1",
                            "Newton iterations per load step")]},
)
#: Expected status per (nodes, max_newton) point of FAILING.
FAILING_STATUS = np.array([[STATUS["error"], STATUS["error"]],
                           [STATUS["solver_failure"], STATUS["ok"]],
                           [STATUS["solver_failure"], STATUS["ok"]]])

#: Slower points for the kill test (CVODE pseudo-dynamics, ~0.25 s per point), so the study
#: can be caught reliably between its first and its last point.
SLOW = Study(
    name="runner_test_slow",
    title="CVODE points",
    paper="tests only",
    scene="table1-50g",
    integrator="cvode",
    reference="exact",
    sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (12, 16, 20), "1", "N"),
                      Sweep("mass", "rods.catheter.tip_load.mass", MASSES, "kg", "tip mass")]},
)

REPO = Path(rodsim.__file__).resolve().parent.parent

# Wall times are measured per point and cannot be identical between two runs; every other
# variable (statistics included) is deterministic and must match exactly.
TIMING = ["wall_time"]


def without_timing(ds: xr.Dataset) -> xr.Dataset:
    return ds.drop_vars(TIMING)


def point_files(folder: Path) -> dict[str, tuple[bytes, int]]:
    """Content and modification time of each finished point in a parts folder."""
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns)
            for p in sorted(folder.glob("point-*.json"))}


def folder_snapshot(folder: Path) -> dict[str, tuple[bytes, int]]:
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def spec() -> dict:
    return BASE.spec("small")


@pytest.fixture(scope="module")
def study_run(tmp_path_factory, spec):
    """The BASE study run in-process (workers = 1): (returned Dataset, archive, progress)."""
    output = tmp_path_factory.mktemp("study") / "study.nc"
    calls = []
    dataset = run_spec(spec, output, workers=1, progress=lambda *a: calls.append(a))
    return dataset, output, calls


@pytest.fixture(scope="module")
def failing_run(tmp_path_factory):
    output = tmp_path_factory.mktemp("failing") / "failing.nc"
    return run_study(FAILING, "small", output, workers=1), output


@pytest.fixture
def registered(tmp_path, monkeypatch):
    """Make FAILING a shipped study for the CLI: a module in a folder of rodsim.studies."""
    folder = tmp_path / "extra_studies"
    folder.mkdir()
    module = "zz_runner_test_failing"
    (folder / f"{module}.py").write_text(
        f"from rodsim.study import Study, Sweep\n\nSTUDY = {FAILING!r}\n", encoding="utf-8")
    monkeypatch.setattr(rodsim.studies, "__path__", [*rodsim.studies.__path__, str(folder)])
    monkeypatch.delitem(sys.modules, f"rodsim.studies.{module}", raising=False)
    monkeypatch.setattr(rodsim.studies, module, None, raising=False)
    return FAILING.name


# 1. Round trip, units and provenance -------------------------------------------------------


def test_archive_round_trip_units_and_provenance(study_run, spec):
    dataset, output, calls = study_run
    assert output.exists()
    assert not parts_folder(output).exists(), "the parts folder must go once the study is done"
    with xr.open_dataset(output) as opened:
        reopened = opened.load()
    xr.testing.assert_identical(reopened, dataset)
    xr.testing.assert_identical(read_dataset(output), dataset)

    assert (dataset["status"].values == STATUS["ok"]).all(), dataset["message"].values
    for name, variable in dataset.data_vars.items():
        assert variable.attrs.get("long_name"), name
        if name not in ("status", "message"):  # flags and text have no unit
            assert variable.attrs.get("units"), f"{name} has no units"
    assert dataset["tip"].attrs["units"] == "m"
    assert dataset["centerline"].attrs["units"] == "m"
    assert dataset["wall_time"].attrs["units"] == "s"
    assert np.asarray(dataset["status"].attrs["flag_values"]).tolist() == list(STATUS.values())
    assert dataset["status"].attrs["flag_meanings"].split() == list(STATUS)

    attrs = dataset.attrs
    base = load_scene("table1-50g")
    assert json.loads(attrs["scene_json"]) == json.loads(base.to_json())
    assert attrs["scene_toml"] == (REPO / "data" / "table1-50g.toml").read_text(encoding="utf-8")
    stored = json.loads(attrs["spec_json"])
    assert stored == spec
    assert [s["key"] for s in stored["sweeps"]] == ["rods.catheter.nodes",
                                                    "rods.catheter.tip_load.mass"]
    assert [s["values"] for s in stored["sweeps"]] == [list(NODES), list(MASSES)]
    assert attrs["rodsim_version"] == rodsim.__version__
    assert str(attrs["schema_version"]) == SCHEMA_VERSION
    assert attrs["integrator"] == "static" and attrs["reference"] == "exact"
    assert int(attrs["points"]) == 6 and int(attrs["failed_points"]) == 0
    if (REPO / ".git").exists():
        head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "HEAD"], check=True,
                              capture_output=True, text=True).stdout.strip()
        assert attrs["git_commit"] == head
    else:
        assert "git_commit" not in attrs

    # Progress: (done, failed, total, elapsed), from nothing done to every point done.
    assert calls[0] == (0, 0, 6, 0.0)
    assert [c[0] for c in calls] == list(range(7))
    assert calls[-1][:3] == (6, 0, 6) and calls[-1][3] > 0


# 2. Dimensions, coordinates and the common σ grid ------------------------------------------


def test_one_dimension_per_sweep_and_common_sigma_grid(study_run):
    dataset, _, _ = study_run
    assert dataset["status"].dims == ("nodes", "mass")
    assert dataset["centerline"].dims == ("nodes", "mass", "rod", "sigma", "axis")
    assert dataset["tip"].dims == ("nodes", "mass", "rod", "axis")
    assert dataset["nodes"].values.tolist() == list(NODES)
    assert dataset["mass"].values.tolist() == list(MASSES)
    assert dataset["nodes"].attrs == {"units": "1", "long_name": "number of control points N",
                                      "scene_key": "rods.catheter.nodes"}
    assert dataset["mass"].attrs == {"units": "kg", "long_name": "tip mass",
                                     "scene_key": "rods.catheter.tip_load.mass"}
    assert dataset["rod"].values.tolist() == ["catheter"]
    np.testing.assert_array_equal(dataset["sigma"].values, np.linspace(0.0, 1.0, 101))
    assert dataset["sigma"].attrs["units"] == "1"

    length = 0.12
    centerlines = dataset["centerline"].sel(rod="catheter")
    assert not np.isnan(centerlines.values).any()
    for n in NODES:
        for mass in MASSES:
            line = centerlines.sel(nodes=n, mass=mass).values
            np.testing.assert_array_equal(line[0], [0.0, 0.0, 0.0])  # clamped root at σ = 0
            np.testing.assert_array_equal(line[-1], dataset["tip"].sel(
                nodes=n, mass=mass, rod="catheter").values)
            # σ is s/L: the arc length along the sampled curve grows like σ L (the catheter
            # barely stretches under 50 g).
            arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0),
                                                                  axis=1))])
            np.testing.assert_allclose(arc / length, dataset["sigma"].values, atol=2e-3)

    # Independent solve of one point: its nodes lie on the σ grid (σ_i = i/(N-1)).
    result = solve(load_scene("table1-50g", ["rods.catheter.nodes=11",
                                             "rods.catheter.tip_load.mass=0.05"]), "static")
    nodes = result.positions("catheter")
    line = centerlines.sel(nodes=11, mass=0.05).values
    np.testing.assert_allclose(line[::10], nodes, rtol=0, atol=1e-12)

    # Different N are compared on the same σ: they agree to discretisation error only.
    coarse, fine = (centerlines.sel(nodes=n, mass=0.05).values for n in (6, 21))
    gap = np.linalg.norm(coarse - fine, axis=1).max()
    assert 0 < gap < 0.02 * length
    errors = dataset["tip_error"].sel(mass=0.05).values
    assert errors[0] > errors[1] > errors[2] > 0  # converging to the elastica as N grows


# 3. Resume after a kill --------------------------------------------------------------------

KILLABLE = """\
import json, sys
from rodsim.study_runner import run_spec
with open(sys.argv[1], encoding="utf-8") as stream:
    spec = json.load(stream)
run_spec(spec, sys.argv[2], workers=1)
"""


def test_resume_after_kill_runs_only_missing_points(tmp_path, monkeypatch):
    spec = SLOW.spec("small")
    total = len(grid_points(spec))
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(json.dumps(spec), encoding="utf-8")
    output = tmp_path / "killed" / "slow.nc"
    output.parent.mkdir()
    parts = parts_folder(output)
    log = (tmp_path / "child.log").open("w")
    child = subprocess.Popen([sys.executable, "-c", KILLABLE, str(spec_file), str(output)],
                             stdout=log, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 60
        while len(list(parts.glob("point-*.json"))) < 2:
            assert child.poll() is None, "the study ended before it could be killed: " \
                + (tmp_path / "child.log").read_text()
            assert time.monotonic() < deadline, "no point finished within 60 s"
            time.sleep(0.005)
        os.kill(child.pid, signal.SIGKILL)
        assert child.wait(timeout=30) == -signal.SIGKILL
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
        log.close()

    before = point_files(parts)
    assert 2 <= len(before) < total, f"killed too late: {sorted(before)}"
    assert (parts / "spec.json").exists()
    assert not output.exists(), "no archive while the study is incomplete"
    assert not list(output.parent.glob(f".{output.name}.*")), "no partial archive either"

    calls = []

    def recording(spec_, index):
        calls.append(tuple(index))
        return evaluate_point(spec_, index)

    monkeypatch.setattr(rodsim.study_runner, "evaluate_point", recording)
    resumed = run_spec(spec, output, workers=1, keep_parts=True)
    done = {tuple(json.loads(record)["index"]) for record, _ in before.values()}
    assert len(calls) == len(set(calls)), f"a point ran twice: {calls}"
    assert set(calls) == set(grid_points(spec)) - done, "finished points must not run again"
    after = point_files(parts)
    assert len(after) == total
    for name, (content, mtime) in before.items():
        assert after[name] == (content, mtime), f"{name} was rewritten on resume"
    assert output.exists()
    xr.testing.assert_identical(read_dataset(output), resumed)

    # An uninterrupted run of the same spec, elsewhere: identical but for the wall times.
    monkeypatch.undo()
    (tmp_path / "whole").mkdir()
    whole = run_spec(spec, tmp_path / "whole" / "slow.nc", workers=1)
    assert (whole["status"].values == STATUS["ok"]).all(), whole["message"].values
    xr.testing.assert_identical(without_timing(resumed), without_timing(whole))

    # Resuming a complete parts folder runs nothing, reproduces the Dataset exactly (the
    # stored wall times included) and removes the parts folder.
    calls.clear()
    monkeypatch.setattr(rodsim.study_runner, "evaluate_point", recording)
    again = run_spec(spec, output, workers=1)
    assert calls == []
    xr.testing.assert_identical(again, resumed)
    assert not parts.exists()
    xr.testing.assert_identical(read_dataset(output), resumed)


# 4. Failing points -------------------------------------------------------------------------


def test_failing_points_are_recorded_and_do_not_stop_the_study(failing_run):
    dataset, output = failing_run
    assert not parts_folder(output).exists()
    xr.testing.assert_identical(read_dataset(output), dataset)
    np.testing.assert_array_equal(dataset["status"].values, FAILING_STATUS)
    assert int(dataset.attrs["failed_points"]) == 4
    assert int(dataset.attrs["points"]) == 6

    messages = dataset["message"].values
    for message in messages[0]:  # N = 2: an invalid scene, named in the message
        assert "rods.catheter.nodes" in message and "2" in message, message
    for message in messages[1:, 0]:  # one Newton iteration, load steps >= 0.5
        assert "min_load_step" in message or "Newton" in message, message
    for message in messages[1:, 1]:
        assert message == "converged"

    bad = dataset.isel(nodes=0)
    for name in ("tip", "centerline", "tip_error", "area_error", "residual",
                 "quaternion_norm_error", "steps", "newton_iters", "wall_time"):
        assert np.isnan(bad[name].values).all(), name
    good = dataset.isel(nodes=slice(1, None), max_newton=1)
    for name in ("tip", "centerline", "tip_error", "area_error", "residual", "wall_time"):
        assert not np.isnan(good[name].values).any(), name
    assert (good["tip_error"].values < 0.02).all()


def test_solver_failure_points_store_no_results(failing_run):
    """A point whose solver failed has no equilibrium: its results must be NaN, not the
    state the solver gave up in (which would be plotted and scored as if it were one)."""
    dataset, _ = failing_run
    failed = dataset.isel(nodes=slice(1, None), max_newton=0)
    assert (failed["status"].values == STATUS["solver_failure"]).all()
    for name in ("tip", "centerline", "tip_error", "area_error"):
        values = failed[name].values
        assert np.isnan(values).all(), (
            f"{name} at the solver-failure points is {values.ravel()[:4]}…, expected NaN")


def test_cli_study_exit_code_is_1_when_points_failed(registered, tmp_path, cli, capsys):
    assert load_study(registered) == FAILING
    assert cli(["study"]) == 0
    assert registered in capsys.readouterr().out
    output = tmp_path / "cli.nc"
    code = cli(["study", registered, "--size", "small", "--workers", "1", "-o", str(output)])
    out = capsys.readouterr().out
    assert code == 1, out
    assert "6 points, 4 failed" in out
    dataset = read_dataset(output)
    np.testing.assert_array_equal(dataset["status"].values, FAILING_STATUS)
    assert int(dataset.attrs["failed_points"]) == 4


# 5, 6. Parallel local processes and dask give the same Dataset -----------------------------


def test_two_local_processes_match_in_process_run(study_run, spec, tmp_path):
    dataset, _, _ = study_run
    output = tmp_path / "two.nc"
    parallel = run_spec(spec, output, workers=2)
    assert not parts_folder(output).exists()
    xr.testing.assert_identical(without_timing(parallel), without_timing(dataset))
    xr.testing.assert_identical(read_dataset(output), parallel)


def test_dask_local_cluster_matches_local_run(study_run, spec, tmp_path):
    import dask  # a test dependency (pyproject's "test" extra): missing it must fail, not skip
    import distributed  # noqa: F401

    dataset, _, _ = study_run
    output = tmp_path / "dask.nc"
    # A LocalCluster of two worker processes can take several seconds to start.
    with dask.config.set({"distributed.comm.timeouts.connect": "120s",
                          "distributed.comm.timeouts.tcp": "120s"}):
        distributed = run_spec(spec, output, scheduler="local")
    assert not parts_folder(output).exists()
    xr.testing.assert_identical(without_timing(distributed), without_timing(dataset))
    xr.testing.assert_identical(read_dataset(output), distributed)


# 7. Parts folder of another spec, missing output folder ------------------------------------


def test_parts_folder_of_another_spec_is_refused_and_left_alone(tmp_path, spec):
    tiny = Study(name="runner_test_tiny", title="t", paper="tests only", scene="table1-50g",
                 integrator="static", reference="exact",
                 sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (6, 8), "1", "N")],
                         "full": [Sweep("nodes", "rods.catheter.nodes", (6, 8, 10), "1", "N")]})
    output = tmp_path / "tiny.nc"
    run_study(tiny, "small", output, workers=1, keep_parts=True)
    parts = parts_folder(output)
    folder = folder_snapshot(parts)
    archive = output.read_bytes()
    assert len([name for name in folder if name.startswith("point-")]) == 2

    other_sweep = json.loads(json.dumps(tiny.spec("small")))
    other_sweep["sweeps"][0]["values"] = [6, 9]
    for other in (tiny.spec("full"), other_sweep, spec):
        with pytest.raises(StudyError, match="different study or size") as caught:
            run_spec(other, output, workers=1)
        assert str(parts) in str(caught.value)
        assert folder_snapshot(parts) == folder, "the parts folder must be left untouched"
        assert output.read_bytes() == archive

    stray = tmp_path / "stray.nc.parts"
    stray.mkdir()
    (stray / "notes.txt").write_text("mine", encoding="utf-8")
    with pytest.raises(StudyError, match="not a rodsim study's parts folder"):
        run_spec(spec, tmp_path / "stray.nc", workers=1)
    assert [p.name for p in stray.iterdir()] == ["notes.txt"]

    missing = tmp_path / "no" / "such" / "folder" / "out.nc"
    with pytest.raises(StudyError, match="does not exist"):
        run_spec(spec, missing, workers=1)
    assert not (tmp_path / "no").exists()

    with pytest.raises(StudyError, match="no size 'huge'"):
        tiny.spec("huge")


# 8. Study rerun ----------------------------------------------------------------------------


def test_rerun_study_reproduces_stored_centerlines(study_run):
    _, output, _ = study_run
    dataset = read_dataset(output)
    records, largest = rerun_study(dataset)
    assert sorted(tuple(r["index"]) for r in records) == sorted(grid_points(
        json.loads(dataset.attrs["spec_json"])))
    assert largest < 1e-12
    for record in records:
        assert record["status"] == STATUS["ok"]
        stored = dataset["centerline"].values[tuple(record["index"])][0]
        np.testing.assert_allclose(record["centerline"]["catheter"], stored, rtol=0, atol=1e-12)

    records, largest = rerun_study(dataset, {"nodes": 11, "mass": "0.05"})
    assert [r["index"] for r in records] == [[1, 1]]
    assert largest < 1e-12
    np.testing.assert_allclose(records[0]["centerline"]["catheter"],
                               dataset["centerline"].sel(nodes=11, mass=0.05).values[0],
                               rtol=0, atol=1e-12)

    with pytest.raises(StudyError, match="not a swept parameter"):
        rerun_study(dataset, {"sigma": 0.5})
    with pytest.raises(StudyError, match="no point matches"):
        rerun_study(dataset, {"nodes": 7})


def test_cli_rerun_of_a_study_archive(study_run, tmp_path, cli, capsys):
    _, output, _ = study_run
    assert cli(["rerun", str(output), "--point", "nodes=11"]) == 0
    out = capsys.readouterr().out
    assert "re-ran 2 point(s), 0 failed" in out, out
    assert cli(["rerun", str(output), "--point", "nodes=21", "--point", "mass=0.02"]) == 0
    assert "re-ran 1 point(s)" in capsys.readouterr().out

    assert cli(["rerun", str(output), "--point", "sigma=0.5"]) == 2
    err = capsys.readouterr().err
    assert "sigma" in err and "not a swept parameter" in err and "nodes, mass" in err, err
    assert "Traceback" not in err

    # A stored centerline that is off by 1 µm is caught.
    tampered = read_dataset(output)
    tampered["centerline"].loc[{"nodes": 11}] = tampered["centerline"].sel(nodes=11) + 1e-6
    path = write_dataset(tampered, tmp_path / "tampered.nc")
    assert cli(["rerun", str(path), "--point", "nodes=11"]) == 1
    assert "differs from the archive" in capsys.readouterr().err
    assert cli(["rerun", str(path), "--point", "nodes=6"]) == 0


# 9. Plot -----------------------------------------------------------------------------------


@pytest.mark.parametrize("which", ["study", "failing"])
def test_cli_plot_of_a_study_archive(which, study_run, failing_run, tmp_path, cli, capsys):
    source = (study_run if which == "study" else failing_run)[1]
    archive = tmp_path / source.name
    archive.write_bytes(source.read_bytes())
    assert cli(["plot", str(archive)]) == 0
    out = capsys.readouterr().out
    png, pdf = archive.with_suffix(".png"), archive.with_suffix(".pdf")
    assert str(png) in out and str(pdf) in out
    assert png.read_bytes().startswith(b"\x89PNG\r\n\x1a\n") and png.stat().st_size > 5000
    assert pdf.read_bytes().startswith(b"%PDF") and pdf.stat().st_size > 1000
