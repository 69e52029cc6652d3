"""Tendon friction along a simulation in physical time (``rodsim.simulate``): the
friction history carried from step to step, the tendons' tensions and stick/slip states
kept at the output times, and every routing point that broke loose or stuck again with the
time located (docs/dynamics.md, "Friction in physical time")."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from rodsim.app.programs import Programs
from rodsim.core.friction_record import (
    Breakaway,
    FrictionRecord,
    Restick,
    breakaways,
    friction_record,
    resticks,
)
from rodsim.core.model import Model
from rodsim.solvers.physical.restick import Held

__all__ = ["FrictionTrace"]


class FrictionTrace:
    """Friction's history carried from step to step (``Programs.carry_history``), the
    tendons' friction state (``friction_record``) kept at the output times, and the points
    that broke loose (``breakaways``: each carried at its located time, the split of its
    step, rodsim/solvers/physical/breakaway.py)."""

    def __init__(self, programs: Programs, outputs: np.ndarray) -> None:
        self.programs = programs
        self.outputs = {float(t) for t in outputs}
        self.kept: dict[float, FrictionRecord] = {}
        #: The last step's end (t, history, free state): a terminal event's time, which is
        #: no output time, reads its state from it.
        self.latest: tuple[float, Model, np.ndarray] | None = None
        #: Every routing point of a tendon with stiction that broke loose, in time order.
        self.breakaways: list[Breakaway] = []
        #: Every sliding routing point that stuck again, in time order.
        self.resticks: list[Restick] = []
        #: Whether a change of stick/slip state counts as a breakaway (not the start's
        #: history, carried before the run: ``start``).
        self.started = False

    def start(self, x: np.ndarray) -> None:
        """The history of the run's start at t = 0, the state ``x`` (the equilibrium it was
        left in, or the rest state): carried, no breakaway."""
        self.after_step(0.0, x)
        self.started = True

    def after_step(self, t: float, x: np.ndarray, held: Sequence[Held] = ()) -> None:
        """``integrate``'s ``after_step``: carry the history, noting the points that broke
        loose at ``t``, and hold the points ``held`` that stuck again there
        (rodsim/solvers/physical/restick.py); at an output time, keep the friction state of
        ``x`` (free state) with the step's history."""
        before = self.programs.model
        end = self.programs.carry_history(t, x)
        if end is not None and self.started:
            self.breakaways.extend(breakaways(before, self.programs.model, t))
        if end is not None and held:
            self.programs.hold(held)
            self.resticks.extend(resticks(self.programs.model, held, t))
        if end is not None:
            self.latest = (t, end, x.copy())
        if end is not None and t in self.outputs:
            found = friction_record(end, end.full(x))
            if found is not None:
                self.kept[t] = found

    def mark(self) -> Callable[[], None]:
        """What restores the history as it is now (the carried anchors, the breakaways
        noted, the last step's end): a trial step (an event's root,
        rodsim/solvers/physical/trajectory.py) is taken from it and undone."""
        model, found, latest = self.programs.model, len(self.breakaways), self.latest
        stuck = len(self.resticks)
        now = -np.inf if latest is None else latest[0]

        def restore() -> None:
            self.programs.restore(model)
            del self.breakaways[found:]
            del self.resticks[stuck:]
            self.latest = latest
            for t in [t for t in self.kept if t > now]:
                del self.kept[t]
        return restore

    def at(self, times: Sequence[float]) -> FrictionRecord | None:
        """The states kept at ``times`` stacked along a leading time axis; None without
        tendon friction."""
        if not self.kept or not len(times):
            return None
        kept = [self.kept[float(t)] if float(t) in self.kept else self._latest_at(float(t))
                for t in times]
        return FrictionRecord(kept[0].chords, np.array([k.tension for k in kept]),
                              kept[0].points, np.array([k.slip for k in kept]))

    def _latest_at(self, t: float) -> FrictionRecord:
        """The friction state at the last step's end ``t`` (a terminal event's time)."""
        if self.latest is None or self.latest[0] != t:
            raise KeyError(f"no friction state kept at t = {t} s")
        _, end, x = self.latest
        found = friction_record(end, end.full(x))
        assert found is not None
        return found
