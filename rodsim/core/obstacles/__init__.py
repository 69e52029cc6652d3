"""Rigid obstacles a rod may touch (vessel walls, tissue), one file per obstacle type, and the
registry that finds them (issue 25).

A scene lists obstacles as ``[obstacles.<name>]`` tables with a ``type`` (a registered
obstacle: ``capsule``, ``plane``, ``sphere``, ``tube``), the ``rods`` it applies to and the
contact law's scales; each type declares its own geometry parameters. Defining an
``Obstacle`` subclass with a new ``type`` registers it (``registered_obstacles``
imports every module of this package). The contact term (rodsim/core/terms/contact.py) turns
an obstacle into a penalty on the rod's nodes; the obstacle only gives the geometry: the
signed gap φ(p) of a point p (> 0 in free space, distance to the surface where it is
smooth), its gradient and its Hessian, by numpy (``Obstacle.gap``) and in its own
compiled kernel (``rodsim/core/kernels/contact_<type>.py``, named by ``Obstacle.kernel``).
tests/test_obstacle_contract.py holds every registered type to the contract.

``resolve_obstacles`` validates the ``obstacles`` tables of a raw scene against the rods
(one-line ``rodsim.core.schema.SceneError`` for every bad input).
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from rodsim.core.names import check_rod_name
from rodsim.core.schema import Parameter, SceneError, shown, validate_table

__all__ = ["Obstacle", "OBSTACLES", "COMMON_PARAMETERS", "DEPTH_LIMIT", "registered_obstacles",
           "resolve_obstacles", "build_obstacle"]

#: Every defined obstacle class, by ``type``.
OBSTACLES: dict[str, type[Obstacle]] = {}

#: Deepest penetration p of a node's sphere into a rigid obstacle for which the penalty law
#: is taken as a rigid contact, in rod radii (rodsim/core/contact_depth.py).
DEPTH_LIMIT = 0.1

#: Values every obstacle table has, whatever its type.
COMMON_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("type", "str", None, "-",
              "obstacle type: a registered one (each type's own keys: its table below)"),
    Parameter("rods", "list", None, "-", "the rods this obstacle acts on (the catheters)"),
    Parameter("stiffness_scale", "float", 1e3, "-",
              "contact stiffness k = stiffness_scale * E I / l^3 of the rod (l its segment "
              "length) [N/m]", 0.0, 1e12, exclusive_minimum=True),
    Parameter("smoothing_scale", "float", 1e-3, "-",
              "smoothing length delta = smoothing_scale * r of the rod (r its radius) over "
              "which the contact force rises from zero (C2 onset)", 0.0, 1.0,
              exclusive_minimum=True),
    Parameter("friction", "float", 0.0, "-",
              "Coulomb friction coefficient mu of the regularised friction opposing each "
              "node's slip since its anchor (0: frictionless)", 0.0, 10.0),
    Parameter("slip_scale", "float", 1e-3, "-",
              "regularisation length epsilon = slip_scale * r of the friction law (r the "
              "rod's radius): the slip over which friction rises to mu |f_n|", 0.0, 1e3,
              exclusive_minimum=True),
)


class Obstacle(ABC):
    """A rigid obstacle: the signed gap φ(p) of points p and its first two derivatives.

    Class attributes a subclass sets: ``type`` (registry key), ``parameters`` (its own
    geometry values), ``kernel`` (its compiled contact kernel: the module
    ``rodsim.core.kernels.<kernel>``, whose constants ``kernel_arguments`` gives by
    name) and ``example`` (a table of the type, which the contract tests
    (tests/test_obstacle_contract.py) solve, draw and archive). docs/architecture.md, "How to
    add an obstacle type".
    """

    type: ClassVar[str]
    #: Module of :mod:`rodsim.core.kernels` holding this type's contact kernel.
    kernel: ClassVar[str]
    #: The type's own keys of a table near a straight rod along +x from the origin, 0.1 m
    #: long and 1 mm thick, that it pushes on when the rod sags toward -y (the contract
    #: tests' scene).
    example: ClassVar[dict[str, Any]] = {}
    parameters: ClassVar[tuple[Parameter, ...]] = ()
    #: True when the rod lies inside the obstacle (a vessel): it must start inside.
    encloses: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "type" in cls.__dict__:
            if cls.type in OBSTACLES:
                raise TypeError(f"obstacle type {cls.type!r} registered twice")
            OBSTACLES[cls.type] = cls

    def __init__(self, name: str, table: Mapping[str, Any]) -> None:
        self.name = name
        #: The validated table (common values and the type's own).
        self.table = dict(table)

    @classmethod
    def resolve(cls, table: dict[str, Any], prefix: str) -> dict[str, Any]:
        """Type-specific checks and completion of a validated table (SceneError, one line)."""
        return table

    @abstractmethod
    def gap(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """φ (n,), ∇φ (n, 3) and ∇²φ (n, 3, 3) at ``points`` (n, 3) — the numpy reference."""

    @abstractmethod
    def kernel_arguments(self) -> dict[str, Any]:
        """The geometry constants of the compiled kernel (``kernel``), by the names of its
        parameters; the contact term adds the rod's and the law's (``dofs``, ``radius``,
        ``stiffness``, ``delta``, ``friction``, ``slip``, ``anchors``)."""

    def narrowest(self) -> float:
        """The smallest free radius of an enclosing obstacle (inf for others) [m]."""
        return float("inf")

    def free_half_space(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(unit normal n (3,), a point p₀ (3,) of the boundary) when the obstacle's free
        space is the half-space n · (p − p₀) > 0 — its gap is then φ(p) = n · (p − p₀), which
        tests/test_obstacle_contract.py checks — else None (the default). Two such obstacles
        facing each other on one rod must leave it room (``resolve_obstacles``)."""
        return None

    # Drawing (figures and the 3-D view; the model never calls these) ------------------

    def outline(self, view: tuple[int, int], level: float, lower: np.ndarray,
                upper: np.ndarray) -> list[np.ndarray]:
        """The obstacle as drawn in the plane of the world axes ``view`` (the third axis at
        depth ``level``) within the box ``lower``–``upper`` (3,): curves, each (k, 3) world
        points. By default the surface φ = 0 cut by that plane (marching squares on a grid
        of ``gap``, so an obstacle type without a drawing of its own is still drawn);
        a type overrides it with its exact outline."""
        from rodsim.core.obstacles._drawing import zero_level

        return zero_level(lambda p: self.gap(p)[0], view, level, lower, upper)

    def surface(self, lower: np.ndarray, upper: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray] | None:
        """A triangulated surface near the box ``lower``–``upper``: vertices (n, 3) and
        triangles (m, 3); None (the default) when the type has none, and the 3-D view
        draws its ``outline`` in the three planes through the box's centre."""
        return None


def registered_obstacles() -> dict[str, type[Obstacle]]:
    """Every registered obstacle class by type, in the types' order (imports this
    package's modules)."""
    _import_every_module()
    return dict(sorted(OBSTACLES.items()))


@functools.cache
def _import_every_module() -> None:
    for module in pkgutil.iter_modules(__path__):
        if not module.name.startswith("_"):
            importlib.import_module(f"{__name__}.{module.name}")


def build_obstacle(name: str, table: Mapping[str, Any]) -> Obstacle:
    """The obstacle of a resolved ``[obstacles.<name>]`` table."""
    return registered_obstacles()[table["type"]](name, table)


def resolve_obstacles(raw: Any, rods: Mapping[str, Mapping[str, Any]],
                      tendons: Mapping[str, Any]) -> dict[str, Any]:
    """Validate the ``obstacles`` tables of a raw scene against its resolved ``rods``."""
    if not isinstance(raw, Mapping):
        raise SceneError("obstacles: expected tables [obstacles.<name>]")
    types = registered_obstacles()
    out: dict[str, Any] = {}
    held: list[tuple[Obstacle, str, str]] = []  # checked after the free space
    built: list[Obstacle] = []
    for name, table in raw.items():
        prefix = f"obstacles.{check_rod_name(name, 'obstacles')}"
        if not isinstance(table, Mapping):
            raise SceneError(f"{prefix}: expected a table, got {type(table).__name__}")
        kind = table.get("type")
        if kind not in types:
            raise SceneError(f"{prefix}.type = {shown(kind)}: unknown obstacle type; allowed: "
                             f"one of {', '.join(repr(t) for t in sorted(types))}",
                             key=f"{prefix}.type", value=kind, allowed=tuple(sorted(types)),
                             reason="unknown obstacle type")
        cls = types[kind]
        resolved = validate_table(table, (*COMMON_PARAMETERS, *cls.parameters), prefix)
        if not resolved["rods"]:
            raise SceneError(f"{prefix}.rods = []: an obstacle acts on at least one rod")
        for rod in resolved["rods"]:
            if rod not in rods:
                raise SceneError(f"{prefix}.rods: no rod {rod!r} in the scene; allowed: "
                                 f"{', '.join(sorted(rods))}", key=f"{prefix}.rods",
                                 value=rod, allowed=tuple(sorted(rods)), reason="unknown rod")
            if rod in tendons:
                raise SceneError(f"{prefix}.rods: {rod!r} is a tendon, which rides inside its "
                                 "catheter; name the catheter")
        resolved = cls.resolve(resolved, prefix)
        obstacle = cls(name, resolved)
        built.append(obstacle)
        for rod in resolved["rods"]:
            table_of_rod = rods[rod]
            radius = float(table_of_rod["radius"])
            if obstacle.encloses and radius >= obstacle.narrowest():
                raise SceneError(f"{prefix}: rod {rod!r} (radius {radius!r} m) is thicker than "
                                 f"the vessel (narrowest radius {obstacle.narrowest():.6g} m)")
            if obstacle.encloses and table_of_rod["clamp"] != "free":
                # The base (s = 0, at its inserted place) must lie inside the vessel; the
                # rest of the straight rest shape may cross the wall (the contact brings it
                # in: a rod inserted into a bend).
                base = table_of_rod.get("base") or {}
                point = (np.asarray(table_of_rod["origin"], dtype=float)
                         + np.array([float(base.get("insertion", 0.0)), 0.0, 0.0]))
                phi = float(obstacle.gap(point[None, :])[0][0])
                if phi <= 0.0:
                    where = ", ".join(f"{v:.6g}" for v in point)
                    raise SceneError(f"{prefix}: rod {rod!r} starts outside the vessel: its "
                                     f"base (s = 0) at ({where}) m is {-phi:.3g} m beyond "
                                     "the wall")
            if not obstacle.encloses:
                held.append((obstacle, prefix, rod))
        out[name] = resolved
    _check_free_space(built, rods)
    for obstacle, prefix, rod in held:
        _check_held_outside(obstacle, prefix, rod, rods[rod])
    return out


def _held_points(table: Mapping[str, Any]) -> list[tuple[str, np.ndarray]]:
    """(what, rest position) of each node a resolved rod table holds in place: its base
    (clamps 'frame' and 'first_segment') and its node supports, on the straight rest shape
    along +x (rodsim/core/supports.py)."""
    from rodsim.core.supports import node_at, support_kind

    base = table.get("base") or {}
    origin = np.asarray(table["origin"], dtype=float) + np.array(
        [float(base.get("insertion", 0.0)), 0.0, 0.0])
    out = []
    if support_kind(table["clamp"]).holds_position:
        out.append(("its base (s = 0)", origin))
    length, nodes = float(table["length"]), int(table["nodes"])
    for name, support in (table.get("supports") or {}).items():
        node = node_at(nodes, length, float(support["s"]))
        place = origin + np.array([node * length / (nodes - 1), 0.0, 0.0]) + np.asarray(
            support.get("displacement", (0.0, 0.0, 0.0)), dtype=float)
        out.append((f"its support {name!r} (s = {float(support['s']):.6g} m)", place))
    return out


def _check_held_outside(obstacle: Obstacle, prefix: str, rod: str,
                        table: Mapping[str, Any]) -> None:
    """SceneError when a node the rod holds in place lies deeper inside a solid obstacle
    than the contact law's validity (rodsim/core/contact_depth.py): it cannot leave, and the
    penalty pushes on it for ever (a rod based inside a plane, a support driving the tip
    into one)."""
    radius = float(table["radius"])
    for what, point in _held_points(table):
        depth = (radius - float(obstacle.gap(point[None, :])[0][0])) / radius
        if depth > DEPTH_LIMIT:
            where = ", ".join(f"{v:.6g}" for v in point)
            raise SceneError(f"{prefix}: rod {rod!r} holds {what} at ({where}) m, "
                             f"{depth:.3g} radii inside the obstacle; allowed: held nodes "
                             f"outside it (at most {DEPTH_LIMIT:g} radii in, the contact "
                             "law's validity, docs/contact.md)")


def _check_free_space(obstacles: list[Obstacle],
                      rods: Mapping[str, Mapping[str, Any]]) -> None:
    """SceneError when two obstacles whose free space is a half-space
    (``Obstacle.free_half_space``: planes) face each other on one rod and leave it no room:
    their free half-spaces overlap by less than the rod's diameter."""
    walls = [(obstacle, half) for obstacle in obstacles
             if (half := obstacle.free_half_space()) is not None]
    for i, (a, (na, pa)) in enumerate(walls):
        for b, (nb, pb) in walls[i + 1:]:
            if na @ nb > -1.0 + 1e-9:
                continue  # not facing each other: the free space is unbounded
            width = float(na @ (pb - pa))
            for rod in set(a.table["rods"]) & set(b.table["rods"]):
                diameter = 2.0 * float(rods[rod]["radius"])
                if width < diameter:
                    raise SceneError(f"obstacles.{a.name} and obstacles.{b.name}: facing "
                                     f"planes {width:.6g} m apart leave rod {rod!r} (diameter "
                                     f"{diameter:.6g} m) no free space; allowed: planes "
                                     "farther apart than the rod is thick")
