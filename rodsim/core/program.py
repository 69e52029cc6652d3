"""Programs: scene values that vary in physical time (issue 33, item 2; docs/dynamics.md,
"Initial state and programs").

A program gives one numeric scene value p (a load, a tendon's tension or displacement, a
base's insertion or rotation, a node support's displacement: any key ``track`` ramps) as a
function of time for ``rodsim.simulate``; the model at time t is
the scene with p(t), and the loads' potential −F·r then does the work ∫ ∂V/∂p ṗ dt
(rodsim/solvers/physical/trajectory.py). Two forms:

- ``Table`` — piecewise linear through (times, values): a repeated time is a step;
  before the first time and after the last the end values hold.
- ``Sinusoid`` — p(t) = offset + amplitude · sin(2π · frequency · t + phase), frequency
  in Hz and phase in radians; ``offset`` None stands for the scene's own value of the key
  (filled in by ``Sinusoid.about``), so that a run from the scene's equilibrium starts
  with p(0) = offset + amplitude · sin(phase).

In a scene file, a ``[program]`` table holds one entry per key (a dotted key or a short
form as for ``--set``, quoted because it has dots), either form::

    [program."tip_load.force[1]"]
    times = [0.0, 0.1, 0.2]        # s
    values = [0.0, -0.1, -0.1]

    [program."tendon_string.tension"]
    amplitude = 0.5                # the key's unit
    frequency = 2.0                # Hz
    phase = 0.0                    # rad (default 0)
    offset = 1.0                   # default: the scene's value

``program_entry`` reads either (and ``(times, values)`` pairs, the Python form);
``resolve_program`` validates the scene file's table (structure and numbers: the keys
and the values' ranges need the scene and are checked by ``rodsim.simulate`` before any
work, ``rodsim.app.programs.check_programs``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.schema import SceneError, shown

__all__ = ["Table", "Sinusoid", "ProgramEntry", "program_entry", "resolve_program",
           "SINUSOID_KEYS"]

#: The keys of a sinusoid's table (``amplitude`` and ``frequency`` required).
SINUSOID_KEYS = ("amplitude", "frequency", "phase", "offset")


@dataclass(frozen=True)
class Table:
    """A piecewise-linear program through (``times`` [s], ``values``), times not
    decreasing (one repeated time is a step)."""

    times: tuple[float, ...]
    values: tuple[float, ...]

    def value(self, t: float, before: bool = False) -> float:
        """p(t): linear between the times, the end values outside, at a step the value
        after it (``before``: the value before it)."""
        times = np.asarray(self.times)
        right = int(np.searchsorted(times, t, side="left" if before else "right"))
        if right == 0:
            return self.values[0]
        if right == len(times):
            return self.values[-1]
        t0, t1 = times[right - 1], times[right]
        share = (t - t0) / (t1 - t0)
        return float(self.values[right - 1] + share * (self.values[right]
                                                       - self.values[right - 1]))

    def rate(self, t: float) -> float:
        """dp/dt at ``t``: the slope of the piece that holds ``t`` (at a table time, the
        piece after it), 0 before the first time and after the last; exact, the table
        being piecewise linear (a moving support's velocity, docs/dynamics.md)."""
        times = np.asarray(self.times)
        right = int(np.searchsorted(times, t, side="right"))
        if right == 0 or right == len(times):
            return 0.0
        t0, t1 = times[right - 1], times[right]
        return float((self.values[right] - self.values[right - 1]) / (t1 - t0))

    def extremes(self) -> tuple[float, float]:
        """The smallest and largest value over all times (a linear piece lies between its
        ends)."""
        return min(self.values), max(self.values)

    def data(self) -> dict[str, list[float]]:
        """The scene file's form, ``{"times": [...], "values": [...]}``."""
        return {"times": list(self.times), "values": list(self.values)}

    def archived(self) -> list[list[float]]:
        """The trajectory archive's form, ``[times, values]`` (docs/archive.md)."""
        return [list(self.times), list(self.values)]


@dataclass(frozen=True)
class Sinusoid:
    """p(t) = offset + amplitude · sin(2π · frequency · t + phase).

    ``amplitude`` ≥ 0 in the key's unit, ``frequency`` > 0 [Hz], ``phase`` [rad];
    ``offset`` None: the scene's value of the key (``about``).
    """

    amplitude: float
    frequency: float
    phase: float = 0.0
    offset: float | None = None

    def about(self, value: float) -> Sinusoid:
        """This sinusoid with ``value`` as its offset when it has none."""
        if self.offset is not None:
            return self
        return Sinusoid(self.amplitude, self.frequency, self.phase, float(value))

    def value(self, t: float, before: bool = False) -> float:
        """p(t) (ValueError without an offset: ``about`` first); ``before`` changes
        nothing, a sinusoid has no step."""
        if self.offset is None:
            raise ValueError("a sinusoid without offset: give it the scene's value (about)")
        return self.offset + self.amplitude * math.sin(2.0 * math.pi * self.frequency * t
                                                       + self.phase)

    def rate(self, t: float) -> float:
        """dp/dt = 2π · frequency · amplitude · cos(2π · frequency · t + phase), exact."""
        angular = 2.0 * math.pi * self.frequency
        return angular * self.amplitude * math.cos(angular * t + self.phase)

    def extremes(self) -> tuple[float, float]:
        """offset ∓ amplitude, the smallest and largest value (ValueError without an
        offset)."""
        if self.offset is None:
            raise ValueError("a sinusoid without offset: give it the scene's value (about)")
        return self.offset - self.amplitude, self.offset + self.amplitude

    def data(self) -> dict[str, float]:
        """The scene file's form (``offset`` left out when it is the scene's value)."""
        out = {"amplitude": self.amplitude, "frequency": self.frequency, "phase": self.phase}
        if self.offset is not None:
            out["offset"] = self.offset
        return out

    def archived(self) -> dict[str, float]:
        """The trajectory archive's form: ``data``."""
        return self.data()


ProgramEntry = Table | Sinusoid


def _number(name: str, field: str, value: Any) -> float:
    """A finite real number, or SceneError naming the program's ``field``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)
                                                 ) or not math.isfinite(float(value)):
        raise SceneError(f"program {shown(name, bare=True)}.{field} = {shown(value)}: "
                         "allowed a finite number")
    return float(value)


def _table(name: str, times: Any, values: Any) -> Table:
    """A checked ``Table`` from two lists of numbers."""
    try:
        t, v = (np.asarray(part, dtype=float) for part in (times, values))
    except (TypeError, ValueError):
        raise SceneError(f"program {shown(name, bare=True)}: expected times and values, two "
                         "lists of numbers") from None
    if t.ndim != 1 or t.shape != v.shape or t.size == 0 or not (
            np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise SceneError(f"program {shown(name, bare=True)}: expected times and values of "
                         "the same length (at least one), finite")
    if np.any(np.diff(t) < 0.0) or np.any(t[2:] == t[:-2]):
        raise SceneError(f"program {shown(name, bare=True)}: times must not decrease (one "
                         "repeated time is a step)")
    return Table(tuple(map(float, t)), tuple(map(float, v)))


def _sinusoid(name: str, table: Mapping[str, Any]) -> Sinusoid:
    """A checked ``Sinusoid`` from a table of ``SINUSOID_KEYS``."""
    unknown = [key for key in table if key not in SINUSOID_KEYS]
    if unknown:
        raise SceneError(f"program {shown(name, bare=True)}.{shown(unknown[0], bare=True)}: "
                         "unknown key; a sinusoid has " + ", ".join(SINUSOID_KEYS))
    for key in ("amplitude", "frequency"):
        if key not in table:
            raise SceneError(f"program {shown(name, bare=True)}: a sinusoid needs {key}")
    amplitude = _number(name, "amplitude", table["amplitude"])
    frequency = _number(name, "frequency", table["frequency"])
    if amplitude < 0.0:
        raise SceneError(f"program {shown(name, bare=True)}.amplitude = {amplitude!r}: "
                         "allowed a number >= 0 (a phase of pi turns the sign)")
    if frequency <= 0.0:
        raise SceneError(f"program {shown(name, bare=True)}.frequency = {frequency!r}: "
                         "allowed a number > 0 [Hz]")
    phase = _number(name, "phase", table.get("phase", 0.0))
    offset = table.get("offset")
    return Sinusoid(amplitude, frequency, phase,
                    None if offset is None else _number(name, "offset", offset))


def program_entry(name: str, raw: Any) -> ProgramEntry:
    """One key's program from any of its forms: a ``Table`` or ``Sinusoid``
    (checked again), a pair ``(times, values)``, or a mapping with ``times`` and ``values``
    or with the keys of a sinusoid (module docstring); SceneError (one line) otherwise."""
    if isinstance(raw, Table):
        return _table(name, raw.times, raw.values)
    if isinstance(raw, Sinusoid):
        return _sinusoid(name, raw.data())
    if isinstance(raw, Mapping):
        if "times" in raw or "values" in raw:
            extra = [key for key in raw if key not in ("times", "values")]
            if extra or len(raw) != 2:
                raise SceneError(f"program {shown(name, bare=True)}: a table has exactly "
                                 "times and values")
            return _table(name, raw["times"], raw["values"])
        return _sinusoid(name, raw)
    if isinstance(raw, Sequence) and not isinstance(raw, str) and len(raw) == 2:
        return _table(name, raw[0], raw[1])
    raise SceneError(f"program {shown(name, bare=True)}: expected (times, values), a "
                     "Sinusoid, or a table with times and values or with amplitude and "
                     "frequency")


def resolve_program(raw: Any) -> dict[str, dict[str, Any]]:
    """The validated ``[program]`` table of a scene file: key → the entry's
    ``Table.data`` (SceneError, one line, for a malformed entry)."""
    if not isinstance(raw, Mapping):
        raise SceneError("program: expected a table, one entry per key ([program.\"KEY\"] "
                         "with times and values, or amplitude and frequency)")
    out = {}
    for name, entry in raw.items():
        if not isinstance(entry, Mapping):
            raise SceneError(f"program {shown(name, bare=True)}: expected a table with times "
                             "and values, or amplitude and frequency")
        out[str(name)] = program_entry(str(name), entry).data()
    return out
