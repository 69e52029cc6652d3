"""The app's rooms stay of one concept (issue 21): no module of rodsim/app above 450 lines,
one atomic writer (rodsim/io/atomic.py), one statistics vocabulary (rodsim/io/statistics.py)
drawn from the solvers' documented statistics."""

from __future__ import annotations

import re
from pathlib import Path

from rodsim.io.statistics import COUNTERS, POINT_STAT_DOCS, POINT_STATS, SUMMARY_STATS
from rodsim.solvers.result import STAT_DOCS

PACKAGE = Path(__file__).resolve().parents[1] / "rodsim"
MAX_LINES = 450


def test_no_app_module_is_above_450_lines():
    sizes = {str(path.relative_to(PACKAGE)): len(path.read_text(encoding="utf-8").splitlines())
             for path in (PACKAGE / "app").rglob("*.py")}
    assert len(sizes) > 30  # the walk found the app's packages (cli, figures, inverse)
    assert {name: n for name, n in sizes.items() if n > MAX_LINES} == {}


def test_one_atomic_write_then_replace():
    """Only rodsim/io/atomic.py renames a written temporary file over its target (the study
    runner's os.replace of a whole staging folder is a folder's creation, not a write)."""
    replacing = sorted(str(path.relative_to(PACKAGE)) for path in PACKAGE.rglob("*.py")
                       if re.search(r"\bos\.replace\(", path.read_text(encoding="utf-8")))
    assert replacing == ["app/study_parts.py", "io/atomic.py"]
    parts = (PACKAGE / "app" / "study_parts.py").read_text(encoding="utf-8")
    assert parts.count("os.replace(") == 1 and "os.replace(staging, folder)" in parts


def test_the_statistics_vocabulary_is_the_solvers():
    """Every statistic a study stores or run prints as a run's counter is one the solvers
    document (STAT_DOCS), but for the two counters of the summary line that only some
    integrators add (re-initialisations and tolerance tightenings); the
    archive's long names cover exactly the stored statistics."""
    assert set(COUNTERS) <= set(STAT_DOCS) and set(POINT_STATS) <= set(STAT_DOCS)
    assert set(SUMMARY_STATS) - set(STAT_DOCS) == {"reinits", "tightenings"}
    assert tuple(POINT_STAT_DOCS) == POINT_STATS == (*COUNTERS, "wall_time")
