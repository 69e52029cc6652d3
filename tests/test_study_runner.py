"""Studies end to end: the runner (local processes, in-process, dask), resume after a kill,
failing points, the assembled archive and its provenance, study rerun and plots.

The studies here are small custom ones on the Table 1 scene (50 g), not the shipped ones,
so that every point takes tens of milliseconds (static integrator, N = 6–21) and the whole
file stays well under a minute on two cores.
"""

from __future__ import annotations

import dataclasses
import errno
import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from fault_injection import Faults, child_preamble

import rodsim
import rodsim.app.study_runner
import rodsim.studies
from rodsim.app.api import load_scene, solve
from rodsim.app.study import (
    STATUS,
    Study,
    StudyError,
    StudySpec,
    Sweep,
    evaluate_point,
    grid_points,
    load_study,
    rerun_study,
)
from rodsim.app.study_runner import WORKER_DIED, parts_folder, run_spec, run_study
from rodsim.io.archive import read_dataset, write_dataset
from rodsim.io.archive_schema import SCHEMA_VERSION

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

#: Attributes that say when the archive was assembled (docs/archive.md, "Conventions and
#: provenance"): two assemblies of the same points differ in them only.
CREATED = ("date_created", "history")


def without_creation(ds: xr.Dataset) -> xr.Dataset:
    out = ds.copy(deep=False)
    out.attrs = {k: v for k, v in ds.attrs.items() if k not in CREATED}
    return out


def without_timing(ds: xr.Dataset) -> xr.Dataset:
    return without_creation(ds.drop_vars(TIMING))


def assert_units_and_long_names(ds: xr.Dataset) -> None:
    """Every variable and coordinate has a long_name; numbers have units, text has none
    (docs/archive.md, "Study archives")."""
    for name, variable in ds.variables.items():
        assert variable.attrs.get("long_name"), f"{name} has no long_name"
        if np.issubdtype(variable.dtype, np.number):
            assert variable.attrs.get("units"), f"{name} has no units"
        else:
            assert variable.dtype.kind in "UO", f"{name}: {variable.dtype}"
            assert "units" not in variable.attrs, f"{name} is text and has units"


def point_files(folder: Path) -> dict[str, tuple[bytes, int]]:
    """Content and modification time of each finished point in a parts folder."""
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns)
            for p in sorted(folder.glob("point-*.json"))}


def folder_snapshot(folder: Path) -> dict[str, tuple[bytes, int]]:
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def spec() -> StudySpec:
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


def study_module(folder: Path, study: Study) -> Path:
    """Write ``study`` as a study file ``<folder>/<name>.py`` (for rodsim.studies)."""
    folder.mkdir(exist_ok=True)
    path = folder / f"{study.name}.py"
    path.write_text(f"from rodsim.app.study import Study, Sweep\n\nSTUDY = {study!r}\n",
                    encoding="utf-8")
    return path


@pytest.fixture
def registered(tmp_path, monkeypatch):
    """Make FAILING a shipped study for the CLI: a module in a folder of rodsim.studies."""
    folder = tmp_path / "extra_studies"
    module = study_module(folder, FAILING).stem
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
    # In the file (schema 3) the text-labelled dimensions have numeric coordinates and their
    # labels beside them; read_dataset gives back exactly the Dataset that was written.
    for dim in ("rod", "axis"):
        assert reopened[dim].values.tolist() == list(range(dataset.sizes[dim]))
        assert reopened[f"{dim}_label"].values.tolist() == dataset[dim].values.tolist()
    np.testing.assert_array_equal(reopened["centerline"].values, dataset["centerline"].values)
    xr.testing.assert_identical(read_dataset(output), dataset)

    assert (dataset["status"].values == STATUS["ok"]).all(), dataset["message"].values
    assert_units_and_long_names(dataset)
    assert dataset["status"].attrs["units"] == "1"
    assert "units" not in dataset["message"].attrs  # text: long_name only (docs/archive.md)
    assert dataset["tip"].attrs["units"] == "m"
    assert dataset["centerline"].attrs["units"] == "m"
    assert dataset["wall_time"].attrs["units"] == "s"
    assert np.asarray(dataset["status"].attrs["flag_values"]).tolist() == list(STATUS.values())
    assert dataset["status"].attrs["flag_meanings"].split() == list(STATUS)

    attrs = dataset.attrs
    base = load_scene("table1-50g")
    assert json.loads(attrs["scene_json"]) == json.loads(base.to_json())
    assert attrs["scene_toml"] == (REPO / "data" / "table1-50g.toml").read_text(encoding="utf-8")
    assert attrs["spec_json"] == spec.to_json()
    assert StudySpec.from_json(attrs["spec_json"]) == spec
    stored = json.loads(attrs["spec_json"])
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
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--", "rodsim",
                                "studies", "data", "pyproject.toml"], check=True,
                               capture_output=True, text=True).stdout.strip()
        assert int(attrs["git_dirty"]) == int(bool(dirty))
    else:
        assert "git_commit" not in attrs and "git_dirty" not in attrs

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
import sys
from rodsim.app.study import StudySpec
from rodsim.app.study_runner import run_spec
with open(sys.argv[1], encoding="utf-8") as stream:
    spec = StudySpec.from_json(stream.read())
run_spec(spec, sys.argv[2], workers=int(sys.argv[3]))
"""


@pytest.fixture(scope="module")
def slow_whole(tmp_path_factory) -> xr.Dataset:
    """The SLOW study run uninterrupted, in-process: what every resumed run must give."""
    whole = run_spec(SLOW.spec("small"), tmp_path_factory.mktemp("whole") / "slow.nc",
                     workers=1)
    assert (whole["status"].values == STATUS["ok"]).all(), whole["message"].values
    return whole


def children_of(pid: int) -> list[int]:
    """Live (not zombie) child processes of ``pid``, from /proc."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid and fields[0] != "Z":
            found.append(int(stat.parent.name))
    return found


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def kill_mid_study(tmp_path: Path, spec: StudySpec, workers: int) -> tuple[Path, list[int]]:
    """Run ``spec`` in a child process, SIGKILL it once two points are recorded; returns
    the output path and the child's own children (worker processes) at the kill."""
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(spec.to_json(), encoding="utf-8")
    output = tmp_path / "killed" / "slow.nc"
    output.parent.mkdir()
    parts = parts_folder(output)
    with (tmp_path / "child.log").open("w") as log:
        child = subprocess.Popen([sys.executable, "-c", KILLABLE, str(spec_file), str(output),
                                  str(workers)], stdout=log, stderr=subprocess.STDOUT)
        try:
            deadline = time.monotonic() + 60
            while len(list(parts.glob("point-*.json"))) < 2:
                assert child.poll() is None, "the study ended before it could be killed: " \
                    + (tmp_path / "child.log").read_text()
                assert time.monotonic() < deadline, "no point finished within 60 s"
                time.sleep(0.005)
            workers_at_kill = children_of(child.pid) if sys.platform == "linux" else []
            os.kill(child.pid, signal.SIGKILL)
            assert child.wait(timeout=30) == -signal.SIGKILL
        finally:
            if child.poll() is None:
                child.kill()
                child.wait()
    return output, workers_at_kill


def resume_and_check(spec: dict, output: Path, workers: int, whole: xr.Dataset,
                     monkeypatch) -> None:
    """Resume a killed study: only the missing points run, none twice, finished points are
    not rewritten, and the Dataset is identical to an uninterrupted run's."""
    parts = parts_folder(output)
    total = len(grid_points(spec))
    before = point_files(parts)
    assert 2 <= len(before) < total, f"killed too late: {sorted(before)}"
    assert (parts / "spec.json").exists()
    assert not output.exists(), "no archive while the study is incomplete"
    assert not list(output.parent.glob(f".{output.name}.*")), "no partial archive either"

    done = {tuple(json.loads(record)["index"]) for record, _ in before.values()}
    calls = []

    def recording(spec_, index):
        calls.append(tuple(index))
        return evaluate_point(spec_, index)

    if workers == 1:  # in-process: every evaluated point is seen
        monkeypatch.setattr(rodsim.app.study_runner, "evaluate_point", recording)
        resumed = run_spec(spec, output, workers=1, keep_parts=True)
        assert len(calls) == len(set(calls)), f"a point ran twice: {calls}"
        assert set(calls) == set(grid_points(spec)) - done, "finished points ran again"
        monkeypatch.undo()
    else:  # worker processes: the progress calls count the points run
        progress = []
        resumed = run_spec(spec, output, workers=workers, keep_parts=True,
                           progress=lambda *a: progress.append(a))
        assert progress[0][:3] == (len(done), 0, total)
        assert [c[0] for c in progress] == list(range(len(done), total + 1))
    after = point_files(parts)
    assert len(after) == total
    for name, (content, mtime) in before.items():
        assert after[name] == (content, mtime), f"{name} was rewritten on resume"
    assert output.exists()
    xr.testing.assert_identical(read_dataset(output), resumed)
    # Identical to the uninterrupted run but for the wall times.
    xr.testing.assert_identical(without_timing(resumed), without_timing(whole))

    # Resuming a complete parts folder runs nothing, reproduces the Dataset exactly (the
    # stored wall times included; only its creation time is new) and removes the parts folder.
    calls.clear()
    monkeypatch.setattr(rodsim.app.study_runner, "evaluate_point", recording)
    again = run_spec(spec, output, workers=1)
    monkeypatch.undo()
    assert calls == []
    xr.testing.assert_identical(without_creation(again), without_creation(resumed))
    assert not parts.exists()
    xr.testing.assert_identical(read_dataset(output), again)


def test_resume_after_kill_runs_only_missing_points(tmp_path, monkeypatch, slow_whole):
    spec = SLOW.spec("small")
    output, _ = kill_mid_study(tmp_path, spec, workers=1)
    resume_and_check(spec, output, 1, slow_whole, monkeypatch)


@pytest.mark.slow  # worker processes start and import rodsim: 3-5 s of CPU
def test_resume_after_kill_of_a_two_process_run(tmp_path, monkeypatch, slow_whole):
    """The default path (a pool of worker processes): SIGKILL of the runner leaves no idle
    workers behind (they notice their parent is gone), and a resume with two workers
    completes the study identically to an uninterrupted run."""
    spec = SLOW.spec("small")
    output, workers = kill_mid_study(tmp_path, spec, workers=2)
    if sys.platform == "linux":
        assert len(workers) >= 2, f"expected the pool's workers, found {workers}"
        deadline = time.monotonic() + 3 * rodsim.app.study_runner.PARENT_POLL + 10
        while any(alive(pid) for pid in workers) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(alive(pid) for pid in workers), "workers outlived their runner"
    resume_and_check(spec, output, 2, slow_whole, monkeypatch)


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


@pytest.mark.slow  # worker processes start and import rodsim: 3-5 s of CPU
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

    small = tiny.spec("small")
    other_sweep = dataclasses.replace(small, sweeps=(
        dataclasses.replace(small.sweeps[0], values=(6, 9)),))
    other_scene = dataclasses.replace(tiny, overrides=("rods.catheter.tip_load.mass=0.02",))
    # Each refusal names what differs: a spec key, the sweep entry, the base scene's key.
    for other, named in ((tiny.spec("full"), ["size: 'small' in the parts folder, 'full' now",
                                              "sweeps[0].values"]),
                         (other_sweep, ["sweeps[0].values[1]: 8 in the parts folder, 9 now"]),
                         (spec, ["name: 'runner_test_tiny' in the parts folder, "
                                 "'runner_test' now"]),
                         (other_scene.spec("small"),
                          ["base scene rods.catheter.tip_load.mass: 0.05 in the parts folder, "
                           "0.02 now"])):
        with pytest.raises(StudyError, match="different study definition") as caught:
            run_spec(other, output, workers=1)
        message = str(caught.value)
        assert str(parts) in message
        for text in named:
            assert text in message, message
        assert "\n" not in message
        assert folder_snapshot(parts) == folder, "the parts folder must be left untouched"
        assert output.read_bytes() == archive

    # The parts folder records the rodsim that computed its points; another version's (or
    # an older rodsim's, which recorded none) is refused, naming rodsim_version.
    marker = json.loads((parts / "spec.json").read_text(encoding="utf-8"))
    assert marker["rodsim_version"] == rodsim.__version__
    assert marker["spec"] == tiny.spec("small").to_dict()
    for stored, named in ((marker | {"rodsim_version": "0.0.1"}, "rodsim 0.0.1, this is rodsim"),
                          (marker["spec"], "older rodsim")):
        (parts / "spec.json").write_text(json.dumps(stored), encoding="utf-8")
        with pytest.raises(StudyError, match="rodsim_version differs") as caught:
            run_spec(tiny.spec("small"), output, workers=1)
        assert named in str(caught.value)
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
        StudySpec.from_json(dataset.attrs["spec_json"])))
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
    # A value no point has: the message lists the valid values of that dimension.
    with pytest.raises(StudyError, match="nodes=7: no point has this value; the values of "
                                         "nodes are 6, 11, 21$"):
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
    assert "sigma" in err and "not a swept parameter" in err, err
    assert "the swept values are nodes: 6, 11, 21; mass: 0.02, 0.05" in err, err
    assert "Traceback" not in err

    # A value that is not swept: the valid ones are listed (it printed a Python dict).
    assert cli(["rerun", str(output), "--point", "nodes=22"]) == 2
    err = capsys.readouterr().err
    assert "nodes=22: no point has this value; the values of nodes are 6, 11, 21" in err, err
    assert "{" not in err and len(err.strip().splitlines()) == 1

    # One value per swept parameter: a repeated dimension is refused, not silently dropped.
    assert cli(["rerun", str(output), "--point", "nodes=6", "--point", "nodes=11"]) == 2
    err = capsys.readouterr().err
    assert "--point nodes=… given twice (6 and 11)" in err, err
    assert len(err.strip().splitlines()) == 1

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


# 10. Crashed workers, interrupts, bad outputs, full disks, corrupt points ------------------

#: BASE under another name, so that the fault hook (fault_injection.Faults) can single out
#: its points.
CRASH = dataclasses.replace(BASE, name="runner_test_crash")


def test_a_point_that_kills_its_worker_is_recorded_and_the_study_goes_on(
        study_run, tmp_path, monkeypatch):
    """os._exit in a worker (as a segfault or the OOM killer): the point is recorded as an
    error "worker process died …" — so a resume does not hit it again — and every other
    point completes, in a fresh pool, with the values of an in-process run."""
    dataset, _, _ = study_run
    monkeypatch.setattr(rodsim.app.study_runner, "POINT_HOOK", Faults(f"exit:{CRASH.name}:1-0"))
    output = tmp_path / "crash.nc"
    logged: list[str] = []
    crashed = run_study(CRASH, "small", output, workers=2, log=logged.append, keep_parts=True)

    expected = np.full(crashed["status"].shape, STATUS["ok"])
    expected[1, 0] = STATUS["error"]
    np.testing.assert_array_equal(crashed["status"].values, expected)
    message = str(crashed["message"].values[1, 0])
    assert message.startswith(WORKER_DIED), message
    assert int(crashed.attrs["failed_points"]) == 1
    assert any("[1, 0]" in line and WORKER_DIED in line for line in logged), logged
    dead = crashed.isel(nodes=1, mass=0)
    for name in ("tip", "centerline", "tip_error", "residual", "wall_time"):
        assert np.isnan(dead[name].values).all(), name
    ok = xr.DataArray(expected == STATUS["ok"], dims=("nodes", "mass"))
    for name in ("tip", "centerline", "tip_error", "area_error", "residual", "newton_iters"):
        xr.testing.assert_identical(crashed[name].where(ok), dataset[name].where(ok))

    # The dead point is persisted: a resume (the fault still armed) runs nothing.
    record = json.loads((parts_folder(output) / "point-1-0.json").read_text(encoding="utf-8"))
    assert record["status"] == STATUS["error"] and record["message"] == message
    output.unlink()
    calls = []
    again = run_study(CRASH, "small", output, workers=2, progress=lambda *a: calls.append(a))
    assert [c[0] for c in calls] == [6]
    xr.testing.assert_identical(without_creation(again), without_creation(crashed))


def test_interrupt_cancels_queued_points_and_ends_the_workers(tmp_path, monkeypatch,
                                                               slow_whole):
    """Ctrl-C while points run: return at once — no waiting for running or queued points
    (here they would hang for an hour) — with no worker process left, the finished point
    kept; a resume completes the study as if it had never stopped."""
    spec = SLOW.spec("small")
    points = grid_points(spec)
    monkeypatch.setattr(rodsim.app.study_runner, "POINT_HOOK",
                        Faults(",".join(f"hang:{SLOW.name}:{i}-{j}" for i, j in points[1:])))
    output = tmp_path / "interrupted.nc"

    def interrupt_after_first(done, failed, total, elapsed):
        if done:
            raise KeyboardInterrupt

    def too_slow(signum, frame):
        raise AssertionError("the interrupted study did not stop within 60 s")

    previous = signal.signal(signal.SIGALRM, too_slow)
    signal.alarm(60)
    try:
        start = time.monotonic()
        with pytest.raises(KeyboardInterrupt):
            run_spec(spec, output, workers=2, progress=interrupt_after_first)
        stopped = time.monotonic() - start
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert stopped < 30, stopped
    deadline = time.monotonic() + 10
    while multiprocessing.active_children() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert multiprocessing.active_children() == [], "worker processes outlived the interrupt"
    parts = parts_folder(output)
    assert [p.name for p in parts.glob("point-*.json")] == ["point-0-0.json"]
    assert not output.exists()

    monkeypatch.setattr(rodsim.app.study_runner, "POINT_HOOK", None)
    resumed = run_spec(spec, output, workers=2)
    xr.testing.assert_identical(without_timing(resumed), without_timing(slow_whole))


SIGTERM_CHILD = child_preamble(4) + """\
import rodsim.studies
rodsim.studies.__path__.append(sys.argv[1])
from rodsim.app.cli import main
sys.exit(main(["study", sys.argv[2], "--size", "small", "--workers", "2", "-o", sys.argv[3]]))
"""


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")
def test_cli_study_stops_on_sigterm_like_ctrl_c(tmp_path):
    """`rodsim study` on SIGTERM: exit 130 at once, workers ended, finished points kept and
    the command to resume named."""
    study = dataclasses.replace(SLOW, name="zz_runner_test_sigterm")
    folder = tmp_path / "extra_studies"
    study_module(folder, study)
    output = tmp_path / "out" / "sigterm.nc"
    output.parent.mkdir()
    points = grid_points(study.spec("small"))
    faults = ",".join(f"hang:{study.name}:{i}-{j}" for i, j in points[1:])
    child = subprocess.Popen([sys.executable, "-c", SIGTERM_CHILD, str(folder), study.name,
                              str(output), faults], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not (parts_folder(output) / "point-0-0.json").exists():
            assert child.poll() is None, child.communicate()
            assert time.monotonic() < deadline, "the first point did not finish in 60 s"
            time.sleep(0.01)
        workers = children_of(child.pid)
        assert len(workers) >= 2, workers
        child.send_signal(signal.SIGTERM)
        _, err = child.communicate(timeout=30)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == 130, err
    assert "Traceback" not in err, err
    assert f"finished points are kept in {parts_folder(output)}" in err, err
    assert "rodsim: interrupted" in err, err
    deadline = time.monotonic() + 10
    while any(alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(alive(pid) for pid in workers), "workers outlived the study"
    assert [p.name for p in parts_folder(output).glob("point-*.json")] == ["point-0-0.json"]


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rodsim: error: "), err
    return lines[0]


def test_cli_study_refuses_an_unwritable_output_before_running(registered, tmp_path, cli,
                                                                capsys, monkeypatch):
    calls = []
    monkeypatch.setattr(rodsim.app.study_runner, "evaluate_point",
                        lambda *args: calls.append(args))
    existing = tmp_path / "a folder.nc"
    existing.mkdir()
    cases = {existing: "it is a folder", tmp_path / "missing" / "x.nc": "does not exist"}
    if sys.platform == "linux":  # a pseudo file system: the folder exists, files cannot
        cases[Path("/proc/x.nc")] = "cannot create files in folder '/proc'"
    for output, reason in cases.items():
        code = cli(["study", registered, "--size", "small", "--workers", "1", "-o",
                    str(output)])
        line = one_line_error(capsys)
        assert code == 2 and str(output) in line and reason in line, line
        assert not parts_folder(output).exists()
    assert calls == [], "no point may run for an output that cannot be written"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a folder.nc", "extra_studies"]


def test_a_point_that_cannot_be_saved_stops_the_study_cleanly(tmp_path, spec, study_run,
                                                              monkeypatch):
    """A full disk while saving a point: a StudyError naming the file and the reason, no
    temporary left in the parts folder, the points saved before kept; a resume completes."""
    real_fsync = os.fsync
    synced = []

    def disk_full_after_two(fd):
        synced.append(fd)
        if len(synced) > 2:  # the parts folder's marker and the first point get through
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real_fsync(fd)

    monkeypatch.setattr(rodsim.app.study_runner.os, "fsync", disk_full_after_two)
    output = tmp_path / "full.nc"
    parts = parts_folder(output)
    with pytest.raises(StudyError, match="No space left on device") as caught:
        run_spec(spec, output, workers=1)
    assert str(parts / "point-0-1.json") in str(caught.value)
    assert sorted(p.name for p in parts.iterdir()) == ["point-0-0.json", "spec.json"]
    assert not output.exists()
    monkeypatch.undo()
    resumed = run_spec(spec, output, workers=1)
    xr.testing.assert_identical(without_timing(resumed), without_timing(study_run[0]))


def test_corrupt_point_files_are_reported_and_run_again(tmp_path, spec, study_run,
                                                        monkeypatch):
    output = tmp_path / "corrupt.nc"
    run_spec(spec, output, workers=1, keep_parts=True)
    output.unlink()
    parts = parts_folder(output)
    (parts / "point-0-1.json").write_text("", encoding="utf-8")  # empty
    (parts / "point-2-0.json").write_text('{"index": [2, 0], "status": 0, "mes',
                                          encoding="utf-8")  # cut short
    (parts / "point-1-1.json").write_text(json.dumps({"index": [0, 0], "status": 0,
                                                      "message": "converged"}),
                                          encoding="utf-8")  # another point's record
    calls, logged = [], []

    def recording(spec_, index):
        calls.append(tuple(index))
        return evaluate_point(spec_, index)

    monkeypatch.setattr(rodsim.app.study_runner, "evaluate_point", recording)
    resumed = run_spec(spec, output, workers=1, log=logged.append)
    assert sorted(calls) == [(0, 1), (1, 1), (2, 0)]
    assert len(logged) == 3, logged
    for name, line in zip(("point-0-1.json", "point-1-1.json", "point-2-0.json"), logged,
                          strict=True):
        assert name in line and "runs again" in line, line
    xr.testing.assert_identical(without_timing(resumed), without_timing(study_run[0]))


def test_cli_warns_on_stderr_about_a_corrupt_point(registered, tmp_path, cli, capsys):
    output = tmp_path / "warn.nc"
    run_study(FAILING, "small", output, workers=1, keep_parts=True)
    output.unlink()
    (parts_folder(output) / "point-1-1.json").write_text("{", encoding="utf-8")
    assert cli(["study", registered, "--size", "small", "--workers", "1", "-o",
                str(output)]) == 1
    err = capsys.readouterr().err
    assert "rodsim: warning:" in err and "point-1-1.json" in err and "runs again" in err, err
    np.testing.assert_array_equal(read_dataset(output)["status"].values, FAILING_STATUS)


@pytest.mark.slow  # worker processes start and import rodsim: 3-5 s of CPU
def test_dask_through_a_scheduler_address(study_run, spec, tmp_path, monkeypatch):
    """A LocalCluster started here, reached through its tcp:// address: the Dataset is the
    local run's; a point that kills its dask worker is recorded (KilledWorker) and the
    rest completes."""
    import dask
    from distributed import LocalCluster

    dataset, _, _ = study_run
    # The hook travels with each task to the dask workers (pickled by reference: the tests
    # folder is on the spawned workers' sys.path).
    monkeypatch.setattr(rodsim.app.study_runner, "POINT_HOOK", Faults(f"exit:{CRASH.name}:1-0"))
    # Give up on a task at its first worker death (default: 3 retries, each a worker
    # restart), and send each one-thread worker one task at a time, so that the only task
    # on the dying worker is the point that kills it.
    with dask.config.set({"distributed.scheduler.allowed-failures": 0,
                          "distributed.scheduler.worker-saturation": 1.0,
                          "distributed.comm.timeouts.connect": "120s",
                          "distributed.comm.timeouts.tcp": "120s"}), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                         dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://")
        output = tmp_path / "tcp.nc"
        remote = run_spec(spec, output, scheduler=address)
        assert not parts_folder(output).exists()
        xr.testing.assert_identical(without_timing(remote), without_timing(dataset))
        xr.testing.assert_identical(read_dataset(output), remote)

        logged: list[str] = []
        crashed = run_study(CRASH, "small", tmp_path / "crash.nc", scheduler=address,
                            log=logged.append)
    expected = np.full(crashed["status"].shape, STATUS["ok"])
    expected[1, 0] = STATUS["error"]
    np.testing.assert_array_equal(crashed["status"].values, expected)
    message = str(crashed["message"].values[1, 0])
    assert message.startswith(WORKER_DIED) and "KilledWorker" in message, message
    assert any(WORKER_DIED in line for line in logged), logged


def test_unreachable_scheduler_leaves_nothing_behind(registered, tmp_path, cli, capsys):
    import dask

    output = tmp_path / "out" / "unreachable.nc"
    output.parent.mkdir()
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        code = cli(["study", registered, "--size", "small", "-o", str(output),
                    "--scheduler", "tcp://127.0.0.1:1"])
    line = one_line_error(capsys)
    assert code == 2 and "cannot reach the dask scheduler 'tcp://127.0.0.1:1'" in line, line
    assert list(output.parent.iterdir()) == [], "connect before creating the parts folder"


@pytest.mark.parametrize("workers", ["0", "-2", "two"])
def test_cli_study_workers_must_be_a_positive_whole_number(workers, cli, capsys):
    with pytest.raises(SystemExit) as caught:
        cli(["study", "fig6", "--size", "small", "--workers", workers])
    assert caught.value.code == 2
    err = capsys.readouterr().err
    assert "--workers" in err and "Traceback" not in err, err
    with pytest.raises(StudyError, match="positive whole number"):
        run_spec(BASE.spec("small"), "unused.nc", workers=0)


def test_eta_counts_only_the_points_run_in_this_session():
    from rodsim.app.cli.study import study_status as _study_status

    # 4 points kept from an interrupted run, 2 run here in 10 s, 4 to go: 20 s, not 6.7 s.
    line = _study_status("fig7a", 6, 1, 10, 10.0, 4)
    assert line == ("fig7a: 6/10 done (4 kept from an earlier run), 1 failed, 4 remaining, "
                    "ETA 20 s")
    assert "ETA" not in _study_status("fig7a", 4, 0, 10, 0.0, 4)  # nothing run yet
    assert _study_status("fig7a", 5, 0, 10, 10.0, 0).endswith("5 remaining, ETA 10 s")


def test_cli_plot_refuses_bad_formats_and_folders(study_run, tmp_path, cli, capsys):
    _, archive, _ = study_run
    cases = [(["--format", "xyz"], "unknown figure format 'xyz'"),
             (["--format", "png,XYZ"], "unknown figure format 'xyz'"),
             (["--format", " , "], "no figure format"),
             (["-o", str(tmp_path / "no" / "fig")], "does not exist"),
             (["-o", str(tmp_path) + "/"], "must name a file stem")]
    if sys.platform == "linux":
        cases.append((["-o", "/proc/fig"], "cannot create files in folder '/proc'"))
    for extra, reason in cases:
        code = cli(["plot", str(archive), *extra])
        line = one_line_error(capsys)
        assert code == 2 and reason in line, line
        if "xyz" in extra[-1].lower():  # the message lists what matplotlib writes
            assert "pdf" in line and "png" in line and "svg" in line, line
    assert sorted(p.suffix for p in archive.parent.iterdir()) == [".nc"]
    assert list(tmp_path.iterdir()) == []

    assert cli(["plot", str(archive), "-o", str(tmp_path / "fig"), "--format", "SVG"]) == 0
    assert (tmp_path / "fig.svg").read_text(encoding="utf-8").lstrip().startswith("<?xml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.svg"]


#: No reference: no error variables at all (rather than all-NaN ones "against the None
#: reference"), and the per-step history without its error.
NO_REFERENCE = dataclasses.replace(
    BASE, name="runner_test_no_reference", reference=None, history=True,
    plot="error_vs_parameter",
    sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (6, 11), "1", "N")]})


def test_a_study_without_reference_stores_no_errors(tmp_path, cli, capsys):
    output = tmp_path / "noref.nc"
    ds = run_study(NO_REFERENCE, "small", output, workers=1)
    assert (ds["status"].values == STATUS["ok"]).all()
    for name in ("tip_error", "area_error", "history_error"):
        assert name not in ds, name
    assert "history_tip" in ds and "history_time" in ds
    assert ds.attrs["reference"] == "None"
    assert_units_and_long_names(ds)
    assert not any("None" in str(v.attrs.get("long_name")) for v in ds.variables.values())
    for kind in ("error_vs_parameter", "error_vs_iteration", "centerlines"):
        ds.attrs["plot"] = kind
        path = write_dataset(ds, tmp_path / f"{kind}.nc")
        assert cli(["plot", str(path), "--format", "png"]) == 0, kind
        assert path.with_suffix(".png").stat().st_size > 5000
    assert cli(["rerun", str(output), "--point", "nodes=6"]) == 0
    assert "re-ran 1 point(s), 0 failed" in capsys.readouterr().out
