"""Warm-started batches (``rodsim.solve_many(..., warm=True)``, rodsim/app/batch_warm.py).

What must hold: every case is the equilibrium ``rodsim.solve`` finds for it alone, to the
round-off of the equilibrium (both are Newton roots polished until a step no longer halves
the residual; on tdcr-two-segment states whose force residual is at its floor, ~5e-11,
lie up to ~3e-10 m apart, so the bound is 5e-9 L = 2e-9 m), with the same status and
stability verdict; the answer depends on the cases table alone, bit for bit, not on the
chunk size, the workers or a resume; a failing case is recorded and the cases after it
go on; the warm starts take fewer Newton iterations than the solves from rest.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import rodsim.app.batch
from rodsim.app.batch import rerun_batch, solve_chunk, solve_many
from rodsim.app.batch_warm import SEGMENT, solve_order
from rodsim.app.cli import main
from rodsim.app.study_parts import parts_folder
from rodsim.app.study_spec import StudyError
from rodsim.io.archive import read_dataset
from rodsim.io.archive_schema import STATUS
from tests.test_batch import TDCR, TDCR_KEYS, alone, positions, tdcr_cases

#: Largest distance [m] of a warm case from the case solved alone (module docstring).
WARM_GAP = 5e-9 * 0.4
CASES = 60


@pytest.fixture(scope="module")
def batches() -> tuple[dict, xr.Dataset, xr.Dataset]:
    cases = tdcr_cases(CASES, seed=35)
    return cases, solve_many(TDCR, cases), solve_many(TDCR, cases, warm=True)


def test_the_solve_order_is_a_greedy_nearest_neighbour_path():
    # From case 0 (4): 2 and 6 are as near, the lower case (3) goes first; then 0, 6, 8.
    # The second key has one value and is left out.
    values = np.array([[4.0, 2.0], [0.0, 2.0], [8.0, 2.0], [2.0, 2.0], [6.0, 2.0]])
    assert solve_order(values).tolist() == [0, 3, 1, 4, 2]
    table = np.random.default_rng(3).uniform(size=(300, 4))
    order = solve_order(table)
    assert sorted(order.tolist()) == list(range(300)) and order[0] == 0
    steps = np.linalg.norm(np.diff(table[order], axis=0), axis=1)
    assert np.median(steps) < 0.5 * np.median(np.linalg.norm(np.diff(table, axis=0), axis=1))


def test_warm_cases_are_the_cases_solved_alone_to_round_off(batches):
    cases, cold, warm = batches
    assert warm.attrs["warm_starts"] == 1 and cold.attrs["warm_starts"] == 0
    assert (warm["status"].values == STATUS["ok"]).all(), warm["message"].values
    assert np.array_equal(warm["stable"].values, cold["stable"].values)
    # The cold batch is each case alone (tests/test_batch.py); a sample checked here too.
    gap = np.abs(warm["position"].values - cold["position"].values).max()
    assert gap <= WARM_GAP, gap
    assert np.max(warm["residual"].values) < float(warm.attrs["solver_tolerance"])
    for case in (0, 1, 17, 40):
        result = alone(TDCR, cases, case)
        assert np.max(np.abs(warm["position"].values[case] - positions(result))) <= WARM_GAP
    # Warm starts are the point: far fewer Newton iterations than from rest (measured
    # 4.0 against 7.2 a case).
    assert warm["newton_iters"].values.sum() < 0.8 * cold["newton_iters"].values.sum()
    assert sum("warm start" in str(m) for m in warm["message"].values) >= CASES - 2 * (
        CASES // SEGMENT + 1)


def test_warm_answers_do_not_depend_on_chunks_or_workers(batches, tmp_path):
    cases, _, warm = batches
    for chunk, workers in ((7, 1), (SEGMENT, 1), (13, 2), (60, 2)):
        other = solve_many(TDCR, cases, warm=True, chunk=chunk, workers=workers,
                           output=tmp_path / f"w{chunk}.nc")
        for name in ("position", "quaternion", "residual", "newton_iters", "stable"):
            assert np.array_equal(other[name].values, warm[name].values, equal_nan=True), \
                (chunk, workers, name)
        assert list(other["message"].values) == list(warm["message"].values)


def test_a_failing_case_is_recorded_and_the_warm_chain_goes_on():
    """A 10 kN tension has no equilibrium static reaches (tests/test_batch.py); the case
    after it in the solve order starts from rest, and every other case is the case alone."""
    cases = tdcr_cases(8, seed=4)
    cases[TDCR_KEYS[0]][3] = 1e4
    batch = solve_many(TDCR, cases, warm=True)
    assert batch["status"].values[3] == STATUS["solver_failure"]
    assert "did not converge" in str(batch["message"].values[3])
    assert np.isnan(batch["position"].values[3]).all()
    assert batch.attrs["failed_cases"] == 1
    for case in (0, 1, 2, 4, 5, 6, 7):
        result = alone(TDCR, cases, case)
        assert batch["status"].values[case] == STATUS["ok"] and result.success
        assert np.max(np.abs(batch["position"].values[case] - positions(result))) <= WARM_GAP


def test_a_warm_batch_resumes_from_its_parts_and_reruns_bit_for_bit(batches, tmp_path,
                                                                    monkeypatch):
    cases, _, warm = batches
    few = {key: values[:30] for key, values in cases.items()}
    output = tmp_path / "warm.nc"
    first = solve_many(TDCR, few, warm=True, chunk=10, output=output, keep_parts=True)
    parts = parts_folder(output)
    records = [json.loads(p.read_text()) for p in sorted(parts.glob("chunk-*.json"))]
    order = solve_order(np.column_stack([few[k] for k in TDCR_KEYS]))
    assert [c["case"] for r in records for c in r["cases"]] == order.tolist()
    assert [r["start"] for r in records] == [0, SEGMENT]
    calls = []

    def recording(job, start, end):
        calls.append(start)
        return solve_chunk(job, start, end)

    monkeypatch.setattr(rodsim.app.batch, "solve_chunk", recording)
    (parts / "chunk-000000025.json").unlink()  # chunks of whole segments: 0-24, 25-29
    again = solve_many(TDCR, few, warm=True, chunk=10, output=output)
    assert calls == [25]
    assert np.array_equal(again["position"].values, first["position"].values)
    # A cold batch is another batch: its parts are not mixed with the warm one's.
    solve_many(TDCR, few, warm=True, chunk=10, output=tmp_path / "p.nc", keep_parts=True)
    with pytest.raises(StudyError, match="different batch definition"):
        solve_many(TDCR, few, chunk=10, output=tmp_path / "p.nc")
    # Re-run from the archive alone: warm again, the same numbers.
    stored = read_dataset(output)
    assert stored.attrs["warm_starts"] == 1
    _, distance = rerun_batch(stored)
    assert distance == 0.0


def test_the_command_line_takes_warm(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    cases = tdcr_cases(6, seed=9)
    rows = ["s1a.tendon_string.tension,s2b.tendon_string.tension"] + [
        f"{a:.17g},{b:.17g}" for a, b in zip(cases[TDCR_KEYS[0]], cases[TDCR_KEYS[1]], strict=True)]
    Path("cases.csv").write_text("\n".join(rows) + "\n")
    assert main(["batch", TDCR, "--cases", "cases.csv", "-o", "w.nc", "--workers", "1",
                 "--warm"]) == 0
    stored = read_dataset("w.nc")
    assert stored.attrs["warm_starts"] == 1 and (stored["status"].values == 0).all()
    with pytest.raises(StudyError, match="warm must be"):
        solve_many(TDCR, {"s1a.tendon_string.tension": [1.0]}, warm=1)  # type: ignore
