"""The state of a model: the free coordinates are offsets from the rest state (docs/model.md,
"The offset state and the residual floor"); the full state (fixed coordinates included)
holds the positions and quaternions themselves; a Newton step moves along a retraction
that keeps the stiff lengths to first order (rodsim/core/rod/retraction.py, compiled in
rodsim/core/kernels/_retraction.py)."""

from __future__ import annotations

from collections.abc import Callable
from functools import cached_property

import numpy as np

from rodsim.core.model_base import ModelBase
from rodsim.core.rod.retraction import turn_segments
from rodsim.core.supports import quaternion_product, rigid_motion

__all__ = ["ModelManifold"]


class ModelManifold(ModelBase):
    """The state part of ``rodsim.core.model.Model`` (module docstring)."""

    @property
    def x0(self) -> np.ndarray:
        """The undeformed rest state (free coordinates): every simulation starts here.

        The free coordinates are offsets from the rest state (``reference``): a
        position's displacement from its rest place, a quaternion's difference from its rest
        quaternion (docs/model.md, "The offset state and the residual floor"); the rest
        state is zero. ``full`` gives the positions and quaternions themselves."""
        return self.rest_offsets[self.free].copy()

    def full(self, x: np.ndarray) -> np.ndarray:
        """Full state (fixed coordinates included) from the free coordinates: the
        positions [m] and quaternions themselves (``reference`` plus the offsets)."""
        out = self.rest_full.copy()
        out[self.free] = self._reference_free() + x
        return out

    def _reference_free(self) -> np.ndarray:
        """``reference`` at the free coordinates, kept for this model's ``free``."""
        kept = self.__dict__.get("_kept_reference")
        if kept is None or kept[0] is not self.free or kept[1] is not self.reference:
            kept = (self.free, self.reference, self.reference[self.free])
            self._kept_reference = kept
        return kept[2]

    def offsets(self, x: np.ndarray) -> np.ndarray:
        """The full state as offsets from ``reference`` (fixed coordinates included):
        what the terms with ``Term.offsets`` are evaluated on."""
        out = self.rest_offsets.copy()
        out[self.free] = x
        return out

    def state_of(self, full: np.ndarray) -> np.ndarray:
        """The free coordinates (offsets) of the full state ``full`` (positions and
        quaternions themselves, as ``full`` gives them): a warm start from a stored
        shape."""
        return full[self.free] - self._reference_free()

    def carried(self, x: np.ndarray, previous: ModelManifold) -> np.ndarray:
        """The state ``x`` of ``previous`` (a model of the same layout) with each rod moved
        rigidly as its base support moved from ``previous`` to this model (an inserted or
        turned base, rodsim/core/supports.py): the warm start of a step that moves the
        base. ``x`` itself when no support moved and both models have the same rest state
        (``reference``); otherwise the same positions and quaternions as offsets from
        this model's rest state."""
        full = None
        for name, rod in self.rods.items():
            motion = rigid_motion(previous.rods[name].support, rod.support)
            if motion is None:
                continue
            if full is None:
                full = previous.full(x)
            turn, q_turn, before, after = motion
            index = rod.layout.position_index
            full[index] = after + (full[index] - before) @ turn.T
            index = rod.layout.quaternion_index
            full[index] = quaternion_product(q_turn, full[index])
        if full is None:
            if previous.reference is self.reference or np.array_equal(previous.reference,
                                                                      self.reference):
                return x
            full = previous.full(x)
        return self.state_of(full)

    def positions(self, x: np.ndarray, rod: str) -> np.ndarray:
        """Control points of one rod, shape (N, 3) [m]."""
        return self.full(x)[self.rods[rod].layout.position_index]

    @cached_property
    def _step_maps(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(full position indices of every rod's nodes, rod k in rows starts[k]:starts[k+1];
        those starts; free indices of the two points of every stiff link a term declares
        (``Term.rigid_links``: the endpoint coupling's catheter and tendon tips) whose
        six coordinates are all free)."""
        couplings = []
        for term in self.terms:
            for link in term.rigid_links():
                free = self._free_of[link]
                if np.all(free < self.n):
                    couplings.append(free)
        chains = [rod.layout.position_index for rod in self.rods.values()]
        starts = np.cumsum([0] + [len(index) for index in chains])
        return (np.ascontiguousarray(np.concatenate(chains), dtype=np.int64),
                starts.astype(np.int64),
                np.array(couplings, dtype=np.int64).reshape(-1, 6))

    @cached_property
    def _quaternion_chains(self) -> np.ndarray:
        """Full quaternion indices (segment, 4) of every rod, in the order of
        ``_step_maps``' chains: rod k in rows starts[k] − k:starts[k+1] − k − 1."""
        return np.ascontiguousarray(np.concatenate(
            [rod.layout.quaternion_index for rod in self.rods.values()]), dtype=np.int64)

    def _absolute(self, x: np.ndarray) -> np.ndarray:
        """The full state from free coordinates that hold the positions and quaternions
        themselves (not offsets): the retractions' own arithmetic."""
        out = self.rest_full.copy()
        out[self.free] = x
        return out

    def _retracted(self, method: Callable[[np.ndarray, np.ndarray], np.ndarray],
                   x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """A retraction ``method`` (on positions and quaternions themselves) applied to the
        offset state ``x``: x + dx plus the retraction's correction, or x + dx alone when
        the whole correction is within the round-off of the retraction's own arithmetic on
        positions (each rod walked from its base: ~N eps L). Taken there, it would put that
        round-off into offsets that resolve far below it; the correction is O(dx²) and that
        small only once the steps are (a Newton solve's last ones)."""
        absolute = self._reference_free() + x
        linear = absolute + dx
        correction = method(absolute, dx) - linear
        # (ndarray.max rather than np.max: the same number without numpy's Python wrapper,
        # a few µs of each of a solve's Newton steps)
        noise = self._chain_roundoff * float(np.abs(absolute).max(initial=0.0)
                                             + np.abs(dx).max(initial=0.0))
        if float(np.abs(correction).max(initial=0.0)) <= noise:
            return x + dx
        return x + dx + correction

    @cached_property
    def _chain_roundoff(self) -> float:
        """4 N eps, N the most nodes of a rod: the round-off of a walk along the longest
        rod relative to its coordinates (``_retracted``)."""
        return 4.0 * max(rod.nodes for rod in self.rods.values()) * np.finfo(float).eps

    def turned_step(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """``step`` with each rod's segments turned as rigid frames instead of their
        lengths kept (rodsim/core/rod/retraction.py; ``solver.static.retraction =
        "frames"``); the endpoint couplings as in ``step``. Equal to x + dx to first
        order in dx (on the offset state: ``_retracted``; compiled, both in one kernel
        call, ``turn_offsets``: the same numbers, ~9 µs less numpy of each of a solve's
        Newton steps on tdcr-two-segment)."""
        if self._compiled():
            from rodsim.core.kernels._retraction import turn_offsets

            chains, starts, couplings = self._step_maps
            return turn_offsets(np.asarray(x, dtype=float), np.asarray(dx, dtype=float),
                                self._reference_free(), self._chain_roundoff,
                                self.rest_full, self._free_of, chains, starts,
                                self._quaternion_chains, couplings)
        return self._retracted(self._turned_absolute, x, dx)

    def _turned_absolute(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """``turned_step`` on free coordinates that are positions and quaternions
        themselves. Compiled (``turn`` of rodsim/core/kernels/_retraction.py) with
        ``kernels = "compiled"``; this numpy code is the reference."""
        if self._compiled():
            from rodsim.core.kernels._retraction import turn

            chains, starts, couplings = self._step_maps
            y = x + dx
            turn(x, dx, y, self.rest_full, self._free_of, chains, starts,
                 self._quaternion_chains, couplings)
            return y
        before, after = self._absolute(x), self._absolute(x + dx)
        for rod in self.rods.values():
            position, quaternion = rod.layout.position_index, rod.layout.quaternion_index
            r, q = before[position], before[quaternion]
            after[position], after[quaternion] = turn_segments(
                r, q, after[position] - r, after[quaternion] - q,
                np.all(self._free_of[position] >= self.n, axis=1))
        y = after[self.free]
        for free in self._step_maps[2]:  # the endpoint couplings, as in step()
            tip, tendon_tip = free[:3], free[3:]
            edge = x[tendon_tip] - x[tip]
            length = float(np.linalg.norm(edge))
            if length > 0.0:
                predicted = length + float(edge @ (dx[tendon_tip] - dx[tip])) / length
                new_edge = y[tendon_tip] - y[tip]
                y[tendon_tip] = y[tip] + predicted * new_edge / np.linalg.norm(new_edge)
        return y

    def step(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """The state a Newton step ``dx`` from ``x`` reaches, with stiff lengths kept to first
        order (a retraction: equal to x + dx to first order in dx; on the offset state:
        ``_retracted``, the arithmetic below on positions: ``_step_absolute``)."""
        return self._retracted(self._step_absolute, x, dx)

    def _step_absolute(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """``step`` on free coordinates that are positions and quaternions themselves.

        A linear step that turns a stiff link of fixed length stretches it by O(δ²), which the
        link's stiffness turns into a force far above the loads: on the paper's coupling the
        endpoint spring (K_C, rest length r_L, no tension at rest) and the catheter's segments
        (stretch and centerline penalty). Here each rod's segments, walked from its base, and
        then each endpoint coupling (the tendon tip about the catheter tip) keep the length
        the linearisation predicts, in the direction of the linear step's. Compiled
        (rodsim/core/kernels/_retraction.py) with ``kernels = "compiled"``; this numpy code is
        the reference.
        """
        chains, starts, couplings = self._step_maps
        y = x + dx
        if self._compiled():
            from rodsim.core.kernels._retraction import retract

            retract(x, dx, y, self.rest_full, self._free_of, chains, starts, couplings)
            return y
        before, after = self._absolute(x), self._absolute(y)
        for k in range(len(starts) - 1):
            index = chains[starts[k]:starts[k + 1]]
            r, moved = before[index], after[index]
            edges = np.diff(r, axis=0)
            length = np.linalg.norm(edges, axis=1)
            predicted = length + np.einsum("ij,ij->i", edges,
                                           np.diff(moved - r, axis=0)) / length
            new_edges = np.diff(moved, axis=0)
            new_edges *= (predicted / np.linalg.norm(new_edges, axis=1))[:, None]
            moved[1:] = moved[0] + np.cumsum(new_edges, axis=0)
            free = self._free_of[index]
            keep = free < self.n
            y[free[keep]] = moved[keep]
        for free in couplings:
            tip, tendon_tip = free[:3], free[3:]
            edge = x[tendon_tip] - x[tip]
            length = float(np.linalg.norm(edge))
            if length == 0.0:
                continue
            predicted = length + float(edge @ (dx[tendon_tip] - dx[tip])) / length
            new_edge = y[tendon_tip] - y[tip]
            y[tendon_tip] = y[tip] + predicted * new_edge / np.linalg.norm(new_edge)
        return y
