"""A tendon routed through a lumen of a catheter (paper §4): the shared configuration and the
lumen geometry every coupling term uses.

One ``[tendons.<rod>]`` table per tendon, keyed by the tendon rod's name, holds what the
coupling terms share — which rod is the catheter, the lumen offset r_L, the lumen direction
d_t = α d1 + β d2 (Eq. 32), the coupling variant — plus one sub-table per coupling term
(``[tendons.<rod>.lumen]`` …). The lumen point at catheter node j is
L_j = r_j + r_L d_t(q_j) (Eqs. 24, 32), using the quaternion of the segment that starts at
node j (the last node uses the last segment).

Coupling variants (docs/tendon.md):
- ``paper``: as the paper writes it. The endpoint compliance force Eq. (28) acts on the tendon
  only, and each catheter node receives the *average* of the lumen forces of the tendon
  points registered to it (§4.1), applied at the node. Not momentum-conserving.
- ``conserving``: every coupling is the gradient of a penalty energy, so each force has its
  equal and opposite reaction (including the moment of a force applied at the lumen offset).
- ``string``: no tendon rod. A frictionless tendon under tension T is the potential T ℓ of its
  path through routing points on the catheter (rodsim/core/terms/tendon_string.py,
  rodsim/core/routing.py); the table is keyed by the tendon's own name, which must not be a
  rod's, and its term is ``tendon_string``.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from rodsim.core.anchors import Anchor, check_tendon_termination, tendon_termination
from rodsim.core.base_places import BasePlace
from rodsim.core.rod.quaternion import DIRECTOR_FORMS, director, director_gradient
from rodsim.core.rod.rod import Rod, RodOptions
from rodsim.core.routing import check_routing
from rodsim.core.schema import Options, Parameter, SceneError, shown
from rodsim.core.supports import Support, support_kind

__all__ = ["ROD_COUPLING_TABLES", "STRING_TERMS", "TENDON_PARAMETERS", "TENDON_TERMS",
           "LumenFrame", "Tendon", "TendonOptions", "check_tendon", "physical_default",
           "TendonPlace", "tendon_origin", "tendon_support"]

#: Coupling terms a tendon uses unless its table lists others.
TENDON_TERMS = ["lumen", "endpoint_compliance", "endpoint_coupling", "tendon_actuation"]

#: The coupling term of a ``string`` tendon (its default ``terms``).
STRING_TERMS = ["tendon_string"]

#: Largest tension a string tendon takes [N] (tendon_string.tension's range).
MAX_TENSION = 1e6

#: Sub-tables that only a tendon rod's couplings ('paper', 'conserving') read.
ROD_COUPLING_TABLES = ("lumen", "endpoint_compliance", "endpoint_coupling")

TENDON_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("catheter", "str", "catheter", "-", "name of the rod whose lumen holds the tendon"),
    Parameter("offset", "float", 0.003, "m",
              "lumen offset r_L from the catheter centerline (not given in the paper); for "
              "coupling = 'string', the offset of tendon_string.routing = 'constant'",
              0.0, 10.0, exclusive_minimum=True),
    Parameter("direction", "vector", [1.0, 0.0], "-",
              "(α, β) of the lumen direction d_t = α d1 + β d2 (Eq. 32); normalised; "
              "(1, 0) is d1 = +y at rest", length=2),
    Parameter("coupling", "str", "string", "-",
              "'string' (the default, a physical frictionless tendon: no tendon rod, the "
              "tension times the path's length, term tendon_string; a rod table of the "
              "tendon's name only sets where it ends, and tendon_actuation.force is its "
              "tension), 'conserving' (a tendon rod, every penalty force has its reaction) "
              "or 'paper' (Eq. 28 without reaction, averaged lumen reactions)",
              choices=("paper", "conserving", "string")),
    Parameter("terms", "list", TENDON_TERMS, "-",
              "coupling terms of this tendon (default for coupling = 'string': "
              "['tendon_string'])"),
)

@dataclass(frozen=True, kw_only=True)
class TendonOptions(Options):
    """A validated tendon table's own values ([tendons.<rod>]), typed: one field per
    ``TENDON_PARAMETERS`` (checked by tests/test_types.py); its per-term sub-tables are
    the coupling terms' own options."""

    catheter: str = "catheter"
    offset: float = 0.003
    direction: list[float] = field(default_factory=lambda: [1.0, 0.0])
    coupling: str = "string"
    terms: list[str] = field(default_factory=lambda: [
        "lumen", "endpoint_compliance", "endpoint_coupling", "tendon_actuation"])


def physical_default(rods: Mapping[str, Any], tendons: Mapping[str, Any]
                     ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The raw ``rods`` and ``tendons`` tables with every tendon that does not ask for a
    coupling made the physical one, a frictionless ``string`` (docs/tendon.md, "The default
    tendon").

    A tendon table without ``coupling`` becomes ``coupling = 'string'``: its
    ``tendon_actuation.force`` (if given) is the string's ``tendon_string.tension``, and a rod
    table of the tendon's name (how a rod tendon is written) is not simulated: it only sets
    where the tendon ends (``tendon_string.end`` = the rod's length when that is shorter than
    its catheter). A table that also sets what only a rod tendon reads (``terms``, ``lumen``,
    ``endpoint_compliance``, ``endpoint_coupling``, ``tendon_actuation.point``) is refused
    with the line that keeps a rod tendon: ``coupling = 'conserving'`` (or ``'paper'``).
    Tables that are not mappings pass through for the validation to report.
    """
    if not isinstance(rods, Mapping) or not isinstance(tendons, Mapping):
        return dict(rods) if isinstance(rods, Mapping) else rods, tendons
    rods_out, tendons_out = dict(rods), {}
    for name, table in tendons.items():
        if not isinstance(table, Mapping) or "coupling" in table:
            tendons_out[name] = table
            continue
        prefix = f"tendons.{shown(name, bare=True)}"
        actuation = table.get("tendon_actuation", {})
        rod_only = [key for key in ROD_COUPLING_TABLES if key in table]
        if "terms" in table and table["terms"] != STRING_TERMS:
            rod_only.insert(0, "terms")
        if isinstance(actuation, Mapping):
            rod_only += [f"tendon_actuation.{key}" for key in actuation if key != "force"]
        if rod_only:
            raise SceneError(f"{prefix}.{rod_only[0]}: a tendon without a coupling is a "
                             "frictionless string (no tendon rod, no penalty), which has no "
                             f"such setting; to keep a rod tendon set {prefix}.coupling = "
                             "'conserving' (or 'paper', the paper's model)")
        string = table.get("tendon_string", {})
        if not isinstance(string, Mapping):
            tendons_out[name] = {**table, "coupling": "string"}
            continue
        string = dict(string)
        if isinstance(actuation, Mapping) and "force" in actuation:
            if "tension" in string:
                raise SceneError(f"{prefix}.tendon_actuation.force and {prefix}.tendon_string"
                                 ".tension both set the string's tension; allowed: one of them")
            force = actuation["force"]
            if (isinstance(force, (int, float)) and not isinstance(force, bool)
                    and not 0.0 <= force <= MAX_TENSION):
                raise SceneError(f"{prefix}.tendon_actuation.force = {force!r}: out of range "
                                 f"for the string's tension; allowed: a number >= 0 and <= "
                                 f"{MAX_TENSION:g} [N]")
            string["tension"] = force
        rod = rods_out.pop(name, None) if name in rods_out else None
        catheter = rods.get(table.get("catheter", "catheter"))
        if (isinstance(rod, Mapping) and isinstance(catheter, Mapping)
                and "end" not in string):
            length, host = rod.get("length"), catheter.get("length")
            if (isinstance(length, (int, float)) and isinstance(host, (int, float))
                    and 0 < length < host):
                string["end"] = float(length)
        out = {k: v for k, v in table.items() if k != "tendon_actuation"}
        out["coupling"] = "string"
        out["tendon_string"] = string
        tendons_out[name] = out
    return rods_out, tendons_out


def _unit_direction(direction: list[float]) -> tuple[float, float]:
    norm = math.hypot(*direction)
    return direction[0] / norm, direction[1] / norm


def check_tendon(name: str, table: Mapping[str, Any], rods: Mapping[str, Mapping[str, Any]],
                 prefix: str, tendons: Collection[str] = (),
                 term_options: Mapping[str, Any] | None = None) -> None:
    """Cross-check a resolved tendon table against the scene's rods (resolved tables) and the
    other tendons (raises SceneError); ``term_options`` holds the typed options of the
    coupling terms the table lists, by name."""
    options = TendonOptions.of(table)
    if options.coupling == "string":
        _check_string(name, options, rods, prefix, tendons, term_options or {})
        return
    if "tendon_string" in options.terms:
        raise SceneError(f"{prefix}.terms: 'tendon_string' is the term of coupling = "
                         f"'string'; this tendon has coupling = {options.coupling!r}")
    if name not in rods:
        raise SceneError(f"{prefix}: no rod named {shown(name)} (a tendon table is keyed by its "
                         f"rod's name, or set coupling = 'string' for a tendon without a rod); "
                         f"rods: {', '.join(rods)}")
    catheter = options.catheter
    if catheter not in rods:
        raise SceneError(f"{prefix}.catheter = {shown(catheter)}: no such rod; rods: "
                         + ", ".join(rods))
    if catheter == name:
        raise SceneError(f"{prefix}.catheter = {catheter!r}: a rod cannot be its own catheter")
    if catheter in tendons:
        raise SceneError(f"{prefix}.catheter = {catheter!r}: that rod is itself a tendon; "
                         "allowed: a rod with no [tendons.<rod>] table")
    tendon, host = RodOptions.of(rods[name]), RodOptions.of(rods[catheter])
    check_tendon_termination(name, tendon, host, catheter)
    if options.offset >= host.radius:
        raise SceneError(f"{prefix}.offset = {options.offset!r}: the lumen lies outside the "
                         f"catheter; allowed: 0 < r_L < radius = {host.radius!r} [m]",
                         key=f"{prefix}.offset", value=options.offset,
                         allowed=f"0 < r_L < rods.{catheter}.radius",
                         reason="cross-table rule", related=(f"rods.{catheter}.radius",))
    if options.offset + tendon.radius >= host.radius:
        raise SceneError(f"{prefix}.offset = {options.offset!r} with rods.{name}.radius = "
                         f"{tendon.radius!r}: the tendon breaks through the catheter's wall; "
                         f"allowed: r_L + tendon radius < catheter radius = {host.radius!r} "
                         "[m]", key=f"{prefix}.offset", value=options.offset,
                         allowed=f"r_L + rods.{name}.radius < rods.{catheter}.radius",
                         reason="cross-table rule",
                         related=(f"rods.{name}.radius", f"rods.{catheter}.radius"))
    if math.hypot(*options.direction) < 1e-12:
        raise SceneError(f"{prefix}.direction = {options.direction!r}: d_t has zero length; "
                         "allowed: any non-zero (α, β)")
    term_options = term_options or {}
    lumen = term_options.get("lumen") if "lumen" in options.terms else None
    if lumen is not None and options.coupling == "conserving" and lumen.constrain == "d_t":
        raise SceneError(f"{prefix}.lumen.constrain = 'd_t': the conserving coupling holds a "
                         "tendon point on its lumen segment's line in both transverse "
                         "directions; allowed: 'both', or coupling = 'paper' (Eq. 34)")
    actuation = (term_options.get("tendon_actuation") if "tendon_actuation" in options.terms
                 else None)
    proximal = actuation is not None and actuation.point == "proximal"
    if proximal and tendon.clamp != "orientation":
        raise SceneError(f"rods.{name}.clamp = {tendon.clamp!r}: a tendon pulled at its "
                         "proximal end needs its base free to slide; allowed: 'orientation'")
    if tendon.clamp == "orientation" and not proximal:
        raise SceneError(f"rods.{name}.clamp = 'orientation': nothing holds the tendon's base "
                         f"unless it is pulled there; allowed: 'frame', or "
                         f"{prefix}.tendon_actuation.point = 'proximal'")
    if tendon.clamp != "free" and not support_kind(tendon.clamp).tendon_base:
        raise SceneError(f"rods.{name}.clamp = {tendon.clamp!r}: a tendon's base is held by "
                         "'frame' (distal actuation) or 'orientation' (proximal actuation)")
    if tendon.origin != [0.0, 0.0, 0.0]:
        raise SceneError(f"rods.{name}.origin = {tendon.origin!r}: a tendon is placed in its "
                         "lumen automatically; allowed: leave origin unset")


def _check_string(name: str, options: Any, rods: Mapping[str, Mapping[str, Any]], prefix: str,
                  tendons: Collection[str], term_options: Mapping[str, Any]) -> None:
    """Cross-checks of a ``string`` tendon (no rod of its own)."""
    if name in rods:
        raise SceneError(f"{prefix}: coupling = 'string' needs no rod, but a rod is named "
                         f"{name!r}; allowed: a tendon name that is not a rod's")
    if options.terms != STRING_TERMS:
        raise SceneError(f"{prefix}.terms = {shown(options.terms)}: a string tendon has the "
                         f"one term 'tendon_string'; allowed: {STRING_TERMS!r} (or leave terms "
                         "unset)")
    catheter = options.catheter
    if catheter not in rods:
        raise SceneError(f"{prefix}.catheter = {shown(catheter)}: no such rod; rods: "
                         + ", ".join(rods))
    if catheter in tendons:
        raise SceneError(f"{prefix}.catheter = {catheter!r}: that rod is itself a tendon; "
                         "allowed: a rod with no [tendons.<rod>] table")
    if math.hypot(*options.direction) < 1e-12:
        raise SceneError(f"{prefix}.direction = {options.direction!r}: d_t has zero length; "
                         "allowed: any non-zero (α, β)")
    host = RodOptions.of(rods[catheter])
    check_routing(prefix, options, term_options["tendon_string"], host.length, host.radius,
                  host.nodes)


def tendon_origin(catheter: Rod, options: TendonOptions) -> np.ndarray:
    """Rest position of the tendon's base: the lumen point at the catheter's base (Eq. 32);
    ``options`` is the tendon's ``TendonOptions``."""
    alpha, beta = _unit_direction(options.direction)
    frame = director(catheter.base_quaternion, 0), director(catheter.base_quaternion, 1)
    return catheter.origin + options.offset * (
        alpha * frame[0] + beta * frame[1])


def tendon_support(catheter: Rod, options: TendonOptions, clamp: str) -> Support:
    """The base support of a tendon rod: at its lumen's entrance (``tendon_origin``), in
    its catheter's base frame, holding what the tendon rod's ``clamp`` says; it moves and
    turns with the catheter's base (an inserted or rotated catheter carries its tendons)."""
    return Support(clamp, tendon_origin(catheter, options), catheter.base_quaternion)


class TendonPlace(BasePlace):
    """A tendon rod's base: at its lumen's entrance in its catheter (``tendon_support``),
    built after every other rod (rodsim/core/base_places.py)."""

    name = "tendon"
    precedence = 2

    @classmethod
    def claims(cls, scene: Any, rod: str) -> bool:
        return rod in scene.data["tendons"]

    @classmethod
    def parent(cls, scene: Any, rod: str) -> str | None:
        return str(scene.data["tendons"][rod]["catheter"])

    @classmethod
    def order(cls, scene: Any, rod: str) -> tuple[int, int]:
        return (1, 0)

    @classmethod
    def support(cls, scene: Any, rod: str, rods: Mapping[str, Rod]) -> Support:
        tendon = scene.tendons[rod]
        return tendon_support(rods[tendon.catheter], tendon, scene.rods[rod].clamp)


class LumenFrame(NamedTuple):
    """The lumen's directions at n segments and their derivatives in the quaternions q."""

    #: d_t = α d1 + β d2, the direction from the centerline to the lumen, (n, 3).
    dt: np.ndarray
    #: d_n = d3 × d_t, (n, 3).
    dn: np.ndarray
    #: ∂d_t/∂q, (n, 3, 4).
    Dt: np.ndarray
    #: ∂d_n/∂q, (n, 3, 4).
    Dn: np.ndarray
    #: ∂²d_t[m]/∂q² = Ht[m], constant, (3, 4, 4).
    Ht: np.ndarray
    #: ∂²d_n[m]/∂q² = Hn[m], constant, (3, 4, 4).
    Hn: np.ndarray


@dataclass(frozen=True)
class Tendon:
    """The pieces of one tendon table the coupling terms need."""

    name: str
    #: The tendon's rod; ``None`` for a string tendon.
    rod: Rod | None
    catheter: Rod
    offset: float
    alpha: float
    beta: float
    coupling: str

    @classmethod
    def of(cls, name: str, rods: dict[str, Rod], options: TendonOptions) -> Tendon:
        """The tendon of rod ``name`` configured by ``options`` (its ``TendonOptions``)."""
        alpha, beta = _unit_direction(options.direction)
        return cls(name, rods.get(name), rods[options.catheter], options.offset, alpha, beta,
                   options.coupling)

    @property
    def conserving(self) -> bool:
        return self.coupling == "conserving"

    @property
    def tendon_rod(self) -> Rod:
        """The tendon's rod; ValueError for a string tendon (which has none)."""
        if self.rod is None:
            raise ValueError(f"tendon {self.name!r} is a string: it has no rod")
        return self.rod

    @property
    def termination(self) -> Anchor:
        """Where the tendon ends (rodsim/core/anchors.py): its node tied to the catheter's
        node, and the catheter segment orienting the lumen there."""
        return tendon_termination(self.tendon_rod, self.catheter)

    def lumen_frame(self, q: np.ndarray) -> LumenFrame:
        """d_t, d_n = d3 × d_t and their q-derivatives for quaternions q (n, 4)."""
        a, b = self.alpha, self.beta
        d1, d2 = director(q, 0), director(q, 1)
        g1, g2 = director_gradient(q, 0), director_gradient(q, 1)
        return LumenFrame(
            dt=a * d1 + b * d2, dn=a * d2 - b * d1,
            Dt=a * g1 + b * g2, Dn=a * g2 - b * g1,
            Ht=2.0 * (a * DIRECTOR_FORMS[0] + b * DIRECTOR_FORMS[1]),
            Hn=2.0 * (a * DIRECTOR_FORMS[1] - b * DIRECTOR_FORMS[0]),
        )

    def lumen_segment(self, node: np.ndarray) -> np.ndarray:
        """Segment whose quaternion orients the lumen point at catheter ``node``."""
        return np.minimum(node, self.catheter.nodes - 2)

    def lumen_points(self, full: np.ndarray) -> np.ndarray:
        """L_j = r_j + r_L d_t(q_j) at every catheter node (Eqs. 24, 32), shape (N_C, 3)."""
        layout = self.catheter.layout
        r = full[layout.position_index]
        q = full[layout.quaternion_index][self.lumen_segment(np.arange(self.catheter.nodes))]
        # d_t alone: the registration check runs this after every solver step, and the full
        # lumen_frame (derivatives included) was half its cost (docs/benchmark-history.md,
        # "Measurements behind the core's constants").
        d_t = self.alpha * director(q, 0) + self.beta * director(q, 1)
        return r + self.offset * d_t
