"""Where ``rodsim bench`` finds the benchmarks: they are not part of the installed package.

The benchmark code is the package ``rodsim_bench`` in the ``benchmarks/`` folder of a source
checkout (next to ``benchmarks/results``, where the committed results live). rodsim never
imports it as a library; the ``bench`` command loads it from a checkout, found in this
order:

1. the checkout this rodsim was imported from (an editable install, or running from the
   tree);
2. the folder ``pip install .`` installed this rodsim from (recorded by pip in the
   distribution's ``direct_url.json``, PEP 610);
3. the current folder or one of its parents (running ``rodsim bench`` inside a clone);

or from ``sys.path`` (e.g. ``PYTHONPATH=benchmarks``). Without any of them,
``BenchmarksMissing`` says so in one line.

The results go to ``runs/bench`` of the current folder unless asked otherwise
(``-o DIR``, or ``--commit`` for the checkout's committed ``benchmarks/results``).
"""

from __future__ import annotations

import importlib
import json
import sys
from collections.abc import Iterator
from importlib import metadata
from pathlib import Path
from types import ModuleType
from urllib.parse import unquote, urlparse

__all__ = ["BenchmarksMissing", "checkout_root", "load_benchmarks", "default_output",
           "results_folder"]

PACKAGE = "rodsim_bench"

#: Where ``rodsim bench`` writes without ``-o`` or ``--commit`` (relative to the current
#: folder, like every other command's ``runs/``).
DEFAULT_OUTPUT = Path("runs") / "bench"


class BenchmarksMissing(LookupError):
    """The benchmark package is neither in a source checkout nor importable."""


def _is_checkout(folder: Path) -> bool:
    return (folder / "benchmarks" / PACKAGE / "__init__.py").is_file() and (
        folder / "pyproject.toml").is_file()


def _installed_from() -> Path | None:
    """The local folder pip installed the ``rodsim`` distribution from, if it recorded one."""
    try:
        text = metadata.distribution("rodsim").read_text("direct_url.json")
    except metadata.PackageNotFoundError:
        return None
    if not text:
        return None
    try:
        url = json.loads(text).get("url", "")
    except (ValueError, AttributeError):
        return None
    parsed = urlparse(url)
    if parsed.scheme != "file":
        return None
    return Path(unquote(parsed.path))


def _candidates() -> Iterator[Path]:
    yield Path(__file__).resolve().parents[2]  # rodsim/app/bench_locator.py → the checkout
    installed = _installed_from()
    if installed is not None:
        yield installed
    here = Path.cwd().resolve()
    yield here
    yield from here.parents


def checkout_root() -> Path | None:
    """The source checkout the benchmarks are loaded from (it has ``benchmarks/rodsim_bench``
    and ``pyproject.toml``), or None when none can be found."""
    for folder in _candidates():
        if _is_checkout(folder):
            return folder
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
            "folder of a source checkout (run rodsim bench inside a clone of the repository, "
            "or pip install it from one, or put its benchmarks/ folder on PYTHONPATH)"
        ) from None


def default_output() -> Path | None:
    """``benchmarks/results`` of the checkout (what ``--commit`` writes to), or None when
    there is no such folder."""
    root = checkout_root()
    if root is None or not (root / "benchmarks" / "results").is_dir():
        return None
    return root / "benchmarks" / "results"


def results_folder(output: str | None, commit: bool) -> Path | None:
    """Where a benchmark writes: ``output`` if given, the checkout's committed results with
    ``commit`` (None if there is none), else ``DEFAULT_OUTPUT``."""
    if output is not None:
        return Path(output)
    if commit:
        return default_output()
    return DEFAULT_OUTPUT
