"""Smoke test of ``rodsim bench time-scaling --size small`` (benchmarks/rodsim_bench/
time_scaling.py): tdcr-two-segment's physical-time runs timed against the time simulated."""

from __future__ import annotations

import json

import pytest

from rodsim_bench import time_scaling


@pytest.mark.slow
def test_time_scaling_small_outputs(tmp_path):
    """Every integrator runs to every end time and succeeds; a run twice as long takes more
    steps (the step counts, not the timings, are what is asserted); one exponent per pair
    of end times is written, and the table names every integrator."""
    paths = time_scaling.run("small", tmp_path, lambda *_: None)
    assert {p.name for p in paths} == {"time-scaling-small.json", "time-scaling-small.md"}
    report = json.loads((tmp_path / "time-scaling-small.json").read_text())
    rows = report["rows"]
    labels = [label for label, _ in time_scaling.INTEGRATORS]
    assert [(r["integrator"], r["t_end_s"]) for r in rows] == [
        (label, t) for label in labels for t in time_scaling.SIZES["small"]]
    assert all(r["success"] and r["cpu_s"] > 0.0 for r in rows)
    for label in labels:
        short, long = (r for r in rows if r["integrator"] == label)
        assert long["steps"] > short["steps"]
        assert len(report["exponents"][label]) == 1
    fixed = [r for r in rows if r["integrator"].startswith("midpoint, h")]
    assert [r["steps"] for r in fixed] == [20, 40]  # 0.01 s and 0.02 s at 0.5 ms steps
    table = (tmp_path / "time-scaling-small.md").read_text()
    assert all(f"| {label} |" in table for label in labels)
