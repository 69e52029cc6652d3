"""Iteration and step counts in tests: a bound with a stated margin over the measured count,
never the count itself.

A count is deterministic on one machine with one set of library releases, but round-off
moves it between machines: table3-catheter3's static solve took 29 Newton iterations at
27422c4 on one machine and 30 on a fresh one with the same releases, and the test that
allowed 29 turned the suite red. A test asks that a solve stay cheap; the exact counts, with
the machine they were counted on, are the benchmark's (``rodsim bench iterations``,
benchmarks/results/iterations-full.md).
"""

from __future__ import annotations

import math

__all__ = ["MARGIN", "at_most"]

#: How far above its measured value a count may go before a test calls it a regression.
MARGIN = 1.5


def at_most(measured: int) -> int:
    """The bound a test puts on a count measured as ``measured``: ``MARGIN`` × it, rounded up."""
    return math.ceil(MARGIN * measured)
