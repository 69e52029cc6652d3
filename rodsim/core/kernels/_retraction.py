"""Compiled retractions of a Newton step: ``rodsim.core.model.Model.step`` (``retract``: each
rod's segment lengths and each endpoint coupling's length kept to first order; the numpy code
in model.py is the reference, tests/test_static_tendon.py checks that the two agree) and
``rodsim.core.model.Model.turned_step`` (``turn``: each segment turned as a rigid frame,
then the endpoint couplings as in ``retract``; the reference is
``rodsim.core.rod.retraction.turn_segments``, checked by tests/test_retraction_frames.py).
Standalone: no other kernel calls them."""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.rod.quaternion import DIRECTOR_FORMS

_FORMS = np.ascontiguousarray(DIRECTOR_FORMS)
# Each director form A[k, m] (Eq. 2: D(q)[k, m] = qᵀ A[k, m] q) has one non-zero entry, ±1,
# in each row a, at column _PAIR[k, m, a] with sign _SIGN[k, m, a]: the compiled sums
# below take that one term where the full row sums 0 · q[b] over the three others, the
# same numbers for finite q (a sum of terms from +0 is +0 when it is zero, so no zero's
# sign reaches a result), a quarter of the arithmetic (``turn`` was ~19 µs of each of
# tdcr-two-segment's Newton steps).
_PAIR = np.argmax(_FORMS != 0.0, axis=3).astype(np.int64)
_SIGN = np.take_along_axis(_FORMS, _PAIR[..., None], axis=3)[..., 0].copy()
assert np.array_equal(np.count_nonzero(_FORMS, axis=3), np.ones((3, 3, 4), dtype=np.int64))
assert np.all(np.abs(_SIGN) == 1.0)


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
    _couplings(x, dx, y, couplings)


@njit(cache=True)
def _couplings(x: np.ndarray, dx: np.ndarray, y: np.ndarray, couplings: np.ndarray) -> None:
    """Each endpoint coupling's tendon tip (free indices 3–5) put about its catheter tip
    (0–2) at the length the linearisation predicts, in the direction of ``y``'s."""
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


@njit(cache=True)
def _frame(q: np.ndarray, frame: np.ndarray) -> float:
    """frame ← D(q) / |q|² (rows d_k, Eq. 2); returns |q|²."""
    norm2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]
    for k in range(3):
        for m in range(3):
            value = 0.0
            for i in range(4):
                value += q[i] * (_SIGN[k, m, i] * q[_PAIR[k, m, i]])
            frame[k, m] = value / norm2
    return norm2


@njit(cache=True)
def turn(x: np.ndarray, dx: np.ndarray, y: np.ndarray, rest: np.ndarray, free_of: np.ndarray,
         chains: np.ndarray, starts: np.ndarray, quaternions: np.ndarray,
         couplings: np.ndarray) -> None:
    """Write into ``y`` (= x + dx on entry) the step with each rod's segments turned as rigid
    frames (rodsim/core/rod/retraction.py, same formulas), then the endpoint couplings as in
    ``retract``. ``chains`` holds the full position indices (node, 3) of every rod, rod k
    in rows starts[k]:starts[k+1]; ``quaternions`` the full quaternion indices (segment, 4),
    rod k in rows starts[k] − k:starts[k+1] − k − 1; ``couplings`` as in ``retract``."""
    n = x.shape[0]
    q = np.empty(4)
    dq = np.empty(4)
    turned = np.empty(4)
    frame = np.empty((3, 3))
    new_frame = np.empty((3, 3))
    body = np.empty(3)
    old = np.empty(3)
    old_next = np.empty(3)
    moved_base = np.empty(3)
    walked = np.empty(3)
    walked_base = np.empty(3)
    edges = np.empty(3)  # this segment's edge and its step's change, per axis
    steps = np.empty(3)
    for k in range(starts.shape[0] - 1):
        first = starts[k]
        last = starts[k + 1]
        # The node the walk restarts from (the last held node, or the rod's first).
        for a in range(3):
            moved_base[a] = _value(x, dx, rest, free_of, n, chains[first, a], True)
            walked[a] = 0.0
            walked_base[a] = 0.0
        for i in range(first, last - 1):
            s = i - k  # this segment's row in quaternions
            for a in range(4):
                q[a] = _value(x, dx, rest, free_of, n, quaternions[s, a], False)
                dq[a] = _value(x, dx, rest, free_of, n, quaternions[s, a], True) - q[a]
            norm2 = _frame(q, frame)
            along = q[0] * dq[0] + q[1] * dq[1] + q[2] * dq[2] + q[3] * dq[3]
            # body = R (e + Δe) + ΔR e, ΔR[k, m] = 2 qᵀ A[k, m] Δq / |q|² − 2 R[k, m] q·Δq / |q|².
            for a in range(3):
                old[a] = _value(x, dx, rest, free_of, n, chains[i, a], False)
                old_next[a] = _value(x, dx, rest, free_of, n, chains[i + 1, a], False)
                edges[a] = old_next[a] - old[a]
                steps[a] = ((_value(x, dx, rest, free_of, n, chains[i + 1, a], True)
                             - old_next[a])
                            - (_value(x, dx, rest, free_of, n, chains[i, a], True) - old[a]))
            for c in range(3):
                value = 0.0
                for m in range(3):
                    edge = edges[m]
                    step = steps[m]
                    form = 0.0
                    for a in range(4):
                        form += q[a] * (_SIGN[c, m, a] * dq[_PAIR[c, m, a]])
                    change = 2.0 * form / norm2 - 2.0 * frame[c, m] * (along / norm2)
                    value += frame[c, m] * (edge + step) + change * edge
                body[c] = value
            size = 0.0
            for a in range(4):
                turned[a] = q[a] + dq[a]
                size += turned[a] * turned[a]
            norm = np.sqrt(norm2)
            factor = (norm + along / norm) / np.sqrt(size)
            for a in range(4):
                turned[a] *= factor
            _frame(turned, new_frame)
            for a in range(4):
                f = free_of[quaternions[s, a]]
                if f < n:
                    y[f] = turned[a]
            # The next node: walked from the last held node (kept where it is if held).
            held = True
            for a in range(3):
                if free_of[chains[i + 1, a]] < n:
                    held = False
            for m in range(3):
                value = 0.0
                for c in range(3):
                    value += new_frame[c, m] * body[c]
                walked[m] += value
            if held:
                for a in range(3):
                    moved_base[a] = _value(x, dx, rest, free_of, n, chains[i + 1, a], True)
                    walked_base[a] = walked[a]
            else:
                for a in range(3):
                    f = free_of[chains[i + 1, a]]
                    if f < n:
                        y[f] = moved_base[a] + walked[a] - walked_base[a]
    _couplings(x, dx, y, couplings)


@njit(cache=True)
def _largest(values: np.ndarray) -> float:
    """max |values| from 0 (NaN once any value is NaN): numpy's ``np.abs(v).max(initial=0.0)``."""
    largest = 0.0
    for value in values:
        size = abs(value)
        if largest == largest and not size <= largest:
            largest = size
    return largest


@njit(cache=True)
def turn_offsets(x: np.ndarray, dx: np.ndarray, reference: np.ndarray, roundoff: float,
                 rest: np.ndarray, free_of: np.ndarray, chains: np.ndarray,
                 starts: np.ndarray, quaternions: np.ndarray,
                 couplings: np.ndarray) -> np.ndarray:
    """``turn`` on the offset state ``x`` (``reference``: the rest state at the free
    coordinates), as ``rodsim.core.model_manifold.ModelManifold._retracted`` applies it, the
    same operations in the same order: x + dx plus the correction turn(a, dx) − (a + dx),
    a = reference + x, or x + dx alone when that correction's largest entry is within
    ``roundoff`` (max |a| + max |dx|)."""
    n = x.shape[0]
    absolute = np.empty(n)
    linear = np.empty(n)
    for i in range(n):
        absolute[i] = reference[i] + x[i]
        linear[i] = absolute[i] + dx[i]
    turned = linear.copy()
    turn(absolute, dx, turned, rest, free_of, chains, starts, quaternions, couplings)
    correction = np.empty(n)
    for i in range(n):
        correction[i] = turned[i] - linear[i]
    noise = roundoff * (_largest(absolute) + _largest(dx))
    out = np.empty(n)
    keep = _largest(correction) <= noise
    for i in range(n):
        out[i] = x[i] + dx[i] if keep else (x[i] + dx[i]) + correction[i]
    return out
