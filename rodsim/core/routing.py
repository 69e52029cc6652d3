"""A string tendon's routing: its offset ρ(s) from the catheter's centerline, in the body frame.

The tendon of the ``string`` coupling (rodsim/core/terms/tendon_string.py) runs through
routing points carried by its catheter: at rest arc length s the point is
r(s) + ρ_y(s) d1(s) + ρ_z(s) d2(s), with (ρ_y, ρ_z) = ρ(s) in metres. Three forms
(``[tendons.<name>.tendon_string].routing``):

- ``constant``: ρ = offset · (α, β) with the tendon table's ``offset`` and ``direction``
  (the keys the rod tendons use);
- ``table``: ρ tabulated at increasing arc lengths ``table_s`` (``table_y``, ``table_z``),
  interpolated by a cubic spline with not-a-knot ends (scipy ``CubicSpline``; C², so the
  tendon's path has a continuous tangent and no kink between the knots);
- ``helix``: ρ = radius (cos φ, sin φ), φ = phase + 2π s / pitch (a negative pitch turns
  the other way).

The same :class:`Routing` gives the discrete model its offsets and the Rucker–Webster
reference (rodsim/core/analytic/tendon_bvp.py) ρ and ρ′. :func:`check_routing` validates a
routing against its catheter (one-line SceneError).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.schema import SceneError, shown

__all__ = ["ROUTINGS", "Routing", "check_routing", "string_span"]

#: The routing forms.
ROUTINGS = ("constant", "table", "helix")

#: Samples of the span on which the routing's offset is checked against the catheter.
_CHECK_SAMPLES = 2001


@dataclass(frozen=True)
class Routing:
    """ρ(s) and ρ′(s) of one string tendon (see the module docstring)."""

    kind: str
    #: constant: (ρ_y, ρ_z); helix: (radius, pitch, phase); table: unused.
    values: tuple[float, ...] = ()
    #: table: the knots (s, y, z).
    table: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]] | None = None

    @classmethod
    def of(cls, offset: float, direction: Any, string: Any) -> Routing:
        """The routing of a tendon table with ``offset`` and ``direction`` (α, β) whose
        ``tendon_string`` options are ``string``."""
        if string.routing == "constant":
            a, b = direction
            norm = math.hypot(a, b)
            return cls("constant", (offset * a / norm, offset * b / norm))
        if string.routing == "helix":
            return cls("helix", (string.helix_radius, string.helix_pitch, string.helix_phase))
        return cls("table", table=(tuple(string.table_s), tuple(string.table_y),
                                   tuple(string.table_z)))

    @property
    def knots(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        """The knots (s, y, z) of a ``table`` routing (ValueError for the other kinds)."""
        if self.table is None:
            raise ValueError(f"a {self.kind!r} routing has no table")
        return self.table

    def _spline(self) -> Any:
        from scipy.interpolate import CubicSpline

        s, y, z = (np.asarray(v, dtype=float) for v in self.knots)
        return CubicSpline(s, np.stack([y, z], axis=1), bc_type="not-a-knot")

    def offsets(self, s: np.ndarray) -> np.ndarray:
        """ρ(s), shape (len(s), 2) [m]."""
        s = np.asarray(s, dtype=float)
        if self.kind == "constant":
            return np.tile(np.asarray(self.values), (len(s), 1))
        if self.kind == "helix":
            radius, pitch, phase = self.values
            angle = phase + 2.0 * math.pi * s / pitch
            return radius * np.stack([np.cos(angle), np.sin(angle)], axis=1)
        if len(self.knots[0]) == 1:
            return np.tile([self.knots[1][0], self.knots[2][0]], (len(s), 1))
        return self._spline()(s)

    def derivatives(self, s: np.ndarray) -> np.ndarray:
        """ρ′(s), shape (len(s), 2) [-]."""
        s = np.asarray(s, dtype=float)
        if self.kind == "constant" or (self.kind == "table" and len(self.knots[0]) == 1):
            return np.zeros((len(s), 2))
        if self.kind == "helix":
            radius, pitch, phase = self.values
            rate = 2.0 * math.pi / pitch
            angle = phase + rate * s
            return radius * rate * np.stack([-np.sin(angle), np.cos(angle)], axis=1)
        return self._spline()(s, 1)


def string_span(string: Any, length: float) -> tuple[float, float]:
    """(start, end) arc lengths [m] of a string tendon on a catheter of ``length``
    (``end = 0`` means the tip)."""
    return float(string.start), float(string.end) if string.end > 0.0 else float(length)


def check_routing(prefix: str, tendon: Any, string: Any, length: float,
                  radius: float) -> None:
    """Validate a string tendon's span and routing on a catheter of ``length`` and ``radius``
    (raises SceneError); ``prefix`` is the tendon table's key."""
    key = f"{prefix}.tendon_string"
    start, end = string_span(string, length)
    if end > length * (1 + 1e-12):
        raise SceneError(f"{key}.end = {string.end!r}: the termination lies beyond the "
                         f"catheter's tip; allowed: 0 (the tip) or start < end <= L = "
                         f"{length!r} [m]")
    if start >= end:
        raise SceneError(f"{key}.start = {start!r}: not before the termination end = {end!r}; "
                         f"allowed: 0 <= start < end [m]")
    if string.routing == "table":
        s, y, z = string.table_s, string.table_y, string.table_z
        if not s:
            raise SceneError(f"{key}.table_s = []: routing = 'table' needs at least one point")
        if not len(s) == len(y) == len(z):
            raise SceneError(f"{key}: table_s, table_y, table_z have {len(s)}, {len(y)}, "
                             f"{len(z)} values; allowed: the same number")
        if any(b <= a for a, b in zip(s[:-1], s[1:], strict=True)):
            raise SceneError(f"{key}.table_s = {shown(s)}: not strictly increasing; allowed: "
                             "increasing arc lengths [m]")
        if s[0] < 0.0 or s[-1] > length * (1 + 1e-12):  # a knot off the catheter
            raise SceneError(f"{key}.table_s = {shown(s)}: outside the catheter; allowed: "
                             f"arc lengths from 0 to L = {length!r} [m]")
        if len(s) > 1 and (s[0] > start + 1e-12 * length or s[-1] < end - 1e-12 * length):
            raise SceneError(f"{key}.table_s = {shown(s)}: does not cover the tendon's span "
                             f"[{start!r}, {end!r}] m; allowed: table_s[0] <= start and "
                             "table_s[-1] >= end")
    elif string.routing == "helix":
        if string.helix_radius <= 0.0:
            raise SceneError(f"{key}.helix_radius = {string.helix_radius!r}: routing = "
                             "'helix' needs a radius; allowed: > 0 [m]")
        if string.helix_pitch == 0.0:
            raise SceneError(f"{key}.helix_pitch = 0.0: allowed: a non-zero arc length per "
                             "turn [m] (negative: the other hand)")
    routing = Routing.of(tendon.offset, tendon.direction, string)
    samples = np.linspace(start, end, _CHECK_SAMPLES)
    if string.routing == "table":
        samples = np.union1d(samples, [v for v in string.table_s if start <= v <= end])
    offset = np.hypot(*routing.offsets(samples).T)
    if not np.all(np.isfinite(offset)):
        raise SceneError(f"{key}: the routing's offset is not finite")
    largest = float(offset.max())
    if string.spacers:
        if string.routing != "table" and largest <= 0.0:
            raise SceneError(f"{key}: an offset of 0 needs no spacers; allowed: an offset > 0")
        if largest >= length:
            raise SceneError(f"{key}: the routing reaches {largest:.6g} m from the "
                             f"centerline, not below the catheter's length {length!r} m; "
                             "allowed: spacer disks smaller than the catheter is long")
    elif largest >= radius:
        raise SceneError(f"{key}: the routing reaches {largest:.6g} m from the centerline, "
                         f"outside the catheter (radius {radius!r} m); allowed: an offset "
                         "below the radius, or spacers = true (the tendon rides on spacer "
                         "disks)")
