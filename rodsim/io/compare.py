"""Comparing stored and recomputed shapes (``rodsim rerun``): any NaN is a difference."""

from __future__ import annotations

import numpy as np

__all__ = ["largest_distance", "largest_rod_distance"]


def largest_distance(stored: np.ndarray, new: np.ndarray) -> float:
    """Largest Euclidean distance [m] between matching points (last axis: x, y, z).

    Infinite when the shapes differ or either array holds a non-finite value: a NaN in a
    stored or recomputed shape is a difference, never a match (``max(0, nan)`` would hide
    it, and ``nan > tolerance`` is false).
    """
    stored, new = np.asarray(stored, dtype=float), np.asarray(new, dtype=float)
    if stored.shape != new.shape or not (np.all(np.isfinite(stored))
                                         and np.all(np.isfinite(new))):
        return float("inf")
    if stored.size == 0:
        return 0.0
    with np.errstate(over="ignore"):  # 1e300 apart: an infinite distance, no warning
        return float(np.max(np.linalg.norm(stored - new, axis=-1)))


def largest_rod_distance(stored: np.ndarray, stored_rods: np.ndarray, new: np.ndarray,
                         new_rods: np.ndarray) -> float:
    """``largest_distance`` between two sets of control points (node axis second to
    last) matched rod by rod through their ``rod`` labels: a re-run scene read back from
    ``scene_json`` (sorted keys) lists its rods alphabetically, which need not be the order
    of the stored archive. Infinite when the rods differ."""
    stored_rods, new_rods = np.asarray(stored_rods).astype(str), np.asarray(new_rods).astype(str)
    names = list(dict.fromkeys(stored_rods))
    if sorted(names) != sorted(set(new_rods)):
        return float("inf")
    order_stored = np.concatenate([np.flatnonzero(stored_rods == name) for name in names])
    order_new = np.concatenate([np.flatnonzero(new_rods == name) for name in names])
    return largest_distance(np.take(stored, order_stored, axis=-2),
                            np.take(new, order_new, axis=-2))
