"""Progress lines on stderr for runs longer than about a second."""

from __future__ import annotations

import shutil
import sys
import time
from typing import TextIO

__all__ = ["ProgressPrinter"]


class ProgressPrinter:
    """A progress callback (see ``rodsim.solvers.base.Progress``).

    Silent for the first ``delay`` seconds; then one status line at most every ``interval``
    seconds — rewritten in place on a terminal (cut to the terminal's width, so it never
    wraps), appended otherwise (logs stay readable). The last line shown is never a stale
    one: the first report of completion (``fraction`` 1) is shown at once, and a status held
    back by the interval is shown by ``close``.
    """

    def __init__(self, stream: TextIO | None = None, delay: float = 1.0,
                 interval: float = 0.5) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.delay = delay
        self.interval = interval if self.stream.isatty() else max(interval, 5.0)
        self._start = time.perf_counter()
        self._last = -float("inf")
        self._shown = False  # an in-place line is open (ended by close)
        self._any = False  # a line was ever shown
        self._complete = False  # completion was shown
        self._pending: str | None = None  # a line held back by the interval

    def __call__(self, fraction: float | None, status: str) -> None:
        now = time.perf_counter()
        elapsed = now - self._start
        done = f"{100 * fraction:5.1f}% " if fraction is not None else ""
        line = f"[{elapsed:6.1f} s] {done}{status}"
        if elapsed < self.delay:
            return
        first_completion = fraction is not None and fraction >= 1.0 and not self._complete
        if now - self._last < self.interval and not first_completion:
            self._pending = line
            return
        self._complete = self._complete or first_completion
        self._last = now
        self._write(line)

    def _write(self, line: str) -> None:
        if self.stream.isatty():
            # One column short of the width: a line filling the last column wraps on some
            # terminals, and the next "\r" then rewrites only the wrapped part.
            width = max(shutil.get_terminal_size().columns - 1, 20)
            self.stream.write("\r" + line[:width].ljust(width))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()
        self._shown = self._any = True
        self._pending = None

    def close(self) -> None:
        """Show a held-back status, and end the in-place line (call once the run is over, or
        before printing something else)."""
        if self._pending is not None and self._any:
            self._write(self._pending)
        self._pending = None
        if self._shown and self.stream.isatty():
            self.stream.write("\n")
            self.stream.flush()
        self._shown = False
