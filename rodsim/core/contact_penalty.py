"""The contact penalty law ψ, ψ′, ψ″ (docs/contact.md, "The law"), written once.

    ψ(p) = 0                               p ≤ 0
    ψ(p) = p³ / (6 δ)                      0 < p < δ      (the onset: ψ″ = p/δ rises to 1)
    ψ(p) = p²/2 − δ p/2 + δ²/6             p ≥ δ          (a linear spring, ψ″ = 1)

``onset`` and ``linear`` are plain arithmetic on floats or numpy arrays, so the same
source is the numpy reference (``penalty``, used by rodsim/core/terms/contact.py) and,
compiled by numba, every obstacle type's contact kernel (rodsim/core/kernels/_contact.py).
This module imports no numba. ``p**3`` is numpy's ``pow`` on arrays and, compiled, the
product p·p·p: each path computes the numbers it did when the law was written out in each
(bit-identical: the two may differ in ψ's last bit on the onset, ψ′ and ψ″ never).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["onset", "linear", "penalty"]


def onset(p: Any, delta: float) -> tuple[Any, Any, Any]:
    """ψ, ψ′, ψ″ on the onset 0 < p < δ."""
    return p**3 / (6.0 * delta), p * p / (2.0 * delta), p / delta


def linear(p: Any, delta: float) -> tuple[Any, Any, Any]:
    """ψ, ψ′, ψ″ past the onset, p ≥ δ."""
    return 0.5 * p * p - 0.5 * delta * p + delta * delta / 6.0, p - 0.5 * delta, 1.0


def penalty(p: np.ndarray, delta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ψ(p), ψ'(p), ψ''(p) of the C² penalty at every penetration of ``p`` (arrays)."""
    p = np.asarray(p, dtype=float)
    ramp = (p > 0.0) & (p < delta)
    full = p >= delta
    # where() picks each regime's values; the other regime's are computed and dropped
    with np.errstate(over="ignore", invalid="ignore"):
        ramped, beyond = onset(p, delta), linear(p, delta)
    return tuple(np.where(ramp, r, 0.0) + np.where(full, f, 0.0)  # type: ignore[return-value]
                 for r, f in zip(ramped, beyond, strict=True))
