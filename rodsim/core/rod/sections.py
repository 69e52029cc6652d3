"""Cross-sections and materials that vary along a rod: ``[[rods.<name>.sections]]`` spans.

A rod without ``sections`` is uniform, with the rod table's own values. With ``sections``,
the spans must cover the rod exactly: the first starts at s = 0, each starts where the one
before ends, the last ends at s = L (docs/model.md, "Sections that vary along a rod"). A
span's material and radius default to the rod table's own values (read when the rod is
built, so that changing the rod's value changes every span that did not set its own); its
area A, second moment I and polar moment J default to those of a tube of ``radius`` and
``inner_radius`` (a solid rod when ``inner_radius`` is 0), and may be given directly for
other shapes (the bending stiffness is isotropic: one I for both bending directions).

How the discrete rod reads a piecewise-constant property p(s) (a boundary may fall anywhere,
not only on a node or a quaternion):

- stiffnesses of springs in series, E_s A of a segment and E I, G J of a bending element over
  its dual length [s_a, s_b] (between the two quaternions' midpoints, or [0, l/2] for the clamp
  element): the harmonic mean ``(1/(s_b − s_a)) ∫ 1/p ds)⁻¹``. Under a constant tension or
  moment it gives the exact stretch or rotation of the span, so a piecewise-uniform rod in
  pure bending keeps the arc's exactness;
- the frame at an arclength s between two quaternions' midpoints a < s < b (a string
  tendon's routing points, rodsim/core/terms/_string_points.py; a body-frame point load,
  rodsim/core/terms/point_loads.py): the weight of q_b is the share
  of the twist compliance 1/(G J) over [a, b] that lies in [a, s], the share of the element's
  rotation under a constant moment reached at s — (s − a)/(b − a) in a uniform span. The
  twist rate jumps with G J where a section ends; there the linear weight ½ puts a node's
  frame, and with it a tendon's routing point, O(h) away from the continuum's, and a tendon
  crossing the jump of a twisted rod converged at first order (measured: issue 20's tip
  moment on catheter-pull-ring, order 1.68, 1.46, 1.24 at N = 41 → 321; with this weight
  1.94, 1.97, 1.99). Only the twist matters to first order: a bending rate's jump moves the
  routing point along the tendon's path, which changes its length at O(δ²). A G J jump
  inside a segment gets a routing point of its own (``changes``), where the path kinks;
- masses and weights: the consistent share ∫ ρ A N_i ds of each control point (N_i the hat
  function of the linear interpolation), which is the usual half-segment lumping for a
  uniform span; a quaternion's rotational mass integrates ρ I over its segment.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.rod.geometry import RodGeometry
from rodsim.core.schema import Parameter, SceneError, shown, validate_table

__all__ = ["SECTION_PARAMETERS", "INHERITED", "SectionProfile", "resolve_sections"]

#: Keys of a span whose default is the rod table's own value.
INHERITED = ("youngs_modulus", "stretch_modulus", "poisson_ratio", "radius", "density")

SECTION_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("start", "float", None, "m", "rest arclength where the span starts", 0.0, 100.0),
    Parameter("end", "float", None, "m", "rest arclength where the span ends", 0.0, 100.0),
    Parameter("youngs_modulus", "float", None, "Pa", "E_b of the span (default: the rod's)",
              1e-3, 1e13),
    Parameter("stretch_modulus", "float", None, "Pa", "E_s of the span (default: the rod's)",
              1e-3, 1e13),
    Parameter("poisson_ratio", "float", None, "-",
              "ν of the span (default: the rod's); G = E_b / (2(1 + ν))", -0.99, 0.5),
    Parameter("shear_modulus", "float", 0.0, "Pa",
              "G of the span; 0: from youngs_modulus and poisson_ratio", 0.0, 1e13),
    Parameter("radius", "float", None, "m", "outer radius of the span (default: the rod's)",
              1e-9, 1.0),
    Parameter("inner_radius", "float", 0.0, "m", "inner radius of a tube (0: a solid rod)",
              0.0, 1.0),
    Parameter("area", "float", 0.0, "m^2",
              "cross-section area A; 0: π (r² − r_i²) from the radii", 0.0, 1.0),
    Parameter("second_moment", "float", 0.0, "m^4",
              "area moment I of bending (both directions); 0: π (r⁴ − r_i⁴) / 4", 0.0, 1.0),
    Parameter("polar_moment", "float", 0.0, "m^4",
              "torsion constant J; 0: π (r⁴ − r_i⁴) / 2", 0.0, 1.0),
    Parameter("density", "float", None, "kg/m^3", "mass density ρ of the span (default: "
              "the rod's)", 1e-3, 1e9),
)


#: Section geometry a span may give itself (0: computed from its radii).
GEOMETRY_OVERRIDES = ("area", "second_moment", "polar_moment")
#: Smallest such value: the smallest normal double, whose reciprocal (the compliance of the
#: span's harmonic mean, :class:`SectionProfile`) is finite; a subnormal 1e-320 made it
#: infinite and every force NaN.
MIN_GEOMETRY = float(np.finfo(float).tiny)


def resolve_sections(raw: Any, rod: Mapping[str, Any], prefix: str) -> list[dict[str, Any]]:
    """The validated spans of ``[[<prefix>.sections]]`` (``rod``: the rod's resolved table),
    each with every default filled in except the rod's own values (``INHERITED``) it does
    not set; SceneError (one line) for bad input, spans that are not increasing, overlap,
    leave a gap or do not cover [0, L]."""
    key = f"{prefix}.sections"
    if not isinstance(raw, (list, tuple)) or not all(isinstance(t, Mapping) for t in raw):
        raise SceneError(f"{key} = {shown(raw)}: wrong type; allowed: a list of tables "
                         f"[[{key}]]", key=key, value=raw, reason="wrong type")
    declared = tuple(Parameter(p.name, p.kind, rod[p.name], p.unit, p.doc, p.minimum,
                               p.maximum) if p.name in INHERITED else p
                     for p in SECTION_PARAMETERS)
    spans = [validate_table(table, declared, f"{key}.{i}") for i, table in enumerate(raw)]
    if not spans:
        raise SceneError(f"{key} = []: no span; allowed: spans covering [0, length], or no "
                         "sections key for a uniform rod", key=key, reason="empty")
    length = float(rod["length"])
    expected = 0.0
    for i, span in enumerate(spans):
        where = f"{key}.{i}"
        if span["start"] != expected:
            what = "overlaps the span before" if span["start"] < expected else "leaves a gap"
            raise SceneError(f"{where}.start = {shown(span['start'])}: {what} (expected "
                             f"{expected!r}); allowed: spans in order, each starting where "
                             "the one before ends, the first at 0", key=f"{where}.start",
                             value=span["start"], reason="not contiguous")
        if not span["end"] > span["start"]:
            raise SceneError(f"{where}.end = {shown(span['end'])}: not above its start "
                             f"{span['start']!r}; allowed: end > start", key=f"{where}.end",
                             value=span["end"], reason="not increasing")
        if span["inner_radius"] >= span["radius"]:
            raise SceneError(f"{where}.inner_radius = {shown(span['inner_radius'])}: not below "
                             f"the radius {span['radius']!r} m; allowed: inner_radius < radius",
                             key=f"{where}.inner_radius", value=span["inner_radius"],
                             reason="out of range")
        for name in GEOMETRY_OVERRIDES:  # 0: from the radii; else a normal number
            if 0.0 < span[name] < MIN_GEOMETRY:  # a subnormal's reciprocal is infinite
                raise SceneError(f"{where}.{name} = {shown(span[name])}: too small; allowed: "
                                 f"0 (from the radii) or at least {MIN_GEOMETRY:g}",
                                 key=f"{where}.{name}", value=span[name],
                                 reason="out of range")
        expected = span["end"]
    if abs(expected - length) > 1e-12 * length:
        raise SceneError(f"{key}.{len(spans) - 1}.end = {shown(expected)}: the sections do "
                         f"not cover the rod (length {length!r} m); allowed: the last span "
                         "ends at the rod's length", key=f"{key}.{len(spans) - 1}.end",
                         value=expected, reason="not covering")
    # The resolved scene keeps an inherited value out of the span, so that a later change of
    # the rod's own value (--set, a fit) still reaches the spans that did not set their own.
    return [{name: value for name, value in span.items()
             if name not in INHERITED or name in table}
            for span, table in zip(spans, raw, strict=True)]


@dataclass(frozen=True)
class SectionProfile:
    """Piecewise-constant section properties of a rod, one entry per span (SI units)."""

    start: np.ndarray
    end: np.ndarray
    youngs_modulus: np.ndarray
    stretch_modulus: np.ndarray
    shear_modulus: np.ndarray
    area: np.ndarray
    second_moment: np.ndarray
    polar_moment: np.ndarray
    density: np.ndarray

    @classmethod
    def of(cls, spans: Sequence[Mapping[str, Any]], rod: Mapping[str, Any]) -> SectionProfile:
        """The profile of resolved ``spans``; ``rod`` gives the values of ``INHERITED``
        a span does not set."""
        def column(name: str) -> np.ndarray:
            return np.array([float(span.get(name, rod.get(name))) for span in spans])

        outer, inner = column("radius"), column("inner_radius")
        area = np.where(column("area") > 0.0, column("area"), math.pi * (outer**2 - inner**2))
        quartic = outer**4 - inner**4
        second = np.where(column("second_moment") > 0.0, column("second_moment"),
                          math.pi * quartic / 4.0)
        polar = np.where(column("polar_moment") > 0.0, column("polar_moment"),
                         math.pi * quartic / 2.0)
        young = column("youngs_modulus")
        shear = np.where(column("shear_modulus") > 0.0, column("shear_modulus"),
                         young / (2.0 * (1.0 + column("poisson_ratio"))))
        return cls(column("start"), column("end"), young, column("stretch_modulus"), shear,
                   area, second, polar, column("density"))

    def overlaps(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Length of [a_e, b_e] inside each span, shape (len(a), spans) [m]."""
        low = np.maximum(np.asarray(a)[:, None], self.start[None, :])
        high = np.minimum(np.asarray(b)[:, None], self.end[None, :])
        return np.maximum(high - low, 0.0)

    def harmonic_mean(self, values: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(1/(b − a)) ∫_a^b 1/p ds)⁻¹ of the per-span ``values`` p over each [a_e, b_e]."""
        overlap = self.overlaps(a, b)
        return np.sum(overlap, axis=1) / (overlap @ (1.0 / values))

    def compliance_fraction(self, values: np.ndarray, a: np.ndarray, s: np.ndarray,
                            b: np.ndarray) -> np.ndarray:
        """Where each s_e lies in [a_e, b_e] measured in the compliance 1/p of the per-span
        ``values`` p: ∫_a^s 1/p ds / ∫_a^b 1/p ds, s clipped to [a, b]. It is the share of
        the rotation across [a, b] under a constant moment that is reached at s, and so the
        weight of the frame at b in the frame at s (module docstring). Where p is the same
        on all of [a_e, b_e] it is the linear clip((s − a)/(b − a), 0, 1), to the bit."""
        a, s, b = (np.asarray(v, dtype=float) for v in (a, s, b))
        linear = np.clip((s - a) / (b - a), 0.0, 1.0)
        overlap = self.overlaps(a, b)
        inside = overlap > 0.0
        compliance = 1.0 / values
        varies = (np.max(np.where(inside, compliance, -np.inf), axis=1)
                  > np.min(np.where(inside, compliance, np.inf), axis=1))
        if not np.any(varies):
            return linear
        reached = self.overlaps(a, np.clip(s, a, b)) @ compliance
        return np.where(varies, reached / np.where(varies, overlap @ compliance, 1.0), linear)

    def changes(self, values: np.ndarray) -> np.ndarray:
        """The span boundaries inside the rod where the per-span ``values`` change [m]."""
        return self.end[:-1][values[1:] != values[:-1]]

    def integral(self, values: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """∫_a^b p ds of the per-span ``values`` over each [a_e, b_e]."""
        return self.overlaps(a, b) @ values

    def node_integral(self, values: np.ndarray, geometry: RodGeometry) -> np.ndarray:
        """∫ p N_i ds for every control point i (consistent share), shape (N,)."""
        out = np.zeros(geometry.nodes)
        for value, start, end in zip(values, self.start, self.end, strict=True):
            out += value * geometry.hat_integrals(start, end)
        return out

    @property
    def uniform(self) -> bool:
        """Whether every span has the same stiffnesses and mass per length."""
        return all(np.all(v == v[0]) for v in (
            self.youngs_modulus * self.second_moment, self.shear_modulus * self.polar_moment,
            self.stretch_modulus * self.area, self.density * self.area))
