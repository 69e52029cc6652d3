"""Study runs that stop or resume from bad files (issue 15, items 7 and 8): worker processes
end without tracebacks when a parallel study stops, and point files that are valid JSON
but wrong (a missing statistic, a residual that is text, a tip of length 2, an unknown rod,
a NaN in a centerline) are re-run with a warning rather than trusted or crashing the
resume; a parts folder whose spec.json holds no spec is refused in one line."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from fault_injection import child_preamble

import rodsim.app.study_runner
import rodsim.studies
from rodsim.app.study import STATUS, Study, Sweep, evaluate_point
from rodsim.app.study_runner import parts_folder, run_spec, run_study
from rodsim.io.archive import read_dataset

#: Three quick points (static, N = 6–8).
TRIO = Study(name="zz_hardening_trio", title="three points", paper="tests only",
             scene="table1-50g", integrator="static", reference="exact",
             sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (6, 7, 8), "1", "N")]})

# argv: studies folder, study, output, faults (fault_injection.Faults; "" for none).
CHILD = child_preamble(4) + """\
import rodsim.studies
rodsim.studies.__path__.append(sys.argv[1])
from rodsim.app.cli import main
sys.exit(main(["study", sys.argv[2], "--size", "small", "--workers", "2", "-o", sys.argv[3]]))
"""


def register(folder: Path, study: Study) -> None:
    folder.mkdir(exist_ok=True)
    (folder / f"{study.name}.py").write_text(
        f"from rodsim.app.study import Study, Sweep\n\nSTUDY = {study!r}\n", encoding="utf-8")


@pytest.mark.slow
def test_stopping_a_parallel_study_prints_no_worker_traceback(tmp_path):
    """Item 7: SIGTERM when the last point runs on one worker and the other is idle: the
    idle worker inherited the study's SIGTERM → KeyboardInterrupt handler and printed
    "Process ForkProcess-2: Traceback … KeyboardInterrupt"."""
    folder = tmp_path / "studies"
    register(folder, TRIO)
    output = tmp_path / "trio.nc"
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(folder), TRIO.name,
                              str(output), f"hang:{TRIO.name}:2"], cwd=tmp_path,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        parts = parts_folder(output)
        while len(list(parts.glob("point-*.json"))) < 2:
            assert child.poll() is None, child.communicate()
            assert time.monotonic() < deadline, "the two quick points did not finish"
            time.sleep(0.01)
        time.sleep(0.3)  # the idle worker is back waiting for work
        child.send_signal(signal.SIGTERM)
        _, err = child.communicate(timeout=30)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert "rodsim: interrupted" in err


@pytest.mark.skipif(not hasattr(__import__("resource"), "RLIMIT_FSIZE"),
                    reason="needs RLIMIT_FSIZE")
@pytest.mark.slow
def test_a_file_size_limit_stops_the_study_in_one_line(tmp_path):
    """Item 7: `(ulimit -f 4; rodsim study …)`: a point cannot be saved, the study stops
    with one error line and its workers end without tracebacks."""
    import resource

    folder = tmp_path / "studies"
    register(folder, TRIO)
    output = tmp_path / "limited.nc"

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)

    child = subprocess.run([sys.executable, "-c", CHILD, str(folder), TRIO.name,
                            str(output), ""], preexec_fn=limit, cwd=tmp_path,
                           capture_output=True, text=True, timeout=120)
    lines = [line for line in child.stderr.splitlines() if not line.startswith("[")]
    assert child.returncode == 2, child.stderr
    assert len(lines) == 1 and "File too large" in lines[0], child.stderr
    assert "Traceback" not in child.stderr


@pytest.fixture(scope="module")
def trio_parts(tmp_path_factory):
    """TRIO run in-process with its parts kept: (spec, output, the clean Dataset)."""
    output = tmp_path_factory.mktemp("trio") / "trio.nc"
    spec = TRIO.spec("small")
    dataset = run_spec(spec, output, workers=1, keep_parts=True)
    return spec, output, dataset


def edit_point(path: Path, edit) -> None:
    record = json.loads(path.read_text(encoding="utf-8"))
    edit(record)
    path.write_text(json.dumps(record), encoding="utf-8")


BAD_POINTS = {
    "missing stats key": lambda r: r["stats"].pop("newton_iters"),
    "residual is text": lambda r: r.__setitem__("residual", "abc"),
    "tip of length 2": lambda r: r["tip"].__setitem__("catheter", r["tip"]["catheter"][:2]),
    "unknown rod": lambda r: r["tip"].__setitem__("ghost", r["tip"].pop("catheter")),
    "NaN in the centerline": lambda r: r["centerline"]["catheter"][3].__setitem__(
        1, float("nan")),
    "not an object": lambda r: r.clear(),
    "index holds a list (found by the fuzz suite)": lambda r: r["index"].__setitem__(0, []),
}


@pytest.mark.parametrize("case", BAD_POINTS)
def test_a_valid_json_point_with_wrong_contents_runs_again(case, trio_parts, tmp_path,
                                                           monkeypatch):
    """Item 8: each edit made the resume crash (or, for the NaN, assembled it as "ok")."""
    spec, source, clean = trio_parts
    output = tmp_path / "resumed.nc"
    parts = parts_folder(output)
    parts.mkdir()
    for path in parts_folder(source).iterdir():
        (parts / path.name).write_bytes(path.read_bytes())
    if case == "not an object":
        (parts / "point-1.json").write_text("[]", encoding="utf-8")
    else:
        edit_point(parts / "point-1.json", BAD_POINTS[case])
    calls, logged = [], []

    def recording(spec_, index):
        calls.append(tuple(index))
        return evaluate_point(spec_, index)

    monkeypatch.setattr(rodsim.app.study_runner, "evaluate_point", recording)
    resumed = run_spec(spec, output, workers=1, log=logged.append)
    assert calls == [(1,)]
    assert len(logged) == 1 and "point-1.json" in logged[0] and "runs again" in logged[0]
    assert int(resumed["status"].values[1]) == STATUS["ok"]
    np.testing.assert_array_equal(resumed["centerline"].values, clean["centerline"].values)


MARKER_EDITS = {
    "spec is a list": lambda marker: json.dumps(marker | {"spec": []}),
    # Found by the fuzz suite:
    "nested too deeply": lambda marker: "[" * 100_000 + "]" * 100_000,
}


@pytest.mark.parametrize("case", MARKER_EDITS)
def test_a_parts_folder_whose_marker_holds_no_spec_is_refused(case, trio_parts, tmp_path,
                                                              cli, capsys, monkeypatch):
    """Item 8's fifth edit: `"spec": []` in spec.json made the resume crash."""
    folder = tmp_path / "studies"
    register(folder, TRIO)
    monkeypatch.setattr(rodsim.studies, "__path__", [*rodsim.studies.__path__, str(folder)])
    output = tmp_path / "marker.nc"
    parts = parts_folder(output)
    parts.mkdir()
    marker = json.loads((parts_folder(trio_parts[1]) / "spec.json").read_text("utf-8"))
    (parts / "spec.json").write_text(MARKER_EDITS[case](marker), encoding="utf-8")
    assert cli(["study", TRIO.name, "--size", "small", "--workers", "1", "-o",
                str(output)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "spec.json" in err[0] and "Traceback" not in err[0], err
    assert not output.exists()


def test_a_marker_with_a_git_commit_that_is_not_text_resumes(trio_parts, tmp_path):
    """Found by the fuzz suite: `"git_commit": {"": null}` in spec.json crashed the resume
    (it slices the commit for a note); it is not a commit, so no note, and the points are
    kept."""
    spec, source, clean = trio_parts
    output = tmp_path / "commit.nc"
    parts = parts_folder(output)
    parts.mkdir()
    for path in parts_folder(source).iterdir():
        (parts / path.name).write_bytes(path.read_bytes())
    marker = json.loads((parts / "spec.json").read_text("utf-8"))
    (parts / "spec.json").write_text(json.dumps(marker | {"git_commit": {"": None}}),
                                     encoding="utf-8")
    logged: list[str] = []
    resumed = run_spec(spec, output, workers=1, log=logged.append)
    assert logged == []
    np.testing.assert_array_equal(resumed["centerline"].values, clean["centerline"].values)


def test_cli_resume_warns_and_completes(trio_parts, tmp_path, cli, capsys, monkeypatch):
    """Through the CLI: the warning on stderr, and the archive equals the clean run's."""
    folder = tmp_path / "studies"
    register(folder, TRIO)
    monkeypatch.setattr(rodsim.studies, "__path__", [*rodsim.studies.__path__, str(folder)])
    output = tmp_path / "cli.nc"
    parts = parts_folder(output)
    parts.mkdir()
    for path in parts_folder(trio_parts[1]).iterdir():
        (parts / path.name).write_bytes(path.read_bytes())
    edit_point(parts / "point-0.json", BAD_POINTS["NaN in the centerline"])
    assert cli(["study", TRIO.name, "--size", "small", "--workers", "1", "-o",
                str(output)]) == 0
    err = capsys.readouterr().err
    assert "rodsim: warning:" in err and "point-0.json" in err and "Traceback" not in err
    np.testing.assert_array_equal(read_dataset(output)["centerline"].values,
                                  trio_parts[2]["centerline"].values)


def test_run_study_in_process_still_matches(trio_parts, tmp_path):
    """The validation accepts every record rodsim writes: a resume from an intact parts
    folder runs nothing and assembles the same archive."""
    spec, source, clean = trio_parts
    output = tmp_path / "intact.nc"
    parts = parts_folder(output)
    parts.mkdir()
    for path in parts_folder(source).iterdir():
        (parts / path.name).write_bytes(path.read_bytes())
    calls = []
    resumed = run_study(TRIO, "small", output, workers=1,
                        progress=lambda *args: calls.append(args))
    assert [c[0] for c in calls] == [3]
    np.testing.assert_array_equal(resumed["centerline"].values, clean["centerline"].values)


def test_a_scheduler_without_workers_is_a_clear_failure(tmp_path):
    """`study --scheduler tcp://…` with no worker waited forever, silently. A scheduler that
    has had no worker for `worker_timeout` seconds while points wait fails the study with
    one line, and the parts folder stays for a resume."""
    import dask
    from distributed import LocalCluster

    from rodsim.app.study import StudyError

    with dask.config.set({"distributed.comm.timeouts.connect": "30s"}), \
            LocalCluster(n_workers=0, dashboard_address=":0") as cluster:
        with pytest.raises(StudyError, match="no worker for 2 s"):
            run_study(TRIO, "small", tmp_path / "alone.nc", scheduler=cluster.scheduler_address,
                      worker_timeout=2.0)
    assert not (tmp_path / "alone.nc").exists()


def test_every_study_point_carries_its_stability_verdict(tmp_path):
    """A study's points say whether their equilibrium is stable (issue 23): table1-50g's rod
    pushed along its axis by 2 N is below its Euler load π²EI/(4L²) with E = 59 MPa
    (10.3 N) and far above it with the scene's 5.9 MPa (1.03 N; both computed here
    independently) — static stays on the straight, unstable branch there, which the archive
    must flag, not pass as a plain result."""
    from rodsim.app.study import Study, Sweep
    from rodsim.app.study_runner import run_study

    def euler_load(modulus: float) -> float:
        return np.pi**2 * modulus * np.pi * 0.006**4 / 4 / (4 * 0.12**2)

    assert euler_load(5.9e6) < 2.0 < euler_load(5.9e7)
    study = Study(name="stability_test", title="push", paper="tests only",
                  scene="table1-50g", integrator="static", reference=None,
                  overrides=("tip_load.mass=0", "nodes=20", "tip_load.force=[-2.0, 0.0, 0.0]"),
                  sweeps={"small": [Sweep("E", "rods.catheter.youngs_modulus", (5.9e7, 5.9e6),
                                          "Pa", "Young's modulus")]})
    ds = run_study(study, "small", tmp_path / "push.nc", workers=1)
    assert ds["status"].values.tolist() == [0, 0]
    assert ds["stable"].values.tolist() == [1.0, 0.0]
    eigenvalues = ds["stiffness_min_eigenvalue"].values
    assert np.isnan(eigenvalues[0]) and eigenvalues[1] < 0.0
