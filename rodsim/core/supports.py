"""Supports: how a rod is held, and where (docs/model.md, "Supports and anchors").

A *support* fixes or prescribes a rod's position and/or orientation at an arclength. Every
rod has one at its base (s = 0), declared by two scene values:

- ``rods.<rod>.clamp`` — what the base support holds (the shorthand kept from earlier
  scenes): ``frame`` (the position r_0 and a frame q_c at s = 0), ``first_segment`` (r_0 and
  the first quaternion q_0, as PyElastica), ``orientation`` (the frame q_c only: a tendon
  pulled at its proximal end), ``free`` (nothing: the rod is held by a ``joint`` anchor to
  another rod, rodsim/core/terms/joint.py) or ``elastic`` (the position and frame held by
  springs, ``ElasticSupport``);
- ``[rods.<rod>.base]`` — where it is: ``insertion`` d [m], the base moved along its axis,
  and ``rotation`` θ [rad], the base frame turned about that axis (and an elastic base's
  springs, ``translational_stiffness`` k_t [N/m], ``rotational_stiffness`` k_b and
  ``torsional_stiffness`` k_τ [N·m/rad]). With the rod's ``origin``
  o and the rest frame R₀ (d3 = +x, docs/model.md),

      r_c = o + d d3,   R_c = R_x(θ) R₀,

  so that an actuated base moves (and turns) the whole rest shape: the rest state, the
  clamp frame of the bending term, and what is attached to the base (a tendon's lumen
  entrance and its base frame, rodsim/core/tendon.py). ``rodsim track --ramp`` and
  ``rodsim reach --actuate`` vary both like any numeric value.

A rod may also be held at other arclengths: each ``[rods.<rod>.supports.<name>]`` table
fixes the position of the node at ``s`` (a node: k L/(N − 1), not the base) at its rest
place moved by ``displacement`` [m] (world frame; the rest place moves with the base) — a
pinned node, or a prescribed displacement that ``rodsim track`` can ramp — and, with
``orientation = true``, the rod's frame there at its rest orientation (the base's frame,
which an actuated base turns): a clamp at s, as a guide or an introducer that grips the
rod (the bending term's frame elements at s_k, rodsim/core/terms/bend_twist.py).

What a support holds is its *kind*, an open registry (``SupportKind``: a subclass with a
unique ``name`` registers itself when defined, as terms and integrators do; docs/architecture.md,
"How to add a support kind"). The rigid kinds are here; a kind of its own file lives in
rodsim/core/support_kinds/, whose every module the registry imports on first use (the
``elastic`` base, rodsim/core/support_kinds/elastic.py). A kind owns everything that depends
on what is held: the coordinates it removes from the free state (``SupportKind.fixed_index``),
whether the bending term gets its frame element (``SupportKind.frame_element``: the element
(q_c, q_0) of dual length l/2 that keeps the clamp second order in N,
rodsim/core/terms/bend_twist.py), its scene rules and keys in ``[rods.<rod>.base]``
(``check_base``, ``base_parameters``) and, for a kind that holds by springs, its energy
(``SupportKind.has_energy``): E, its force −∂E/∂x and its exact Jacobian on the coordinates
(r, q) of the held node, as numpy methods of the kind (``energy``, ``forces``,
``jacobian``) with an optional compiled kernel (``energy_kernel``). The model evaluates them
through one generic term, rodsim/core/terms/support_energy.py, which asks the rod's support
kind for them; the rigid kinds have none. Nothing else in the model knows how a rod is held.
"""

from __future__ import annotations

import functools
import importlib
import math
import pkgutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from rodsim.core.names import check_rod_name
from rodsim.core.rod.layout import RodLayout
from rodsim.core.rod.quaternion import directors, from_rotation_matrix, rest_quaternion
from rodsim.core.schema import Options, Parameter, SceneError, validate_table

__all__ = ["BASE_PARAMETERS", "BaseClamps", "BaseOptions", "CLAMPS", "ENERGY_METHODS",
           "SUPPORT_ENERGY_TERM", "SUPPORT_PARAMETERS", "Support", "SupportKind",
           "all_base_parameters", "base_frame", "base_support", "clamp_doc",
           "node_at", "node_supports", "quaternion_product", "refuse_support_terms",
           "registered_support_kinds", "resolve_base", "resolve_supports", "rigid_motion",
           "support_kind"]

BASE_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("insertion", "float", 0.0, "m",
              "base moved along its axis (+x at rest) from the rod's origin: the whole rod "
              "is inserted by this length", -1e3, 1e3),
    Parameter("rotation", "float", 0.0, "rad",
              "base frame turned about its axis (+x) by this angle: the whole rod is rotated",
              -1e3, 1e3),
)

SUPPORT_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("s", "float", None, "m",
              "arclength of the held node (a node: k L/(N − 1); not 0, the base's)",
              0.0, 100.0),
    Parameter("displacement", "vector", [0.0, 0.0, 0.0], "m",
              "prescribed displacement of the node from its rest place (world frame; 0: "
              "pinned where it is at rest)", -1e3, 1e3, length=3),
    Parameter("orientation", "bool", False, "-",
              "hold the rod's frame at the node too, at its rest orientation (the base "
              "frame): a clamp at s. false: a pin (position only)"),
)

@dataclass(frozen=True, kw_only=True)
class SupportOptions(Options):
    """A validated support table ([rods.<rod>.supports.<name>]), typed: one field per
    ``SUPPORT_PARAMETERS`` (checked by tests/test_types.py)."""

    s: float
    displacement: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    orientation: bool = False


@dataclass(frozen=True, kw_only=True)
class BaseOptions(Options):
    """A validated base table's values ([rods.<rod>.base], SI units), typed: one field per
    ``BASE_PARAMETERS`` (checked by tests/test_types.py)."""

    insertion: float = 0.0
    rotation: float = 0.0


def base_frame(rotation: float) -> np.ndarray:
    """The quaternion q_c of the rest frame R₀ turned by ``rotation`` [rad] about +x
    (d3 = +x stays; d1 = (0, cos θ, sin θ), d2 = (0, −sin θ, cos θ))."""
    if rotation == 0.0:
        return rest_quaternion()
    c, s = math.cos(rotation), math.sin(rotation)
    return from_rotation_matrix(np.array([[0.0, 0.0, 1.0], [c, -s, 0.0], [s, c, 0.0]]))


_KINDS: dict[str, type[SupportKind]] = {}


class SupportKind:
    """What a support holds: subclass with a unique ``name`` (defining the class registers
    it, ``registered_support_kinds``) and set what differs from these defaults — a kind
    that holds nothing, adds no term and may only be a rod's base. A kind is never
    instantiated: its class is the description, as a term's class is."""

    #: The kind's scene name: a value of ``rods.<rod>.clamp`` at the base.
    name: ClassVar[str] = ""
    #: One line for ``rodsim`` help and docs/model.md.
    doc: ClassVar[str] = ""
    #: A rod's base support may be of this kind (``rods.<rod>.clamp``).
    at_base: ClassVar[bool] = True
    #: A support at a node s > 0 may be of this kind (``[rods.<rod>.supports.<name>]``).
    at_node: ClassVar[bool] = False
    #: The held node's position is fixed at the support point.
    holds_position: ClassVar[bool] = False
    #: The first quaternion q_0 is fixed too (its rest value, the support frame).
    holds_first_segment: ClassVar[bool] = False
    #: The bending term gets the frame element (q_c, q_0) (the support frame q_c half a
    #: segment before q_0, dual length l/2: docs/model.md, "Clamp"), or at a node the two
    #: elements (q_{k−1}, q_c), (q_c, q_k).
    frame_element: ClassVar[bool] = False
    #: A tendon rod's base (at its lumen's entrance) may be of this kind.
    tendon_base: ClassVar[bool] = False
    #: Keys this kind adds to ``[rods.<rod>.base]`` (validated only for a base of this kind).
    base_parameters: ClassVar[tuple[Parameter, ...]] = ()
    #: True for a kind that holds by springs: it has an energy, declared by the methods
    #: ``energy_constants``, ``energy``, ``forces`` and ``jacobian`` (each required then:
    #: TypeError when the class is defined without one; ``energy_values``, its constants'
    #: scene values, defaults to its ``base_parameters``'), which the generic
    #: support term evaluates (rodsim/core/terms/support_energy.py). False: a rigid kind.
    has_energy: ClassVar[bool] = False
    #: The compiled kernel of the energy, optional: a module of rodsim/core/kernels/ whose
    #: ``evaluate`` (and ``energy``) take ``dofs`` (1, 7) and the ``energy_constants`` by
    #: name, and compute what the numpy methods compute (tests/test_kernels.py). "" (the
    #: default): the numpy methods on every evaluation path.
    energy_kernel: ClassVar[str] = ""
    #: Term keys an older scene wrote this kind as (a rod naming one in its ``terms``, or
    #: its table, is pointed to this kind in one line, ``refuse_listed``).
    former_terms: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if not cls.name:
            raise TypeError(f"support kind {cls.__name__} must set a name")
        if cls.name in _KINDS:
            raise TypeError(f"support kind name {cls.name!r} is already registered "
                            f"({_KINDS[cls.name].__name__})")
        if cls.holds_first_segment and not cls.holds_position:
            raise TypeError(f"support kind {cls.name!r}: holding q_0 needs the position held")
        missing = [method for method in ENERGY_METHODS if cls.has_energy
                   and getattr(cls, method).__func__ is getattr(SupportKind, method).__func__]
        if missing:
            raise TypeError(f"support kind {cls.name!r} has an energy but does not define "
                            f"{', '.join(missing)}")
        _KINDS[cls.name] = cls

    @classmethod
    def fixed_index(cls, support: Support, layout: RodLayout) -> np.ndarray:
        """Global indices of the coordinates ``support`` (of this kind) removes from the
        free state."""
        parts = []
        if cls.holds_position:
            parts.append(layout.position_index[support.node])
        if cls.holds_first_segment:
            parts.append(layout.quaternion_index[support.node])
        return np.concatenate(parts) if parts else np.zeros(0, dtype=int)

    @classmethod
    def check_base(cls, rod: str, holders: list[str], pulled: bool,
                   holder_terms: Sequence[str] = ()) -> None:
        """The scene rules of a base of this kind on backbone rod ``rod`` (``holders``: its
        terms that hold a base, ``Term.holds_base``, at most one; ``pulled``: a tendon is
        pulled at the rod's base; ``holder_terms``: the keys of every registered term that
        can hold a base, for messages). SceneError when they fail; none by default."""

    @classmethod
    def resolve_base(cls, rod: str, raw: Mapping[str, Any], resolved: dict[str, Any]
                     ) -> dict[str, Any]:
        """The resolved ``[rods.<rod>.base]`` of a base of this kind: ``resolved`` is the
        table validated against ``BASE_PARAMETERS`` and ``base_parameters``, ``raw`` the
        scene's table. Fill or cross-check this kind's own keys here."""
        return resolved

    @classmethod
    def terms(cls, base: Mapping[str, Any]) -> list[tuple[str, dict[str, Any]]]:
        """The terms (rodsim/core/terms/base.py) a base of this kind adds to its rod's model,
        each as its registered term key and its options table (``base``: the rod's resolved
        ``[rods.<rod>.base]``); the model builds them. By default the generic support term
        for a kind with an energy (its options: the kind's name and ``energy_values``),
        none for a rigid kind. Named, not imported: the terms depend on the supports."""
        if not cls.has_energy:
            return []
        return [(SUPPORT_ENERGY_TERM, {"kind": cls.name,
                                       "values": [float(v) for v in cls.energy_values(base)]})]

    @classmethod
    def refuse_listed(cls, rod: str, key: str) -> None:
        """SceneError: rod ``rod`` names term ``key``, an older way of writing this kind
        (``former_terms``), itself — in its ``terms`` or as its table ``[rods.<rod>.<key>]``."""
        keys = ", ".join(p.name for p in cls.base_parameters)
        raise SceneError(f"rods.{rod}.{key}: a support of kind '{cls.name}' now, not a term; "
                         f"allowed: rods.{rod}.clamp = '{cls.name}'"
                         + (f" with [rods.{rod}.base] {keys}" if keys else "")
                         + cls.former_keys)

    #: What ``refuse_listed`` adds after its list of keys (a renamed key).
    former_keys: ClassVar[str] = ""

    # The energy of a kind that holds by springs (``has_energy``). ``x`` is the 7 coordinates
    # (r, q) of the held node and the segment after it (the base: r_0, q_0), full state.

    @classmethod
    def energy_values(cls, base: Mapping[str, Any]) -> Sequence[float]:
        """The kind's spring constants from a resolved ``[rods.<rod>.base]`` of this kind
        (the generic term's options, so a changed value rebuilds it): by default the
        values of ``base_parameters``, in their order."""
        return [float(base[parameter.name]) for parameter in cls.base_parameters]

    @classmethod
    def energy_constants(cls, values: Sequence[float], support: Support,
                         rod: Any) -> dict[str, Any]:
        """The constants ``energy``, ``forces`` and ``jacobian`` take (and the kernel, by
        the names of its parameters after ``dofs``), built once with the model from
        ``values`` (``energy_values``), the ``support`` (its point r_c and frame q_c) and
        the ``rod`` (a ``rodsim.core.rod.rod.Rod``: its stiffnesses, its segment length)."""
        raise NotImplementedError(f"support kind {cls.name!r} has no energy")

    @classmethod
    def energy(cls, constants: Mapping[str, Any], x: np.ndarray) -> float:
        """E(x) [J] of the support's springs."""
        raise NotImplementedError(f"support kind {cls.name!r} has no energy")

    @classmethod
    def forces(cls, constants: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
        """F = −∂E/∂x, shape (7,)."""
        raise NotImplementedError(f"support kind {cls.name!r} has no energy")

    @classmethod
    def jacobian(cls, constants: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
        """∂F/∂x, shape (7, 7), exact (never finite differences)."""
        raise NotImplementedError(f"support kind {cls.name!r} has no energy")


#: The methods a kind with an energy defines (``SupportKind.has_energy``; ``energy_values``
#: has a default).
ENERGY_METHODS = ("energy_constants", "energy", "forces", "jacobian")
#: The registered key of the generic term that evaluates a support kind's energy
#: (rodsim/core/terms/support_energy.py): named, not imported.
SUPPORT_ENERGY_TERM = "support_energy"


@functools.cache
def _import_kind_modules() -> None:
    """Import every module of rodsim/core/support_kinds/ once (defining a kind registers
    it), as the terms' registry does; deferred, as the kinds import this module."""
    import rodsim.core.support_kinds as package

    for module in pkgutil.iter_modules(package.__path__):
        if not module.name.startswith("_"):
            importlib.import_module(f"{package.__name__}.{module.name}")


def registered_support_kinds() -> dict[str, type[SupportKind]]:
    """Every support kind by name, in the order they were defined (the rigid kinds of
    this module first, then rodsim/core/support_kinds/'s)."""
    _import_kind_modules()
    return dict(_KINDS)


def refuse_support_terms(rod: str, table: Any) -> None:
    """SceneError (``SupportKind.refuse_listed``) when the raw rod table ``table`` names a
    term a support kind adds, in its ``terms`` or as a table of its own."""
    if not isinstance(table, Mapping):
        return
    terms = table.get("terms")
    listed = set(terms) if isinstance(terms, list) and all(
        isinstance(t, str) for t in terms) else set()
    for kind in registered_support_kinds().values():
        for key in kind.former_terms:
            if key in table or key in listed:
                kind.refuse_listed(rod, key)


def clamp_doc() -> str:
    """The help line of ``rods.<rod>.clamp``: each kind a base may have, with its ``doc``."""
    parts = [f"'{name}' ({kind.doc})" for name, kind in registered_support_kinds().items()
             if kind.at_base]
    return ("what the base support holds: " + ", ".join(parts[:-1])
            + (" or " if len(parts) > 1 else "") + parts[-1])


def all_base_parameters() -> tuple[Parameter, ...]:
    """``BASE_PARAMETERS`` and every kind's own ``[rods.<rod>.base]`` keys."""
    return BASE_PARAMETERS + tuple(p for kind in registered_support_kinds().values()
                                   for p in kind.base_parameters)


def support_kind(name: str) -> type[SupportKind]:
    """The support kind ``name`` (KeyError naming the registered ones if there is none)."""
    _import_kind_modules()
    try:
        return _KINDS[name]
    except KeyError:
        raise KeyError(f"no support kind {name!r}; registered: {', '.join(_KINDS)}") from None


class FrameSupport(SupportKind):
    """The position and a frame q_c held: a clamp (at the base, or at a node with
    ``orientation = true``)."""

    name = "frame"
    doc = "position and a frame at s = 0"
    at_node = True
    holds_position = True
    frame_element = True
    tendon_base = True


class FirstSegmentSupport(SupportKind):
    """The base position and the first quaternion q_0 held, as PyElastica."""

    name = "first_segment"
    doc = "position and first quaternion fixed, as PyElastica"
    holds_position = True
    holds_first_segment = True


class OrientationSupport(SupportKind):
    """The frame q_c held, the base position free: a tendon pulled at its proximal end."""

    name = "orientation"
    doc = "a frame at s = 0 but the position free: a tendon pulled at its proximal end"
    frame_element = True
    tendon_base = True

    @classmethod
    def check_base(cls, rod: str, holders: list[str], pulled: bool,
                   holder_terms: Sequence[str] = ()) -> None:
        if not pulled:
            raise SceneError(f"rods.{rod}.clamp = 'orientation': it leaves the base position "
                             "free, which only a tendon pulled at its base can have; "
                             "allowed: 'frame' or 'first_segment'")


class FreeSupport(SupportKind):
    """Nothing held: a term holds the base (``Term.holds_base``: a joint to another
    rod)."""

    name = "free"
    doc = "nothing: the base is held by a joint to another rod"

    @classmethod
    def check_base(cls, rod: str, holders: list[str], pulled: bool,
                   holder_terms: Sequence[str] = ()) -> None:
        if not holders:
            base_holders = ", ".join(sorted(set(holder_terms)))
            raise SceneError(f"rods.{rod}.clamp = 'free': nothing would hold the rod; "
                             "allowed: 'frame', 'first_segment' or 'elastic', or 'free' with "
                             f"a joint to another rod (terms: {base_holders})")


class PositionSupport(SupportKind):
    """A node's position held (a pin, or a prescribed displacement), its frame free."""

    name = "position"
    doc = "a node's position (a pin)"
    at_base = False
    at_node = True
    holds_position = True


@dataclass(frozen=True)
class Support:
    """How a rod is held at a node (its base s = 0, or ``node``): what is held (``holds``:
    the name of a registered ``SupportKind``: one of ``CLAMPS`` at the base, ``position``
    or ``frame`` elsewhere), the support point r_c [m] (``position``) and frame q_c
    (``frame``)."""

    holds: str
    position: np.ndarray = field(repr=False)
    frame: np.ndarray = field(repr=False)
    #: Arclength of the support on its rod [m] (0: the base).
    s: float = 0.0
    #: The node it holds (0: the base).
    node: int = 0

    @property
    def kind(self) -> type[SupportKind]:
        """The support's kind (what it holds and how: ``SupportKind``)."""
        return support_kind(self.holds)

    @property
    def holds_position(self) -> bool:
        """Whether the node's position is fixed at ``position``."""
        return self.kind.holds_position

    @property
    def frame_element(self) -> bool:
        """Whether the bending term gets the frame element (q_c, q_0) (the frame q_c half a
        segment before q_0, docs/model.md "Clamp")."""
        return self.kind.frame_element

    def fixed_index(self, layout: RodLayout) -> np.ndarray:
        """Global indices of the coordinates the support removes from the free state."""
        return self.kind.fixed_index(self, layout)

    @property
    def axis(self) -> np.ndarray:
        """The base axis d3 of the frame (+x)."""
        return np.array([1.0, 0.0, 0.0])


def rigid_motion(before: Support, after: Support
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The rigid motion that takes support ``before`` to ``after`` — (R, q_R, p₀, p₁) with
    r ↦ p₁ + R (r − p₀) and q ↦ q_R ⊗ q (the Hamilton product, paper order) — or None
    when the support did not move. A warm start carries a rod's equilibrium with it when
    its base is inserted or turned (``rodsim.core.model.Model.carried``)."""
    if (np.array_equal(before.position, after.position)
            and np.array_equal(before.frame, after.frame)):
        return None
    turn = directors(after.frame).T @ directors(before.frame)  # R₁ R₀ᵀ (columns d_k)
    return turn, from_rotation_matrix(turn), before.position, after.position


def quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a ⊗ b of quaternions (..., 4) in the paper's order (q1, q2, q3
    imaginary, q4 real): the directors of a ⊗ b are those of b turned by a's rotation."""
    av, aw = a[..., :3], a[..., 3:]
    bv, bw = b[..., :3], b[..., 3:]
    vector = aw * bv + bw * av + np.cross(av, bv)
    scalar = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    return np.concatenate([vector, scalar], axis=-1)


def base_support(clamp: str, base: BaseOptions, origin: np.ndarray) -> Support:
    """The base support of a rod: ``clamp`` what it holds, ``base`` its
    ``BaseOptions`` (insertion, rotation), ``origin`` the rod's origin [m]."""
    frame = base_frame(float(base.rotation))
    position = np.asarray(origin, dtype=float) + float(base.insertion) * np.array([1.0, 0, 0])
    return Support(clamp, position, frame)


def node_at(nodes: int, length: float, s: float) -> int:
    """The node nearest arclength ``s`` of a rod of ``nodes`` nodes and ``length``."""
    return int(round(s / length * (nodes - 1)))


def node_exactly_at(nodes: int, length: float, s: float, key: str, rod: str = "the rod") -> int:
    """The node at arclength ``s`` of a rod of ``nodes`` nodes and ``length``; SceneError
    (naming ``key`` and ``rod``) when ``s`` is beyond the rod or between two nodes."""
    if s > length * (1 + 1e-12):
        raise SceneError(f"{key} = {s!r}: beyond {rod} (length {length!r} m); allowed: "
                         f"s <= {length!r}")
    node = node_at(nodes, length, s)
    if abs(s - node * length / (nodes - 1)) > 1e-9 * length:
        raise SceneError(f"{key} = {s!r}: between two nodes of {rod}; allowed: a node's "
                         f"arclength k L/(N − 1), e.g. {node * length / (nodes - 1)!r}")
    return node


def node_supports(nodes: int, length: float, rest: np.ndarray, frame: np.ndarray,
                  supports: Mapping[str, Mapping[str, Any]]) -> tuple[Support, ...]:
    """The supports of a rod's ``[rods.<rod>.supports.<name>]`` tables (validated) for a rod
    of ``nodes`` nodes, ``length``, rest positions ``rest`` (N, 3) and rest frame ``frame``
    (its base's): each holds its node's position, and with ``orientation`` the frame too."""
    out = []
    for table in supports.values():
        options = SupportOptions.of(table)
        node = node_at(nodes, length, options.s)
        out.append(Support("frame" if options.orientation else "position",
                           rest[node] + np.asarray(options.displacement, float),
                           np.asarray(frame, float) if options.orientation else np.zeros(4),
                           float(options.s), node))
    return tuple(out)


def resolve_supports(rod: str, table: Mapping[str, Any], is_tendon: bool
                     ) -> dict[str, dict[str, Any]]:
    """The validated ``[rods.<rod>.supports.<name>]`` tables of a resolved rod table
    (SceneError: not a table of tables, a tendon rod, ``s`` at the base, beyond the rod,
    between nodes, or two supports on one node)."""
    raw = table.get("supports", {})
    prefix = f"rods.{rod}.supports"
    if not isinstance(raw, Mapping) or not all(isinstance(v, Mapping) for v in raw.values()):
        raise SceneError(f"{prefix}: expected tables [{prefix}.<name>] (keys: s, "
                         "displacement)")
    length, nodes = float(table["length"]), int(table["nodes"])
    out: dict[str, dict[str, Any]] = {}
    held: dict[int, str] = {}
    for name, entry in raw.items():
        key = f"{prefix}.{check_rod_name(name, prefix, 'support')}"  # '.' would split its keys
        resolved = validate_table(entry, SUPPORT_PARAMETERS, key)
        s = resolved["s"]
        if is_tendon:
            where = (" at its termination, where its anchor to the catheter holds it"
                     if s >= length * (1 - 1e-12) else "")
            raise SceneError(f"{key}: a support on a tendon rod{where}; a tendon is held by "
                             "its lumen and its termination; allowed: supports on backbone "
                             "rods")
        node = node_exactly_at(nodes, length, s, f"{key}.s")
        if node == 0:
            raise SceneError(f"{key}.s = {s!r}: the base support holds s = 0; allowed: "
                             f"s > 0 (the base: rods.{rod}.clamp and [rods.{rod}.base])")
        if node in held:
            raise SceneError(f"{key}.s = {s!r}: node {node} is already held by "
                             f"{prefix}.{held[node]}")
        held[node] = name
        out[name] = resolved
    return out


def resolve_base(rod: str, table: Mapping[str, Any], is_tendon: bool) -> dict[str, Any] | None:
    """The validated ``[rods.<rod>.base]`` table of a resolved rod table (defaults filled;
    the keys of its clamp's kind too, ``SupportKind.base_parameters``), or None for a tendon
    rod, whose base follows its catheter's (SceneError if it has one)."""
    if is_tendon:
        if "base" in table:
            raise SceneError(f"rods.{rod}.base: a tendon's base is its lumen's entrance and "
                             "moves with its catheter's base; allowed: set the catheter's "
                             "[rods.<catheter>.base]")
        return None
    kind = support_kind(str(table.get("clamp", "frame")))
    raw = table.get("base", {})
    for other in registered_support_kinds().values():
        for parameter in other.base_parameters if other is not kind else ():
            if isinstance(raw, Mapping) and parameter.name in raw:
                raise SceneError(f"rods.{rod}.base.{parameter.name}: a key of clamp = "
                                 f"'{other.name}', and rods.{rod}.clamp = '{kind.name}'; "
                                 f"allowed: rods.{rod}.clamp = '{other.name}' with it")
    resolved = validate_table(raw, BASE_PARAMETERS + kind.base_parameters, f"rods.{rod}.base")
    return kind.resolve_base(rod, raw, resolved)


class BaseClamps(Sequence[str]):
    """What a base support may hold (``rods.<rod>.clamp``): the registered kinds allowed at
    a base, read from the registry each time (a kind defined later, in a test, is one)."""

    def _names(self) -> tuple[str, ...]:
        return tuple(name for name, kind in registered_support_kinds().items() if kind.at_base)

    def __getitem__(self, index: Any) -> Any:
        return self._names()[index]

    def __len__(self) -> int:
        return len(self._names())

    def __contains__(self, name: object) -> bool:
        return name in self._names()

    def __repr__(self) -> str:
        return repr(self._names())


#: What a base support may hold (``rods.<rod>.clamp``), live (``BaseClamps``).
CLAMPS: Sequence[str] = BaseClamps()
