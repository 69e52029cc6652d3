"""Energy and penalty terms, one file each; importing this package registers all of them.

See :mod:`rodsim.core.terms.base` for the contract. To add a term, add one file here defining a
``RodTerm`` or ``TendonTerm`` subclass with a new ``name``; nothing else changes.
"""

import importlib
import pkgutil

from rodsim.core.terms.base import (
    REGISTRY,
    RodTerm,
    TendonTerm,
    Term,
    registered_terms,
)

for _module in pkgutil.iter_modules(__path__):
    if not _module.name.startswith("_") and _module.name != "base":
        importlib.import_module(f"{__name__}.{_module.name}")

__all__ = ["REGISTRY", "Term", "RodTerm", "TendonTerm", "registered_terms"]
