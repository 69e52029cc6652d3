"""Where ``rodsim bench`` finds the benchmarks: they are not part of the installed package.

The benchmark code is the package ``rodsim_bench`` in the ``benchmarks/`` folder of a source
checkout (next to ``benchmarks/results``, where the committed results live). rodsim never
imports it as a library; the ``bench`` command loads it from the checkout this rodsim was
imported from (an editable install or running from the tree), or from ``sys.path`` (e.g.
``PYTHONPATH=benchmarks``). An installed rodsim without a checkout has no benchmarks:
:class:`BenchmarksMissing` says so.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path
from types import ModuleType

__all__ = ["BenchmarksMissing", "checkout_root", "load_benchmarks", "default_output"]

PACKAGE = "rodsim_bench"


class BenchmarksMissing(LookupError):
    """The benchmark package is neither in a source checkout nor importable."""


def checkout_root() -> Path | None:
    """The source checkout this rodsim was imported from (it has ``benchmarks/rodsim_bench``
    beside the ``rodsim`` folder), or None for an installed rodsim."""
    root = Path(__file__).resolve().parents[2]  # rodsim/app/bench_locator.py → the checkout
    if (root / "benchmarks" / PACKAGE / "__init__.py").is_file():
        return root
    return None


def load_benchmarks() -> ModuleType:
    """The ``rodsim_bench`` package: the checkout's, else one on ``sys.path``."""
    root = checkout_root()
    if root is not None:
        folder = str(root / "benchmarks")
        if folder not in sys.path:
            sys.path.insert(0, folder)
    try:
        return importlib.import_module(PACKAGE)
    except ModuleNotFoundError as exc:
        if exc.name != PACKAGE:
            raise
        raise BenchmarksMissing(
            "the benchmarks are not installed with rodsim: they live in the benchmarks/ "
            "folder of a source checkout (git clone the repository and pip install -e . "
            "there, or put its benchmarks/ folder on PYTHONPATH)") from None


def default_output() -> Path | None:
    """``benchmarks/results`` of the checkout, or None when there is no such folder."""
    root = checkout_root()
    if root is None or not (root / "benchmarks" / "results").is_dir():
        return None
    return root / "benchmarks" / "results"
