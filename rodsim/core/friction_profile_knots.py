"""The knots of a friction coefficient given along the arc length,
``tendon_string.friction_profile`` at ``friction_profile_s`` (issue 34; not in the paper;
docs/tendon.md, "Friction along the arc length"): the checks a user's profile must pass
before the string tendon maps it onto its routing points (rodsim/core/tendon_friction.py,
``profile_coefficients``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.schema import SceneError

__all__ = ["checked_knots"]


def checked_knots(prefix: str, options: Any, start: float, end: float) -> np.ndarray:
    """``friction_profile_s`` as an array, after the checks a friction profile needs
    (SceneError, one line): as many arc lengths as values, increasing, within the tendon's
    [start, end], and no ``friction_points`` beside it."""
    values, s = options.friction_profile, np.asarray(options.friction_profile_s, dtype=float)
    if options.friction_points:
        raise SceneError(f"{prefix}.friction_profile and friction_points are both set; "
                         "allowed: one of them (a μ per arc length, or per routing point)")
    if len(values) != len(s) or not len(s):
        raise SceneError(f"{prefix}.friction_profile has {len(values)} values and "
                         f"friction_profile_s {len(s)} arc lengths; allowed: as many of each, "
                         "at least one")
    if np.any(np.diff(s) <= 0.0):
        raise SceneError(f"{prefix}.friction_profile_s = {options.friction_profile_s!r}: "
                         "not increasing; allowed: arc lengths each larger than the one "
                         "before [m]")
    slack = 1e-9 * max(end, 1.0)
    if s[0] < start - slack or s[-1] > end + slack:
        raise SceneError(f"{prefix}.friction_profile_s = {options.friction_profile_s!r}: "
                         f"outside the tendon; allowed: arc lengths within its span "
                         f"[{start:.6g}, {end:.6g}] m (start, end)")
    return s
