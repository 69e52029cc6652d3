"""The step-size controller of the error-controlled midpoint rule
(rodsim/solvers/physical/error_control.py; docs/dynamics.md, "The midpoint rule under
error control"): from a step's scaled error err (accepted when err ≤ 1) the factor by which
the next step's length changes.

The local error estimate is O(h^k) with k = 3 (the midpoint rule is of order 2).

- **Elementary** (Hairer, Nørsett & Wanner I, II.4): factor = ``SAFETY`` · err^(−1/k).
- **PI** (Gustafsson 1991; Söderlind 2002; Hairer & Wanner II, IV.2): on an accepted
  step that follows an accepted one, factor = (θ/err_n)^(``K_I``/k) ·
  (err_{n−1}/err_n)^(``K_P``/k), err_{n−1} the last accepted step's (floored at
  ``FLOOR``): the integral part follows the error's level, the proportional part damps the
  oscillation of the step sequence that the elementary controller's over-reaction drives
  (a step grown to where it is rejected, cut, grown again). θ = ``SAFETY``^k is the err
  at which the elementary factor is 1, so that both controllers aim at the same error per
  step (the safety factor written outside the powers, SAFETY · err^(−(K_I + K_P)/k) …,
  would aim at SAFETY^(k/K_I) = 0.11 instead and shrink the steps: measured, the released
  steel rod at rtol 1e-5 took 576 steps instead of 126). After a rejection and on the
  first step the elementary factor is used (no accepted err_{n−1}: Gustafsson's restart).

Both are bounded to [``FAC_MIN``, ``FAC_MAX``]; after a rejection the factor is at most 1
(the caller's rule). No clock and no state but the last accepted err: the same run gives
the same steps bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["StepController", "SAFETY", "FAC_MIN", "FAC_MAX", "ORDER", "K_I", "K_P",
           "FLOOR"]

#: The controller's safety factor and its bounds on a step's change.
SAFETY = 0.8
FAC_MIN = 0.2
FAC_MAX = 2.0
#: k: the local error estimate's order in h.
ORDER = 3
#: The PI controller's integral and proportional gains × k (Gustafsson's 0.3 and 0.4).
K_I = 0.3
K_P = 0.4
#: The smallest err_{n−1} the PI controller divides by (as DOPRI5's 1e-4).
FLOOR = 1e-4


@dataclass
class StepController:
    """The factor for the next step from the last one's err; ``kind`` "elementary" or "pi"
    (module docstring)."""

    kind: str = "elementary"
    #: The last accepted step's err (NaN: none since the start or the last rejection).
    previous: float = math.nan

    def rejected(self, error: float) -> float:
        """The factor (≤ 1) for the retry of a step rejected with ``error`` (> 1; inf when
        its Newton failed: ``FAC_MIN``)."""
        self.previous = math.nan
        return min(1.0, self._elementary(error))

    def accepted(self, error: float) -> float:
        """The factor for the step after one accepted with ``error`` (≤ 1)."""
        previous, self.previous = self.previous, max(error, FLOOR)
        if self.kind == "elementary" or math.isnan(previous):
            return self._elementary(error)
        if error == 0.0:
            return FAC_MAX
        factor = ((SAFETY ** ORDER / error) ** (K_I / ORDER)
                  * (previous / error) ** (K_P / ORDER))
        return min(FAC_MAX, max(FAC_MIN, factor))

    @staticmethod
    def _elementary(error: float) -> float:
        if error == 0.0:
            return FAC_MAX
        if not math.isfinite(error):
            return FAC_MIN
        return min(FAC_MAX, max(FAC_MIN, SAFETY * error ** (-1.0 / ORDER)))
