"""Compiled :meth:`rodsim.core.model.Model.step`: the Newton step with each rod's segment lengths
and each endpoint coupling's length kept to first order (the numpy code in model.py is the
reference; tests/test_static_tendon.py checks that the two agree). Standalone: no other
kernel calls it."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _value(x: np.ndarray, dx: np.ndarray, rest: np.ndarray, free_of: np.ndarray, n: int,
           index: int, moved: bool) -> float:
    f = free_of[index]
    if f >= n:
        return rest[index]
    return x[f] + dx[f] if moved else x[f]


@njit(cache=True)
def retract(x: np.ndarray, dx: np.ndarray, y: np.ndarray, rest: np.ndarray,
            free_of: np.ndarray, chains: np.ndarray, starts: np.ndarray,
            couplings: np.ndarray) -> None:
    """Write into ``y`` (= x + dx on entry) the retracted step; ``chains`` holds the full
    position indices (node, 3) of every rod, rod k in rows starts[k]:starts[k+1];
    ``couplings`` the free indices (catheter tip 0–2, tendon tip 3–5) of every coupling."""
    n = x.shape[0]
    old_prev = np.empty(3)
    moved_prev = np.empty(3)
    new_prev = np.empty(3)
    old = np.empty(3)
    moved = np.empty(3)
    for k in range(starts.shape[0] - 1):
        first = starts[k]
        for a in range(3):
            old_prev[a] = _value(x, dx, rest, free_of, n, chains[first, a], False)
            moved_prev[a] = _value(x, dx, rest, free_of, n, chains[first, a], True)
            new_prev[a] = moved_prev[a]
        for i in range(first + 1, starts[k + 1]):
            length2 = 0.0
            dot = 0.0
            moved2 = 0.0
            for a in range(3):
                old[a] = _value(x, dx, rest, free_of, n, chains[i, a], False)
                moved[a] = _value(x, dx, rest, free_of, n, chains[i, a], True)
                edge = old[a] - old_prev[a]
                length2 += edge * edge
                dot += edge * ((moved[a] - old[a]) - (moved_prev[a] - old_prev[a]))
                step = moved[a] - moved_prev[a]
                moved2 += step * step
            length = np.sqrt(length2)
            factor = (length + dot / length) / np.sqrt(moved2)
            for a in range(3):
                value = new_prev[a] + factor * (moved[a] - moved_prev[a])
                f = free_of[chains[i, a]]
                if f < n:
                    y[f] = value
                old_prev[a] = old[a]
                moved_prev[a] = moved[a]
                new_prev[a] = value
    for c in range(couplings.shape[0]):
        length2 = 0.0
        dot = 0.0
        new2 = 0.0
        for a in range(3):
            edge = x[couplings[c, 3 + a]] - x[couplings[c, a]]
            length2 += edge * edge
            dot += edge * (dx[couplings[c, 3 + a]] - dx[couplings[c, a]])
            step = y[couplings[c, 3 + a]] - y[couplings[c, a]]
            new2 += step * step
        if length2 == 0.0:
            continue
        length = np.sqrt(length2)
        factor = (length + dot / length) / np.sqrt(new2)
        for a in range(3):
            y[couplings[c, 3 + a]] = y[couplings[c, a]] + factor * (
                y[couplings[c, 3 + a]] - y[couplings[c, a]])
