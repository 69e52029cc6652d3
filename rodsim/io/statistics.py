"""The statistics vocabulary of the app and the archives: which of a run's counters
(``rodsim.solvers.result.STAT_DOCS``) a study archive stores per point, with units and
long names, and which ``rodsim run`` prints. One list: the study's evaluation, its archive
layout (``rodsim.io.study_dataset``), the point records' check and the CLI summary read
it."""

from __future__ import annotations

__all__ = ["COUNTERS", "POINT_STATS", "POINT_STAT_DOCS", "SUMMARY_STATS"]

#: The work counters every integrator reports (NaN where one cannot count).
COUNTERS = ("steps", "newton_iters", "force_evals", "jacobian_evals", "linear_solves")
#: Per-point statistics a study copies from the run, with (units, long name) in its archive.
POINT_STAT_DOCS = {
    "steps": ("1", "integrator steps"), "newton_iters": ("1", "Newton iterations"),
    "force_evals": ("1", "force evaluations"), "jacobian_evals": ("1", "Jacobian evaluations"),
    "linear_solves": ("1", "linear solves"), "wall_time": ("s", "wall time to equilibrium"),
}
POINT_STATS = tuple(POINT_STAT_DOCS)
#: The counters of ``rodsim run``'s ``statistics`` line (those a run has).
SUMMARY_STATS = (*COUNTERS, "reinits", "tightenings")
