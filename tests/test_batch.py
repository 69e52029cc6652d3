"""Many equilibria of one scene (issue 35 item 1): ``rodsim.solve_many`` and ``rodsim batch``.

What must hold: a batch gives the equilibria of solving each case alone (``rodsim.solve`` of
the scene with the case's values, its own model built), to round-off; a failing case is
recorded with its message and the others go on; a batch killed part-way resumes without
running its written chunks again; a bad cases table is refused in one line, exit 2,
nothing written; the archive is validated when read. Checked on tdcr-two-segment and on a
seeded family of user robots (not shipped scenes) written from docs/scenes.md.
"""

from __future__ import annotations

import json
import math
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
import rodsim.app.batch
from rodsim.app.batch import solve_chunk, solve_many
from rodsim.app.cli import main
from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with
from rodsim.app.study_parts import parts_folder
from rodsim.app.study_spec import StudyError
from rodsim.core.schema import SceneError
from rodsim.io.archive import read_dataset
from rodsim.io.archive_schema import STATUS, ArchiveSchemaError, check_archive
from rodsim.io.cf_layout import key_variable

TDCR = "tdcr-two-segment"
#: Tensions of three of its tendons and the tip force's z component, drawn per case.
TDCR_KEYS = ("s1a.tendon_string.tension", "s2b.tendon_string.tension",
             "s2c.tendon_string.tension", "tip_load.force[2]")


def tdcr_cases(count: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {TDCR_KEYS[0]: rng.uniform(0.0, 4.0, count),
            TDCR_KEYS[1]: rng.uniform(0.0, 3.0, count),
            TDCR_KEYS[2]: rng.uniform(0.0, 3.0, count),
            TDCR_KEYS[3]: rng.uniform(-0.05, 0.05, count)}


def alone(scene, cases: dict, case: int) -> rodsim.Result:
    """Case ``case`` solved by itself: its own scene, its own model, from rest."""
    base = rodsim.load_scene(scene)
    keys = numeric_keys(base, list(cases))
    row = np.array([np.asarray(column, dtype=float)[case] for column in cases.values()])
    return rodsim.solve(scene_with(base, keys, row), "static")


def positions(result: rodsim.Result) -> np.ndarray:
    return np.concatenate([rod.positions for rod in result.rods.values()])


def assert_matches_alone(scene, cases: dict, batch: xr.Dataset, length: float) -> None:
    """Every case of ``batch`` is the one-by-one solve: same verdict and message, the same
    equilibrium to round-off (1e-12 L), the same stability verdict."""
    for case in range(batch.sizes["case"]):
        result = alone(scene, cases, case)
        assert bool(batch["status"].values[case] == STATUS["ok"]) == result.success
        assert str(batch["message"].values[case]) == result.message
        if not result.success:
            assert np.isnan(batch["position"].values[case]).all()
            continue
        gap = np.max(np.abs(batch["position"].values[case] - positions(result)))
        assert gap <= 1e-12 * length, (case, gap)
        assert batch["stable"].values[case] == int(result.stability.stable)


@pytest.fixture(scope="module")
def tdcr_batch() -> tuple[dict, xr.Dataset]:
    cases = tdcr_cases(50, seed=35)
    return cases, solve_many(TDCR, cases, chunk=20)


def test_batch_of_fifty_tdcr_cases_is_each_case_solved_alone(tdcr_batch):
    cases, batch = tdcr_batch
    assert batch.sizes["case"] == 50 and batch.attrs["kind"] == "batch"
    assert (batch["status"].values == STATUS["ok"]).all(), batch["message"].values
    full = json.loads(batch.attrs["case_keys"])  # every case's values beside its equilibrium
    for key, name in zip(TDCR_KEYS, full, strict=True):
        assert name.endswith(key)
        assert np.array_equal(key_variable(batch, name).values, cases[key])
    assert_matches_alone(TDCR, cases, batch, 0.4)
    # The tips are spread: the cases are not one shape repeated.
    tips = batch["position"].values[:, -1]
    assert np.ptp(tips, axis=0).max() > 0.05


def test_two_worker_processes_give_the_same_archive(tdcr_batch, tmp_path):
    cases, batch = tdcr_batch
    two = solve_many(TDCR, cases, chunk=20, workers=2, output=tmp_path / "two.nc")
    assert np.array_equal(two["position"].values, batch["position"].values)
    assert np.array_equal(two["status"].values, batch["status"].values)
    stored = read_dataset(tmp_path / "two.nc")  # validated on read (kind "batch")
    assert np.array_equal(stored["position"].values, batch["position"].values)
    assert not parts_folder(tmp_path / "two.nc").exists()


@pytest.mark.slow  # a LocalCluster starts fresh worker processes that import rodsim
def test_a_dask_local_cluster_gives_the_same_archive(tdcr_batch, tmp_path):
    pytest.importorskip("distributed")
    cases, batch = tdcr_batch
    few = {key: values[:12] for key, values in cases.items()}
    dask = solve_many(TDCR, few, chunk=5, workers=2, scheduler="local",
                      output=tmp_path / "dask.nc")
    assert np.array_equal(dask["position"].values, batch["position"].values[:12])
    assert not parts_folder(tmp_path / "dask.nc").exists()


def dying_chunk(job, start, end):
    """A chunk whose worker process dies (as a segfault or the OOM killer would end it)."""
    if start == 5:
        os._exit(3)
    return solve_chunk(job, start, end)


def test_a_chunk_whose_worker_dies_is_recorded_and_the_rest_goes_on(tdcr_batch,
                                                                     monkeypatch):
    cases, batch = tdcr_batch
    few = {key: values[:15] for key, values in cases.items()}
    monkeypatch.setattr(rodsim.app.batch, "solve_chunk", dying_chunk)
    heard = []
    out = solve_many(TDCR, few, chunk=5, workers=2, log=heard.append)
    dead = slice(5, 10)
    assert (out["status"].values[dead] == STATUS["error"]).all()
    assert all(str(m).startswith("worker process died") for m in out["message"].values[dead])
    assert np.isnan(out["position"].values[dead]).all()
    alive = np.r_[0:5, 10:15]
    assert (out["status"].values[alive] == STATUS["ok"]).all()
    assert np.array_equal(out["position"].values[alive], batch["position"].values[alive])
    assert out.attrs["failed_cases"] == 5


def test_inputs_as_a_dataframe_and_an_xarray_dataset(tdcr_batch):
    pandas = pytest.importorskip("pandas")
    cases, batch = tdcr_batch
    few = {key: values[:3] for key, values in cases.items()}
    frame = solve_many(TDCR, pandas.DataFrame(few))
    table = solve_many(TDCR, xr.Dataset({k: ("row", v) for k, v in few.items()}))
    for other in (frame, table):
        assert np.array_equal(other["position"].values, batch["position"].values[:3])


def test_a_failing_case_is_recorded_and_the_others_go_on():
    """A 10 kN tendon tension on tdcr-two-segment has no equilibrium static can reach (its
    load steps fall below min_load_step): that case fails with the solver's message; the
    cases beside it (and one changing a rule across tables, the radius) are the one-by-one
    solves. (A radius of 0.3 m served here until static learnt to solve loads below the
    residual floor: it now gives the fat rod's 2.5e-7 m sag.)"""
    cases = {"radius": [0.0007, 0.0007, 0.0008],
             "s1a.tendon_string.tension": [3.0, 1e4, 1.0]}
    batch = solve_many(TDCR, cases)
    assert list(batch["status"].values) == [STATUS["ok"], STATUS["solver_failure"],
                                            STATUS["ok"]]
    assert "did not converge" in str(batch["message"].values[1])
    assert batch.attrs["failed_cases"] == 1
    assert_matches_alone(TDCR, cases, batch, 0.4)


# A killed batch resumes ------------------------------------------------------------------

KILLABLE = """\
import json, sys
import numpy as np
from rodsim.app.batch import solve_many
cases = {k: np.array(v) for k, v in json.loads(open(sys.argv[1]).read()).items()}
solve_many("tdcr-two-segment", cases, output=sys.argv[2], chunk=4)
"""


def chunk_files(folder: Path) -> dict[str, tuple[str, int]]:
    return {p.name: (p.read_text(), p.stat().st_mtime_ns)
            for p in sorted(folder.glob("chunk-*.json"))}


@pytest.mark.slow  # a child process, killed, then the whole batch twice: 13 s
def test_a_killed_batch_resumes_without_recomputing_what_it_wrote(tmp_path, monkeypatch):
    cases = tdcr_cases(40, seed=7)
    (tmp_path / "cases.json").write_text(json.dumps({k: v.tolist() for k, v in cases.items()}))
    output = tmp_path / "out" / "batch.nc"
    output.parent.mkdir()
    parts = parts_folder(output)
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).parents[1]), OMP_NUM_THREADS="1")
    with (tmp_path / "child.log").open("w") as log:
        child = subprocess.Popen([sys.executable, "-c", KILLABLE, str(tmp_path / "cases.json"),
                                  str(output)], stdout=log, stderr=subprocess.STDOUT, env=env)
        try:
            deadline = time.monotonic() + 120
            while len(list(parts.glob("chunk-*.json"))) < 2:
                assert child.poll() is None, (tmp_path / "child.log").read_text()
                assert time.monotonic() < deadline, "no chunk written within 120 s"
                time.sleep(0.005)
            os.kill(child.pid, signal.SIGKILL)
            assert child.wait(timeout=30) == -signal.SIGKILL
        finally:
            if child.poll() is None:
                child.kill()
                child.wait()
    before = chunk_files(parts)
    assert 2 <= len(before) < 10, sorted(before)
    assert not output.exists()
    kept = {json.loads(text)["start"] for text, _ in before.values()}

    calls = []

    def recording(job, start, end):
        calls.append(start)
        return solve_chunk(job, start, end)

    monkeypatch.setattr(rodsim.app.batch, "solve_chunk", recording)
    progress = []
    resumed = solve_many(TDCR, cases, output=output, chunk=4, keep_parts=True,
                         progress=lambda *a: progress.append(a))
    assert sorted(calls) == sorted(set(range(0, 40, 4)) - kept), "written chunks ran again"
    assert progress[0][:3] == (4 * len(kept), 0, 40)
    after = chunk_files(parts)
    for name, stored in before.items():
        assert after[name] == stored, f"{name} was rewritten on resume"
    whole = solve_many(TDCR, cases, chunk=4)
    assert np.array_equal(resumed["position"].values, whole["position"].values)
    # A complete parts folder: nothing runs, the archive is written, the folder removed.
    calls.clear()
    again = solve_many(TDCR, cases, output=output, chunk=4)
    assert calls == [] and not parts.exists()
    assert np.array_equal(again["position"].values, whole["position"].values)
    # Other cases in the same place: refused, naming what differs.
    solve_many(TDCR, {k: v[:8] for k, v in cases.items()}, output=output, chunk=4,
               keep_parts=True)
    with pytest.raises(StudyError, match="different batch definition"):
        solve_many(TDCR, {k: v[:8] + 0.1 for k, v in cases.items()}, output=output, chunk=4)


def test_corrupt_chunk_files_are_reported_and_run_again(tdcr_batch, tmp_path, monkeypatch):
    """A chunk file cut short, one whose positions hold a NaN and one of another chunk's
    cases are each reported and their cases run again; the archive is the uninterrupted
    one's."""
    cases, batch = tdcr_batch
    few = {key: values[:15] for key, values in cases.items()}
    output = tmp_path / "b.nc"
    solve_many(TDCR, few, output=output, chunk=5, keep_parts=True)
    parts = parts_folder(output)
    first, second, third = sorted(parts.glob("chunk-*.json"))
    first.write_text(first.read_text()[:100])
    record = json.loads(second.read_text())
    record["cases"][2]["position"][3][1] = float("nan")
    second.write_text(json.dumps(record))
    record = json.loads(third.read_text())
    record["start"], record["end"] = 0, 5
    third.write_text(json.dumps(record))
    calls, heard = [], []

    def recording(job, start, end):
        calls.append(start)
        return solve_chunk(job, start, end)

    monkeypatch.setattr(rodsim.app.batch, "solve_chunk", recording)
    again = solve_many(TDCR, few, output=output, chunk=5, log=heard.append)
    assert sorted(calls) == [0, 5, 10]
    assert len(heard) == 3 and all("its cases run again" in line for line in heard), heard
    assert np.array_equal(again["position"].values, batch["position"].values[:15])


# Bad input --------------------------------------------------------------------------------


@pytest.mark.parametrize(("text", "words"), [
    ("nodes\n30\n", "changes the discretisation"),            # a key that is not numeric
    ("name\n3\n", "not a numeric model parameter"),
    ("s1a.tendon_string.tension\n1\nabc\n", "case 1 is 'abc', not a number"),
    ("s1a.tendon_string.tension,radius\n1,\n", "case 0 has no value"),
    ("s1a.tendon_string.tension\n1\nnan\n", "no value (NaN)"),
    ("s1a.tendon_string.tension\n-2\n", "case 0: tendons.s1a.tendon_string.tension = -2 is "
                                        "out of range"),
    ("radius\n0.0007\n0.5\n", "case 1"),                     # a rule across tables
    ("s1a.tendon_string.tension\n", "empty"),
    ("", "empty"),
    ("s1a.tendon_string.tension\n1,2\n", "row 2: 2 values for 1 columns"),
])
def test_bad_cases_table_one_line_exit_2_nothing_written(tmp_path, monkeypatch, capsys, text,
                                                         words):
    monkeypatch.chdir(tmp_path)
    Path("cases.csv").write_text(text)
    assert main(["batch", TDCR, "--cases", "cases.csv", "-o", "out.nc", "--workers", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err, err
    assert sorted(os.listdir(tmp_path)) == ["cases.csv"]


def test_a_cases_path_that_is_not_a_regular_file_is_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    os.mkfifo("fifo.csv")
    os.mkdir("folder.csv")
    for path, words in (("fifo.csv", "not a regular file"), ("folder.csv", "a folder"),
                        ("missing.csv", "no such file")):
        assert main(["batch", TDCR, "--cases", path]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err, err
    assert sorted(os.listdir(tmp_path)) == ["fifo.csv", "folder.csv"]


def test_python_callers_get_scene_errors():
    with pytest.raises(SceneError, match="same number of values"):
        solve_many(TDCR, {"s1a.tendon_string.tension": [1.0, 2.0], "radius": [0.0007]})
    with pytest.raises(SceneError, match="no value"):
        solve_many(TDCR, {"s1a.tendon_string.tension": [1.0, None]})
    with pytest.raises(SceneError, match="must map scene keys"):
        solve_many(TDCR, [1.0, 2.0])
    with pytest.raises(SceneError, match="name no scene key"):
        solve_many(TDCR, {})


def test_cli_batch_writes_a_validated_archive(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    Path("cases.csv").write_text("\ufeffs1a.tendon_string.tension,tip_load.force[2]\n"
                                 "1.0,-0.01\n2.5,0.02\n")
    assert main(["batch", TDCR, "--cases", "cases.csv", "-o", "b.nc", "--workers", "1"]) == 0
    out = capsys.readouterr()
    assert "2 cases, 0 failed" in out.out and "2/2 done" in out.err
    stored = read_dataset("b.nc")
    assert json.loads(stored.attrs["case_keys"]) == ["tendons.s1a.tendon_string.tension",
                                                     "rods.backbone.tip_load.force[2]"]
    cases = {"s1a.tendon_string.tension": [1.0, 2.5], "tip_load.force[2]": [-0.01, 0.02]}
    assert_matches_alone(TDCR, cases, stored, 0.4)
    broken = stored.drop_vars(next(v for v in stored.data_vars
                                   if stored[v].attrs.get("scene_key") ==
                                   "tendons.s1a.tendon_string.tension"))
    with pytest.raises(ArchiveSchemaError, match="case key"):
        check_archive(broken)
    # rerun re-solves every case from the archive alone; plot says it draws none.
    assert main(["rerun", "b.nc"]) == 0
    assert "largest difference from the stored positions: 0 m" in capsys.readouterr().out
    assert main(["plot", "b.nc"]) == 2
    assert "batch archive has no figure" in capsys.readouterr().err
    assert "penalty_error" not in stored and stored.attrs["penalty_estimates"] == 0


def test_cli_batch_penalty_stores_each_cases_estimate(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    Path("cases.csv").write_text("s1a.tendon_string.tension\n1.0\n2.5\n")
    assert main(["batch", TDCR, "--cases", "cases.csv", "-o", "b.nc", "--workers", "1",
                 "--penalty"]) == 0
    stored = read_dataset("b.nc")
    assert stored.attrs["penalty_estimates"] == 1
    expected = [rodsim.penalty_error(alone(TDCR, {"s1a.tendon_string.tension": [1.0, 2.5]},
                                           case)).error for case in range(2)]
    assert list(stored["penalty_error"].values) == expected
    # rerun asks for the estimates again (the archive says it holds them) and matches
    assert main(["rerun", "b.nc"]) == 0
    assert "largest difference from the stored positions: 0 m" in capsys.readouterr().out
    with pytest.raises(ArchiveSchemaError, match="penalty_error"):
        check_archive(stored.drop_vars("penalty_error"))


# A seeded family of user robots -------------------------------------------------------------


def user_robot(rng: np.random.Generator, index: int) -> tuple[dict, dict, float]:
    """A robot as a user would write it from docs/scenes.md, and a few cases of its
    actuation: a steel or nitinol wire with a tip load of mN to N, or a soft polymer
    catheter with two string tendons (their tensions varied, and the tip load)."""
    kind = index % 3
    length = rng.uniform(0.08, 0.5)
    count = 6
    if kind < 2:  # a wire: steel (200 GPa) or nitinol (54 GPa), loaded at the tip
        radius = rng.uniform(2e-4, 1e-3)
        young = 200e9 if kind == 0 else 54e9
        bending = young * math.pi * radius**4 / 4
        scale = bending / length**2  # the tip force of a bend of about one radian
        robot = {"name": f"wire-{index}", "rods": {"wire": {
            "length": length, "radius": radius, "youngs_modulus": young, "density": 7900.0,
            "nodes": int(rng.integers(12, 30)), "terms": ["stretch", "bend_twist",
                                                          "centerline", "tip_load"],
            "tip_load": {"force": [0.0, 0.0, -scale]}}}}
        cases = {"tip_load.force[1]": rng.uniform(-1.5, 1.5, count) * scale,
                 "tip_load.force[2]": rng.uniform(-1.5, 1.5, count) * scale}
        return robot, cases, length
    radius = rng.uniform(1e-3, 4e-3)
    young = 10.0 ** rng.uniform(6.5, 8.0)  # a soft polymer, 3 MPa to 100 MPa
    bending = young * math.pi * radius**4 / 4
    offset = 0.6 * radius
    pull = bending / (offset * length)  # the tension of a one-radian bend
    robot = {"name": f"catheter-{index}", "rods": {"catheter": {
        "length": length, "radius": radius, "youngs_modulus": young, "density": 1200.0,
        "nodes": int(rng.integers(15, 30))}}, "tendons": {
        "left": {"catheter": "catheter", "offset": offset, "direction": [1.0, 0.0],
                 "tendon_actuation": {"force": pull}},
        "up": {"catheter": "catheter", "offset": offset, "direction": [0.0, 1.0],
               "tendon_actuation": {"force": pull}}}}
    cases = {"left.tendon_string.tension": rng.uniform(0.0, 2.0, count) * pull,
             "up.tendon_string.tension": rng.uniform(0.0, 2.0, count) * pull,
             "youngs_modulus": young * rng.uniform(0.7, 1.4, count)}
    return robot, cases, length


def test_a_seeded_family_of_user_robots_as_batches():
    rng = np.random.default_rng(3535)
    for index in range(6):
        robot, cases, length = user_robot(rng, index)
        batch = solve_many(robot, cases, chunk=4)
        assert (batch["status"].values == STATUS["ok"]).sum() >= 5, batch["message"].values
        assert_matches_alone(robot, cases, batch, length)


def test_each_case_carries_the_penalty_estimate_rodsim_run_makes(tmp_path):
    """``penalty=True``: each case's ``penalty_error`` is ``rodsim.penalty_error`` of the case
    solved alone (what ``rodsim run`` prints), bit for bit, cold and warm; the equilibria are
    those of the batch without it, bit for bit; the archive says it holds them."""
    cases = tdcr_cases(6, seed=11)
    plain = solve_many(TDCR, cases, chunk=4)
    batch = solve_many(TDCR, cases, chunk=4, penalty=True, output=tmp_path / "b.nc")
    check_archive(read_dataset(tmp_path / "b.nc"))
    assert batch.attrs["penalty_estimates"] == 1 and plain.attrs["penalty_estimates"] == 0
    assert "penalty_error" not in plain
    assert np.array_equal(batch["position"].values, plain["position"].values)
    for case in range(6):
        expected = rodsim.penalty_error(alone(TDCR, cases, case)).error
        assert 0.0 < expected < 1e-3
        assert batch["penalty_error"].values[case] == expected, case
    # Two worker processes (each builds its own stiffer model) give the same estimates.
    pooled = solve_many(TDCR, cases, chunk=2, workers=2, penalty=True)
    assert np.array_equal(pooled["penalty_error"].values, batch["penalty_error"].values)
    warm = solve_many(TDCR, cases, penalty=True, warm=True)
    # A warm case's equilibrium differs from the cold one within the solver's stopping test
    # (docs/batch.md, "Warm starts"), so its estimate agrees to that resolution only.
    assert np.allclose(warm["penalty_error"].values, batch["penalty_error"].values,
                       rtol=1e-3, atol=1e-9)



def test_penalty_estimates_of_failed_cases_and_of_a_penalty_key():
    """A failed case has no estimate (NaN); a case key that is itself a penalty constant
    (K_P) gets the estimate of its own stiffer scene, still ``rodsim.penalty_error``'s."""
    cases = {"centerline.K_P": [3.2e4, 3.2e4, 1e4],
             "s1a.tendon_string.tension": [3.0, 1e4, 1.0]}
    batch = solve_many(TDCR, cases, penalty=True)
    assert list(batch["status"].values) == [STATUS["ok"], STATUS["solver_failure"],
                                            STATUS["ok"]]
    assert np.isnan(batch["penalty_error"].values[1])
    for case in (0, 2):
        expected = rodsim.penalty_error(alone(TDCR, cases, case)).error
        assert batch["penalty_error"].values[case] == expected, case
    # the softer centerline penalty has the larger penalty error
    assert batch["penalty_error"].values[2] > batch["penalty_error"].values[0]
