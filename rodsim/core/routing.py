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

The same ``Routing`` gives the discrete model its offsets and the Rucker–Webster
reference (rodsim/core/analytic/tendon_bvp.py) ρ and ρ′. ``check_routing`` validates a
routing against its catheter (one-line SceneError), including the sampling rule below.

Sampling: the discrete tendon path is the polygon through routing points at the catheter's
nodes (rodsim/core/terms/_string_points.py), so a routing that turns faster than the nodes
sample it is aliased: a helix of pitch h (one segment per turn) is seen as a constant offset
and bends the catheter the wrong way (catheter-helical with helix_pitch = 0.004 m at N = 41
moved the tip 0.159 L sideways; the Rucker–Webster reference and N = 321 agree on y ≈ 0).
``check_routing`` refuses a helix with fewer than ``SEGMENTS_PER_TURN`` segments per
turn and a table whose knots are closer than ``SEGMENTS_PER_KNOT`` segments (a cubic
spline's shortest wave spans two knot spacings: the same four segments per wave), naming
the number of nodes that is enough. Measured on catheter-helical (tip error / L against the
reference): 1 segment per turn 1.6e-1, 2: 7e-4 – 1.5e-3, 4: 1.4e-4 – 6.3e-4, 8: 6e-5 – 4e-4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.schema import SceneError, shown

__all__ = ["ROUTINGS", "SEGMENTS_PER_KNOT", "SEGMENTS_PER_TURN", "Routing", "check_routing",
           "routing_limits", "string_span"]

#: The routing forms.
ROUTINGS = ("constant", "table", "helix")

#: Samples of the span on which the routing's offset is checked against the catheter.
_CHECK_SAMPLES = 2001

#: Fewest catheter segments per turn of a helical routing (module docstring, "Sampling").
SEGMENTS_PER_TURN = 4

#: Fewest catheter segments per knot spacing of a tabulated routing (two per spacing: four
#: per the shortest wave a cubic spline through the knots can make).
SEGMENTS_PER_KNOT = 2


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

    def second_derivatives(self, s: np.ndarray) -> np.ndarray:
        """ρ″(s), shape (len(s), 2) [1/m] (the friction reference's tendon curvature,
        rodsim/core/analytic/tendon_friction_bvp.py)."""
        s = np.asarray(s, dtype=float)
        if self.kind == "constant" or (self.kind == "table" and len(self.knots[0]) == 1):
            return np.zeros((len(s), 2))
        if self.kind == "helix":
            pitch = self.values[1]
            return -(2.0 * math.pi / pitch) ** 2 * self.offsets(s)
        return self._spline()(s, 2)


def string_span(string: Any, length: float) -> tuple[float, float]:
    """(start, end) arc lengths [m] of a string tendon on a catheter of ``length``
    (``end = 0`` means the tip)."""
    return float(string.start), float(string.end) if string.end > 0.0 else float(length)


def _check_sampling(key: str, string: Any, length: float, nodes: int, start: float,
                    end: float) -> None:
    """Refuse a routing that turns faster than the catheter's ``nodes`` sample it (module
    docstring, "Sampling"); the message names the number of nodes that is enough."""
    segment = length / (nodes - 1)
    if string.routing == "helix":
        feature, per, what = abs(string.helix_pitch), SEGMENTS_PER_TURN, "turn (helix_pitch)"
        shown_value = f"helix_pitch = {string.helix_pitch!r} m"
    elif string.routing == "table" and len(string.table_s) > 1:
        s = np.asarray(string.table_s, dtype=float)
        inside = (s[1:] > start) & (s[:-1] < end)  # the knot spacings the span meets
        if not np.any(inside):
            return
        feature = float(np.min(np.diff(s)[inside]))
        per, what = SEGMENTS_PER_KNOT, "knot spacing of table_s"
        shown_value = f"table_s has knots {feature:.6g} m apart"
    else:
        return
    if segment * per <= feature * (1.0 + 1e-9):
        return
    enough = math.ceil(per * length / feature * (1.0 - 1e-12)) + 1
    raise SceneError(f"{key}: {shown_value}, but the catheter's segments are "
                     f"{segment:.6g} m long: fewer than {per} segments per {what}, so the "
                     f"nodes alias the routing; allowed: nodes >= {enough} on this catheter, "
                     f"or a routing that turns more slowly")


def routing_limits(string: Any, length: float, radius: float, nodes: int
                   ) -> dict[str, tuple[float, float, str]]:
    """The range each number of a string tendon may take, one at a time, under the rules of
    ``check_routing``: name -> (low, high, the rule), for ``start``, ``end``,
    ``helix_radius``, ``helix_pitch`` (its hand kept), ``table_y`` and ``table_z`` (each
    knot's offset) and the tendon table's ``offset``. ``end`` = 0 lies outside its range:
    it names the tip, and a termination to vary is given as a number (L). What varies the
    routing (fit, reach, a track's ramp) is bounded by these before any work;
    ``check_routing`` still judges each whole scene (a spline can overshoot its knots).
    """
    start, end = string_span(string, length)
    room = 1e-9 * length  # strict inequalities, as closed bounds
    wall = length if string.spacers else radius
    where = "below the catheter's length (spacers)" if string.spacers else (
        "inside the catheter's radius")
    limits = {"start": (0.0, end - room, f"0 <= start < end = {end!r} m")}
    limits["end"] = (start + room, length, f"start = {start!r} < end <= L = {length!r} m (end "
                     "= 0 names the tip and cannot vary: give end = L)")
    limits["offset"] = (0.0, wall * (1 - 1e-9), f"offset >= 0, {where} ({wall!r} m)")
    limits["helix_radius"] = (1e-300, wall * (1 - 1e-9), f"helix_radius > 0, {where} "
                              f"({wall!r} m)")
    turn = SEGMENTS_PER_TURN * length / (nodes - 1)
    text = (f"|helix_pitch| >= {SEGMENTS_PER_TURN} segments = {turn:.6g} m (the nodes "
            "sample each turn), of the scene's hand")
    limits["helix_pitch"] = ((turn, math.inf, text) if string.helix_pitch >= 0.0
                             else (-math.inf, -turn, text))
    for axis in ("table_y", "table_z"):
        limits[axis] = (-wall * (1 - 1e-9), wall * (1 - 1e-9), f"|{axis}| {where} "
                        f"({wall!r} m)")
    return limits


def check_routing(prefix: str, tendon: Any, string: Any, length: float,
                  radius: float, nodes: int | None = None) -> None:
    """Validate a string tendon's span and routing on a catheter of ``length``, ``radius``
    and ``nodes`` (None: the sampling rule is not checked) (raises SceneError); ``prefix``
    is the tendon table's key."""
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
    if nodes is not None:
        _check_sampling(key, string, length, nodes, start, end)
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
        if 0.0 < string.disk_radius < largest:
            raise SceneError(f"{key}.disk_radius = {string.disk_radius!r}: the routing "
                             f"reaches {largest:.6g} m from the centerline, outside the disks; "
                             f"allowed: 0 (1.2 × the largest offset) or >= {largest:.6g} [m]")
    elif string.disk_radius != 0.0:
        raise SceneError(f"{key}.disk_radius = {string.disk_radius!r}: a tendon without "
                         "spacers rides on no disks; allowed: spacers = true, or leave "
                         "disk_radius unset")
    elif largest >= radius:
        raise SceneError(f"{key}: the routing reaches {largest:.6g} m from the centerline, "
                         f"outside the catheter (radius {radius!r} m); allowed: an offset "
                         "below the radius, or spacers = true (the tendon rides on spacer "
                         "disks)")
