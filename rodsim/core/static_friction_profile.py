"""A static friction coefficient along the arc length: ``tendon_string.static_friction_profile``
(issue 34; not in the paper; docs/tendon.md, "Stiction along the arc length").

The user's μ_s(s) is given at the kinetic profile's knots ``friction_profile_s``, piecewise
linear between them and constant beyond, as μ(s) is (rodsim/core/tendon_friction.py, "A μ
per arc length"). It is mapped onto the routing points exactly as μ(s) is
(``profile_coefficients``: μ_s(s_0) at the entry, the mean of μ_s over [m_{j−1}, m_j] at
point j, m the chords' midpoints), and it enters the stick/slip law as one μ_s does
("Per-point coefficients and stiction"): point j breaks loose when the tension ratio over it
exceeds e^{μ̄_s,j θ_j}.

μ_s(s) ≥ μ(s) everywhere: both are linear between the same knots and constant beyond, so
it is enough that it holds at every knot; then every point's mean μ̄_s,j ≥ μ̄_j too (the
mean is monotone), and μ̄_s,j = μ̄_j where the two profiles are equal over the point's
cell (that point then has no static excess).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.schema import SceneError
from rodsim.core.tendon_friction import profile_coefficients

__all__ = ["check_static_profile", "static_profile_coefficients"]


def check_static_profile(options: Any, prefix: str) -> None:
    """SceneError (one line) unless ``static_friction_profile`` is unset or has one value
    per ``friction_profile_s`` knot beside a ``friction_profile``, no ``static_friction``
    beside it, and each value at least the kinetic profile's at the same knot."""
    static = list(options.static_friction_profile)
    if not static:
        return
    kinetic = list(options.friction_profile)
    if not kinetic:
        raise SceneError(f"{prefix}.static_friction_profile is set without friction_profile; "
                         "allowed: a static profile at friction_profile_s beside a kinetic "
                         "friction_profile (or static_friction, one μ_s)")
    if options.static_friction != 0.0:
        raise SceneError(f"{prefix}.static_friction and static_friction_profile are both "
                         "set; allowed: one of them (one μ_s, or μ_s along the arc length)")
    if len(static) != len(kinetic):
        raise SceneError(f"{prefix}.static_friction_profile has {len(static)} values and "
                         f"friction_profile {len(kinetic)}; allowed: one value per "
                         "friction_profile_s arc length")
    below = [k for k, (mu_s, mu) in enumerate(zip(static, kinetic, strict=True)) if mu_s < mu]
    if below:
        k = below[0]
        where = (f" at friction_profile_s = {options.friction_profile_s[k]!r}"
                 if k < len(options.friction_profile_s) else "")
        raise SceneError(f"{prefix}.static_friction_profile[{k}] = {static[k]!r}: smaller "
                         f"than friction_profile[{k}] = {kinetic[k]!r}{where}; allowed: "
                         "μ_s(s) >= μ_k(s) at every knot")


def static_profile_coefficients(options: Any, s: np.ndarray) -> np.ndarray | None:
    """The static μ_s of each turn θ_0 … θ_{P−2} of the routing points at arc lengths
    ``s`` from ``static_friction_profile`` (module docstring); None when it is unset."""
    if not options.static_friction_profile:
        return None
    return profile_coefficients(np.asarray(options.friction_profile_s, dtype=float),
                                np.asarray(options.static_friction_profile, dtype=float), s)
