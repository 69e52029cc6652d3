"""Energy and penalty terms, one file each, and the registry that finds them.

See :mod:`rodsim.core.terms.base` for the contract. To add a term, add one file here defining a
``RodTerm`` or ``TendonTerm`` subclass with a new ``name``; nothing else changes:
:func:`registered_terms` imports every module of this package on first use.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil

from rodsim.core.terms.base import REGISTRY, RodTerm, TendonTerm, Term

__all__ = ["REGISTRY", "Term", "RodTerm", "TendonTerm", "registered_terms"]


def registered_terms() -> dict[str, type[Term]]:
    """Every registered term class by name (imports this package's modules)."""
    _import_every_module()
    return dict(REGISTRY)


@functools.cache
def _import_every_module() -> None:
    """Import each module of this package once (defining a class registers it)."""
    for module in pkgutil.iter_modules(__path__):
        if not module.name.startswith("_"):
            importlib.import_module(f"{__name__}.{module.name}")
