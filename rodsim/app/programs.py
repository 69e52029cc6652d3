"""Values that vary in physical time: the programs of a run, checked against their keys
before any work (docs/dynamics.md, "Initial state and programs"), and ``Programs``,
the model with the values of a time.

A program maps a term's numeric value to a piecewise-linear table or a sinusoid
(rodsim/core/program.py), from the scene file's ``[program]`` table and from the caller
(``program=`` / ``--program``), the caller's replacing the file's entry for the same value.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey, numeric_key, scene_with
from rodsim.app.support_programs import SupportPrograms, is_support_key
from rodsim.core.damping_options import ELASTIC_TERMS
from rodsim.core.model import Model
from rodsim.core.program import ProgramEntry, Sinusoid, Table, program_entry
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError, shown
from rodsim.solvers.physical.restick import Held, hold

__all__ = ["Program", "check_programs", "Programs"]

#: key → (times, values), a :class:`~rodsim.core.program.Sinusoid` or a table of either
#: (rodsim/core/program.py).
Program = Mapping[str, tuple[Sequence[float], Sequence[float]] | ProgramEntry
                  | Mapping[str, Any]]


def check_programs(scene: Scene, program: Program | None
                   ) -> tuple[list[NumericKey], list[ProgramEntry]]:
    """The checked programs, the scene file's ``[program]`` table and then ``program`` (which
    replaces the scene's entry for the same value): their keys and entries, each sinusoid
    given the scene's value as its offset when it has none. SceneError (one line) for a
    key that is not a term's number or that cannot vary in time, a malformed entry, a value
    named twice in one source, or a program that leaves the key's range at some time (its
    smallest and largest value are checked: a table's at its times, a sinusoid's
    offset ∓ amplitude)."""
    chosen: dict[str, tuple[NumericKey, ProgramEntry]] = {}
    for source in (scene.data.get("program", {}), program or {}):
        named: set[str] = set()
        for name, raw in source.items():
            key = numeric_key(scene, name)
            parts = key.path.split(".")
            support = is_support_key(parts)
            if support is False or (support is None and (len(parts) != 4 or (
                    parts[0] == "rods" and parts[2] in ELASTIC_TERMS) or (
                    parts[2:] == ["gravity", "direction"]))):
                raise SceneError(f"program {shown(name, bare=True)}: {key.path} cannot vary "
                                 "in time; allowed: a load's or a tendon's value (a term "
                                 "parameter other than the rod's own stiffness or gravity's "
                                 "direction), a base's insertion or rotation, a node "
                                 "support's displacement")
            if key.name in named:
                raise SceneError(f"program {shown(name, bare=True)}: {key.name} is named "
                                 "twice")
            named.add(key.name)
            entry = program_entry(name, raw)
            if isinstance(entry, Sinusoid):
                entry = entry.about(key.value(scene))
            chosen[key.name] = (key, entry)
    for key, entry in chosen.values():  # its extremes, against the key's range
        for value in sorted(set(entry.extremes())):
            try:
                scene_with(scene, [key], [value])
            except SceneError as exc:
                raise SceneError(f"program {key.name} reaches {value:.6g}: {exc}") from None
    return [key for key, _ in chosen.values()], [entry for _, entry in chosen.values()]


class Programs:
    """The models of a scene's values in time: ``model`` with the checked programs
    (``check_programs``) at each time, the same object while nothing changes, and with
    friction's history as far as the run has gone (``carry_history``)."""

    def __init__(self, scene: Scene, model: Model, program: Program | None) -> None:
        self.scene, self.model = scene, model
        #: Whether a term's force depends on the path (friction: a string tendon's capstan,
        #: a frictional contact; rodsim/core/tendon_friction.py, terms/contact.py).
        self.path_dependent = any(term.anchor_positions() is not None
                                  for term in model.terms)
        self.keys, self.entries = check_programs(scene, program)
        #: The entries by full key (what a Simulation and its archive keep).
        self.by_name = {key.name: entry
                        for key, entry in zip(self.keys, self.entries, strict=True)}
        self._models: dict[tuple[float, ...], Model] = {}
        #: The supports' velocity in time, where programs move them
        #: (rodsim/app/support_programs.py).
        self.supports = SupportPrograms(model, self.keys, self.entries)

    @property
    def breaks(self) -> list[float]:
        """Every table time: where a value's slope changes or it jumps (a sinusoid is
        smooth)."""
        return sorted({float(t) for entry in self.entries if isinstance(entry, Table)
                       for t in entry.times})

    @property
    def difference(self) -> float:
        """The half-width [s] of a central difference of the values in time that is exact
        enough: a thousandth of the shortest sinusoid's period (the difference's relative
        error ~ (2π · 1e-3)²/6 = 7e-6), unbounded for tables (linear pieces)."""
        periods = [1.0 / entry.frequency for entry in self.entries
                   if isinstance(entry, Sinusoid)]
        return 1e-3 * min(periods) if periods else math.inf

    def model_at(self, t: float, before: bool = False) -> Model:
        """The model with the values at ``t`` (``before``: just before ``t``, where a table
        steps)."""
        if not self.keys:
            return self.model
        now = tuple(entry.value(t, before) for entry in self.entries)
        if now not in self._models:
            if len(self._models) > 64:
                self._models.clear()
            changed = self.model.with_values(scene_with(self.scene, self.keys, list(now)))
            assert changed is not None
            self._models[now] = changed
        return self._models[now]

    def carry_history(self, t: float, x: np.ndarray) -> Model | None:
        """Friction's history after a step that ended at time ``t`` in the state ``x`` (free
        coordinates): the anchors the model of time ``t`` gives at ``x`` (a string tendon's
        chord tensions, a frictional contact's node positions) become those of every later
        model, so that each step's friction opposes the slip since the step before — as
        ``track`` carries it from one equilibrium to the next (docs/dynamics.md,
        "Friction in physical time"; a point of a string tendon that breaks loose
        inside a step is carried at the time it does, rodsim/solvers/physical/breakaway.py).
        Returns the model of time ``t`` with the step's history (whose friction at ``x`` is
        the state reached: ``rodsim.core.friction_record``); None without friction."""
        if not self.path_dependent:
            return None
        end = self.model_at(t)
        self.model = self.model.with_anchors_of(end.anchored(x))
        self._models.clear()
        return end

    def hold(self, held: Sequence[Held]) -> None:
        """The routing points ``held`` stuck in friction's history (they stuck again where
        it was last carried: rodsim/solvers/physical/restick.py)."""
        if held:
            self.model = hold(self.model, list(held))
            self._models.clear()

    def restore(self, model: Model) -> None:
        """Friction's history back to that of ``model`` (what ``model`` was before some
        ``carry_history``: a trial step undone)."""
        if model is not self.model:
            self.model = model
            self._models.clear()
