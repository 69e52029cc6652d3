"""Progress lines on stderr for runs longer than about a second."""

from __future__ import annotations

import shutil
import sys
import time
from typing import TextIO

__all__ = ["ProgressPrinter"]


class ProgressPrinter:
    """A progress callback (see :data:`rodsim.solvers.base.Progress`).

    Silent for the first ``delay`` seconds; then one status line at most every ``interval``
    seconds — rewritten in place on a terminal (cut to the terminal's width, so it never
    wraps), appended otherwise (logs stay readable). The line that reports completion
    (``fraction`` 1) is always shown once anything has been, so the last line a finished run
    leaves is never an intermediate one.
    """

    def __init__(self, stream: TextIO | None = None, delay: float = 1.0,
                 interval: float = 0.5) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.delay = delay
        self.interval = interval if self.stream.isatty() else max(interval, 5.0)
        self._start = time.perf_counter()
        self._last = -float("inf")
        self._shown = False

    def __call__(self, fraction: float | None, status: str) -> None:
        now = time.perf_counter()
        elapsed = now - self._start
        final = fraction is not None and fraction >= 1.0
        if elapsed < self.delay or (not final and now - self._last < self.interval):
            return
        self._last = now
        done = f"{100 * fraction:5.1f}% " if fraction is not None else ""
        line = f"[{elapsed:6.1f} s] {done}{status}"
        if self.stream.isatty():
            # One column short of the width: a line filling the last column wraps on some
            # terminals, and the next "\r" then rewrites only the wrapped part.
            width = max(shutil.get_terminal_size().columns - 1, 20)
            self.stream.write("\r" + line[:width].ljust(width))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()
        self._shown = True

    def close(self) -> None:
        """End the in-place line (call once the run is over)."""
        if self._shown and self.stream.isatty():
            self.stream.write("\n")
            self.stream.flush()
            self._shown = False
