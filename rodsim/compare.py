"""Comparing stored and recomputed shapes (``rodsim rerun``): any NaN is a difference."""

from __future__ import annotations

import numpy as np

__all__ = ["largest_distance"]


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
