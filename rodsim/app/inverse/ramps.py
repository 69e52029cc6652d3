"""The ramps of ``rodsim track`` (rodsim/app/inverse/track.py): ``--ramp`` text to values.

``KEY=START:STOP:COUNT`` gives COUNT equally spaced values from START to STOP; further
``:STOP:COUNT`` legs go on from the last stop, each COUNT more values ending at its STOP
(``tension=0.5:3:11:0.5:10`` pulls up in 11 values and back down in 10 more: a pull–release
cycle, which a tendon with friction answers with its hysteresis loop, docs/tendon.md).
"""

from __future__ import annotations

import numpy as np

from rodsim.core.schema import SceneError

__all__ = ["MAX_STEPS", "parse_ramp"]

#: Most steps a track may have (a ramp's values): beyond, the values alone fill memory and
#: the run takes days.
MAX_STEPS = 100_000


def parse_ramp(text: str) -> tuple[str, np.ndarray]:
    """``KEY=START:STOP:COUNT[:STOP:COUNT …]`` → (key, the values); SceneError."""
    key, sep, spec = text.partition("=")
    parts = spec.split(":")
    if not sep or not key.strip() or len(parts) < 3 or len(parts) % 2 == 0:
        raise SceneError(f"--ramp {text[:60]!r}: expected KEY=START:STOP:COUNT, optionally "
                         "followed by :STOP:COUNT legs")
    try:
        stops = [float(v) for v in parts[:1] + parts[1::2]]
        counts = [int(v) for v in parts[2::2]]
    except ValueError:
        raise SceneError(f"--ramp {text[:60]!r}: START and STOP must be numbers, COUNT a "
                         "whole number") from None
    if (not all(np.isfinite(stops)) or counts[0] < 2 or min(counts) < 1
            or sum(counts) > MAX_STEPS):
        raise SceneError(f"--ramp {text[:60]!r}: finite START and STOP, a first COUNT from 2 "
                         f"and {MAX_STEPS} values at most expected")
    values = [np.linspace(stops[0], stops[1], counts[0])]
    for start, stop, count in zip(stops[1:-1], stops[2:], counts[1:], strict=True):
        values.append(np.linspace(start, stop, count + 1)[1:])
    return key.strip(), np.concatenate(values)
