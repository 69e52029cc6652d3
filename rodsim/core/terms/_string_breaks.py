"""Where a string tendon's turns are split: at the routing points where another string
tendon on the same catheter starts or ends, the catheter's curvature jumps and the path may
turn back or out of its plane, so the capstan law takes the turn there in two parts
(rodsim/core/tendon_friction.py, "Split turns"). Applied once to a model's terms
(rodsim/core/model.py)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rodsim.core.terms.tendon_string import TendonString

__all__ = ["SPLIT_AT", "split_at_breaks"]

#: A routing point within this fraction of the catheter's length of another string tendon's
#: start or end has its turn split (``split_at_breaks``).
SPLIT_AT = 1e-9


def split_at_breaks(terms: Sequence[object]) -> None:
    """Mark on every string tendon with friction among ``terms`` the routing points where
    another string tendon on its catheter starts or ends (its ``split``): there the
    catheter's curvature jumps, and the path may turn back or out of its plane
    (rodsim/core/tendon_friction.py, "Split turns")."""
    strings = [t for t in (getattr(term, "string", term) for term in terms)
               if isinstance(t, TendonString)]
    for term in strings:
        if not term.rubs:
            continue
        rod = term.tendon.catheter
        breaks = np.array([s for other in strings if other is not term
                           and other.tendon.catheter is rod for s in (other.start, other.end)])
        if len(breaks):
            near = np.abs(term.points.s[:, None] - breaks[None, :]) <= SPLIT_AT * rod.length
            split = np.any(near, axis=1)
            split[[0, -1]] = False  # the entry's turn is its own; the termination has none
            term.split = split
