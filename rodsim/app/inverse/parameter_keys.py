"""Numeric scene parameters by key: what sensitivities, tracking, fitting and inverse
kinematics vary (rodsim/app/inverse/).

A key is any ``--set``-style key of a numeric scene value (a full dotted key or an
unambiguous suffix: ``K_E``, ``tip_load.mass``, ``rods.catheter.youngs_modulus``, the base
support's ``insertion`` and ``rotation``), or one
component of a vector value as ``KEY[i]`` (``origin[1]``, ``tip_load.force[0]``). Each key
carries its schema declaration (unit, allowed range), which gives the bounds of a fit,
narrowed for a string tendon's numbers by the routing rules (rodsim/core/routing.py,
``routing_limits``: an end past the tip, a start after the end, routing outside the catheter,
a helix the nodes alias), so that a track, a fit or a reach never asks for a scene that
``run`` refuses.

Refused, with a one-line ``rodsim.core.schema.SceneError``: solver settings (they do not
change the equilibrium), integer values (``nodes`` changes the discretisation: the state has
no derivative with respect to it), and text, switches and lists.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rodsim.core.anchors import scene_joints
from rodsim.core.rod.rod import ROD_PARAMETERS
from rodsim.core.scene import Scene
from rodsim.core.schema import Parameter, SceneError, shown
from rodsim.core.supports import SUPPORT_PARAMETERS, all_base_parameters
from rodsim.core.tendon import TENDON_PARAMETERS

__all__ = ["NumericKey", "numeric_key", "numeric_keys", "scene_with"]

_COMPONENT = re.compile(r"^(?P<key>.+)\[(?P<index>\d+)\]$")


@dataclass(frozen=True)
class NumericKey:
    """One numeric scene value: its full dotted ``path``, the vector component ``index``
    (or None), and its schema ``parameter``."""

    path: str
    index: int | None
    parameter: Parameter
    #: (low, high, the rule) from the rules across tables, or None (the declaration alone).
    limits: tuple[float, float, str] | None = None

    @property
    def name(self) -> str:
        """The full key, with ``[i]`` for a vector component."""
        return self.path if self.index is None else f"{self.path}[{self.index}]"

    @property
    def unit(self) -> str:
        return "1" if self.parameter.unit == "-" else self.parameter.unit

    def value(self, scene: Scene) -> float:
        value = scene.get(self.path)
        return float(value if self.index is None else value[self.index])

    def bounds(self) -> tuple[float, float]:
        """The allowed range from the schema (−inf/inf where it has none); an exclusive
        minimum is moved up by a relative 1e-9 (or 1e-300 at 0)."""
        low = -math.inf if self.parameter.minimum is None else float(self.parameter.minimum)
        if self.parameter.exclusive_minimum:
            low = low + max(abs(low) * 1e-9, 1e-300)
        high = math.inf if self.parameter.maximum is None else float(self.parameter.maximum)
        if self.limits is not None:
            low, high = max(low, self.limits[0]), min(high, self.limits[1])
        return low, high

    @property
    def allowed(self) -> str:
        """The allowed values in words: the declaration's, and the rule's where one narrows
        it."""
        if self.limits is None:
            return self.parameter.allowed
        return f"{self.parameter.allowed}; and {self.limits[2]}"

    @property
    def routing(self) -> bool:
        """Whether the value takes part in a string tendon's routing rules."""
        return self.limits is not None


def _routing_limits(scene: Scene, path: str) -> tuple[float, float, str] | None:
    """The routing rule's range of a string tendon's number at ``path`` (None for others)."""
    from rodsim.core.routing import routing_limits

    parts = path.split(".")
    if parts[0] != "tendons" or scene.tendons[parts[1]].coupling != "string":
        return None
    name = parts[-1] if len(parts) == 3 or parts[2] == "tendon_string" else None
    if name is None:
        return None
    rod = scene.rods[scene.tendons[parts[1]].catheter]
    string = scene.term_options("tendons", parts[1], "tendon_string")
    if name == "offset" and string.routing != "constant":
        return None
    return routing_limits(string, rod.length, rod.radius, rod.nodes).get(name)


def _schema(path: str) -> Parameter | None:
    """The declaration of the scene value at a full dotted key (None: not declared)."""
    from rodsim.core.terms import registered_terms

    parts = path.split(".")
    if parts[0] == "rods":
        table = ROD_PARAMETERS
    elif parts[0] == "tendons":
        table = TENDON_PARAMETERS
    else:
        return None
    if len(parts) == 4 and parts[0] == "rods" and parts[2] == "base":
        table = all_base_parameters()  # insertion, rotation; an elastic base's springs
    elif len(parts) == 5 and parts[0] == "rods" and parts[2] == "supports":
        table = SUPPORT_PARAMETERS  # a node support's s and displacement
    elif len(parts) == 4:
        term = registered_terms().get(parts[2])
        table = term.parameters if term is not None else ()
    elif len(parts) != 3:
        return None
    return next((p for p in table if p.name == parts[-1]), None)


def _joins_rods(parts: Sequence[str]) -> bool:
    """Whether the dotted key ``parts`` is a value of a rod term that joins the rod to
    another (``Term.joins_rods``: its ``s`` picks the node it is joined at)."""
    from rodsim.core.terms import registered_terms

    kind = registered_terms().get(parts[2]) if len(parts) == 4 and parts[0] == "rods" else None
    return kind is not None and kind.joins_rods


def numeric_key(scene: Scene, key: str) -> NumericKey:
    """The numeric scene value ``key`` names (see the module docstring), or SceneError."""
    match = _COMPONENT.match(key.strip())
    text, index = (match["key"], int(match["index"])) if match else (key.strip(), None)
    path = scene.full_key(text)
    if path.startswith("solver."):
        raise SceneError(f"{shown(key, bare=True)}: {path} is a solver setting, not a model "
                         "parameter (it does not change the equilibrium)")
    parameter = _schema(path)
    if parameter is None:
        raise SceneError(f"{shown(key, bare=True)}: {path} is not a numeric model parameter")
    parts = path.split(".")
    if parts[0] == "rods" and parts[2] == "base" and parts[1] in scene_joints(scene):
        raise SceneError(f"{shown(key, bare=True)}: rod {parts[1]!r} is joined to another "
                         "rod, whose base it follows; allowed: the base of a supported rod")
    if parameter.kind == "int" or (parameter.name == "s" and (
            ".supports." in path or _joins_rods(parts))):
        raise SceneError(f"{shown(key, bare=True)}: {path} changes the discretisation (the "
                         "free coordinates), so the equilibrium has no derivative with respect "
                         "to it")
    if parameter.kind == "vector":
        if index is None:
            raise SceneError(f"{shown(key, bare=True)}: {path} is a vector; name one "
                             f"component as {path}[i]")
        size = len(scene.get(path))
        if index >= size:
            raise SceneError(f"{shown(key, bare=True)}: {path} has {size} components "
                             f"(index 0 to {size - 1})")
    elif parameter.kind != "float":
        raise SceneError(f"{shown(key, bare=True)}: {path} is not a number ({parameter.allowed})")
    elif index is not None:
        raise SceneError(f"{shown(key, bare=True)}: {path} is a number, not a vector")
    return NumericKey(path, index, parameter, _routing_limits(scene, path))


def numeric_keys(scene: Scene, keys: Sequence[str]) -> list[NumericKey]:
    """``numeric_key`` for each of ``keys``; SceneError if two name the same value."""
    resolved = [numeric_key(scene, key) for key in keys]
    names = [k.name for k in resolved]
    for name in names:
        if names.count(name) > 1:
            raise SceneError(f"{name} is named twice")
    return resolved


#: Rod values that no rule across tables (rodsim.core.scene.resolve,
#: rodsim.core.tendon.check_tendon)
#: involves, like every term parameter: checking the value against its declaration is the
#: whole validation.
_LOCAL_ROD_VALUES = ("youngs_modulus", "stretch_modulus", "poisson_ratio", "density")


def _local(key: NumericKey) -> bool:
    """Whether the value of ``key`` is validated by its declaration alone (no cross-check;
    a base support's insertion and rotation are: the model places the rod from them)."""
    parts = key.path.split(".")
    if key.routing:
        return False
    return len(parts) == 4 or (parts[0] == "rods" and parts[-1] in _LOCAL_ROD_VALUES)


def scene_with(scene: Scene, keys: Sequence[NumericKey], values: Sequence[float] | np.ndarray
               ) -> Scene:
    """``scene`` with the given values at ``keys`` (validated: SceneError out of range).

    Tracking and fitting build one scene per step, so values that take part in no rule
    across tables (term parameters, moduli, density) are checked against their declaration
    and set on a copy of the tables along their path only (0.02 ms instead of 0.4 ms for a
    validation of the whole scene, which every other value gets)."""
    if all(_local(key) for key in keys):
        data = dict(scene.data)
        for key, value in zip(keys, values, strict=True):
            *parents, last = key.path.split(".")
            node = data
            for part in parents:
                node[part] = dict(node[part])
                node = node[part]
            if key.index is None:
                node[last] = key.parameter.check(float(value), key.path)
            else:
                vector = list(node[last])
                vector[key.index] = float(value)
                node[last] = key.parameter.check(vector, key.path)
        return Scene(data, scene.source)
    assignments: dict[str, float | list[float]] = {}
    vectors: dict[str, list[float]] = {}
    for key, value in zip(keys, values, strict=True):
        if key.index is None:
            assignments[key.path] = float(value)
        else:
            vector = vectors.setdefault(key.path, list(scene.get(key.path)))
            vector[key.index] = float(value)
            assignments[key.path] = vector
    return scene.with_values(assignments)
