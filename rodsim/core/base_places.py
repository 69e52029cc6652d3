"""Where a rod's base support is: an open registry of *places* (docs/architecture.md, "How
to add a support kind" and "How to add a kind of rod").

A rod's base support has a kind (what it holds, ``SupportKind`` in rodsim/core/supports.py)
and a place (its point r_c and frame q_c). The place depends on what kind of rod it is:

- a backbone rod's base is at its ``origin`` moved and turned by ``[rods.<rod>.base]``
  (``OriginPlace``, here: ``rodsim.core.supports.base_support``);
- a tendon rod's at its lumen's entrance, in its catheter's base frame (``TendonPlace``,
  rodsim/core/tendon.py);
- a rod joined to another at its joint (``JoinedPlace``, rodsim/core/anchors.py).

Each place is a ``BasePlace`` subclass; defining it registers it. The model asks
``base_place(scene, rod)`` — the registered place of highest ``precedence`` that
``claims`` the rod — for the rod's support and for the order it builds the rods in (a rod
whose base is placed on another rod, its ``parent``, after that rod); nothing else in the
model knows the kinds of rod.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.supports import Support, base_support

__all__ = ["BasePlace", "OriginPlace", "base_place", "registered_base_places"]

_PLACES: dict[str, type[BasePlace]] = {}


class BasePlace:
    """Where the base support of a kind of rod is: subclass with a unique ``name``
    (defining the class registers it) and a ``precedence`` above the other places that may
    claim the same rods (the first claim wins). A place is never instantiated. ``scene``
    is a resolved ``rodsim.core.scene.Scene`` (not imported: the scene imports the
    supports)."""

    #: The place's name (for messages and the registry).
    name: ClassVar[str] = ""
    #: Places are asked in decreasing precedence; the first that claims a rod places it.
    precedence: ClassVar[int] = 0

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if not cls.name:
            raise TypeError(f"base place {cls.__name__} must set a name")
        if cls.name in _PLACES:
            raise TypeError(f"base place name {cls.name!r} is already registered "
                            f"({_PLACES[cls.name].__name__})")
        _PLACES[cls.name] = cls

    @classmethod
    def claims(cls, scene: Any, rod: str) -> bool:
        """Whether rod ``rod`` of ``scene`` is of this place's kind."""
        raise NotImplementedError

    @classmethod
    def parent(cls, scene: Any, rod: str) -> str | None:
        """The rod the base of ``rod`` is placed on (built first), or None."""
        return None

    @classmethod
    def order(cls, scene: Any, rod: str) -> tuple[int, int]:
        """The rod's key in the order the model builds the rods (stable over the scene's
        order): a rod's key must sort after its ``parent``'s. It sets the rods' places in
        the state vector, so a shipped place's key never changes."""
        return (0, 0)

    @classmethod
    def support(cls, scene: Any, rod: str, rods: Mapping[str, Rod]) -> Support:
        """The base support of ``rod``: the kind its ``clamp`` names at this place
        (``rods`` holds its ``parent``, built)."""
        raise NotImplementedError


class OriginPlace(BasePlace):
    """A backbone rod's base: its ``origin``, moved along +x by ``insertion`` and turned
    about it by ``rotation`` (``[rods.<rod>.base]``). Claims every rod the others leave."""

    name = "origin"
    precedence = -1

    @classmethod
    def claims(cls, scene: Any, rod: str) -> bool:
        return True

    @classmethod
    def support(cls, scene: Any, rod: str, rods: Mapping[str, Rod]) -> Support:
        options = scene.rods[rod]
        return base_support(options.clamp, scene.base_options(rod),
                            np.asarray(options.origin, dtype=float))


def registered_base_places() -> dict[str, type[BasePlace]]:
    """Every base place by name, in decreasing precedence."""
    return dict(sorted(_PLACES.items(), key=lambda item: -item[1].precedence))


def base_place(scene: Any, rod: str) -> type[BasePlace]:
    """The place of rod ``rod``'s base: the first registered place, in decreasing
    precedence, that claims it."""
    for place in registered_base_places().values():
        if place.claims(scene, rod):
            return place
    raise AssertionError("unreachable: OriginPlace claims every rod")
