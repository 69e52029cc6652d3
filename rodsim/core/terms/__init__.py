"""Energy and penalty terms, one file each, and the registry that finds them.

See ``rodsim.core.terms.base`` for the contract. To add a term, add one file here defining a
``RodTerm`` or ``TendonTerm`` subclass with a new ``name``; nothing else changes:
``registered_terms`` imports every module of this package on first use.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from collections.abc import Mapping
from typing import Any

from rodsim.core.terms.base import REGISTRY, RodTerm, TendonTerm, Term

__all__ = ["REGISTRY", "Term", "RodTerm", "TendonTerm", "registered_terms", "term_class",
           "term_keys"]


def registered_terms() -> dict[str, type[Term]]:
    """Every registered term class by name, in the names' order (imports this package's
    modules; the order does not depend on which of them something imported first)."""
    _import_every_module()
    return dict(sorted(REGISTRY.items()))


def term_keys(scope: str) -> list[str]:
    """The scene keys a rod (``scope = "rod"``) or a tendon (``"tendon"``) may list in its
    ``terms``, sorted (a key shared by variants once)."""
    return sorted({cls.key for cls in registered_terms().values() if cls.scope == scope})


def term_class(key: str, owner: Mapping[str, Any]) -> type[Term]:
    """The term class the scene key ``key`` builds for the owner table ``owner`` (a rod's or
    a tendon's own values): the registered class of that key that the table selects
    (``Term.selected_by``; the lumen's ``coupling``). KeyError when none does."""
    for cls in registered_terms().values():
        if cls.key == key and cls.selected_by(owner):
            return cls
    raise KeyError(key)


@functools.cache
def _import_every_module() -> None:
    """Import each module of this package once (defining a class registers it)."""
    for module in pkgutil.iter_modules(__path__):
        if not module.name.startswith("_"):
            importlib.import_module(f"{__name__}.{module.name}")
