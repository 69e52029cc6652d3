"""Fault injection for the study runner's tests: a point hook (rodsim.app.study_runner's
``point_hook`` / ``POINT_HOOK``) that makes the worker process starting a given grid point
call ``os._exit`` (as a segfault or the OOM killer would end it) or sleep for an hour (a
point that never ends). Production code never reads it: the tests inject it."""

from __future__ import annotations

import os
import time
from typing import Any


class Faults:
    """``Faults("exit:<study>:<i>-<j>,hang:<study>:<i>-<j>,…")``: a picklable point hook."""

    def __init__(self, wanted: str) -> None:
        self.wanted = tuple(wanted.split(","))

    def __call__(self, spec: Any, index: tuple[int, ...]) -> None:
        point = f"{spec.name}:{'-'.join(map(str, index))}"
        if f"exit:{point}" in self.wanted:
            os._exit(70)
        if f"hang:{point}" in self.wanted:
            time.sleep(3600.0)


#: Lines a child script runs before the CLI to arm the faults given in ``argv[index]``
#: (the tests folder is put on sys.path so that workers can unpickle the hook).
def child_preamble(index: int) -> str:
    folder = os.path.dirname(os.path.abspath(__file__))
    return (f"import sys\nsys.path.insert(0, {folder!r})\n"
            "import fault_injection, rodsim.app.study_runner as _runner\n"
            f"_runner.POINT_HOOK = fault_injection.Faults(sys.argv[{index}])\n")
