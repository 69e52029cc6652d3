"""Smoke test of ``rodsim bench cvode-scaling --size small`` (benchmarks/rodsim_bench/
cvode_scaling.py): CVODE's dense and banded Newton matrix and IDA timed against N."""

from __future__ import annotations

import json

import pytest

from rodsim.solvers.physical import ode_newton
from rodsim_bench import cvode_scaling


@pytest.mark.slow
def test_cvode_scaling_small_outputs(tmp_path):
    """Every run succeeds, each CVODE run on the solver it names (the size rule restored
    after), dense and banded within 1e-4 L of each other's tip error, the growth exponents
    written (no timing is asserted)."""
    paths = cvode_scaling.run("small", tmp_path, lambda *_: None)
    assert {p.name for p in paths} == {"cvode-scaling-small.json", "cvode-scaling-small.md"}
    assert ode_newton.DENSE_LIMIT == 400
    report = json.loads((tmp_path / "cvode-scaling-small.json").read_text())
    rows = report["rows"]
    assert [(row["nodes"], row["solver"]) for row in rows] == [
        (n, s) for n in (5, 9) for s in ("ida", "cvode-dense", "cvode-banded")]
    assert all(row["success"] and row["cpu_s"] > 0.0 for row in rows)
    assert all(row["tip_error_over_L"] < 2e-4 for row in rows)
    dense = {row["nodes"]: row for row in rows if row["solver"] == "cvode-dense"}
    banded = {row["nodes"]: row for row in rows if row["solver"] == "cvode-banded"}
    assert all(abs(dense[n]["tip_error_over_L"] - banded[n]["tip_error_over_L"]) < 1e-4
               for n in (5, 9))
    assert len(report["exponents"]["cvode-banded"]["cpu"]) == 1
    assert "| 9 | cvode-banded |" in (tmp_path / "cvode-scaling-small.md").read_text()
