"""Command line: ``rodsim run | rerun | track | fit | reach | study | plot | scenes | terms``
(and ``bench``).

One file per command (or family: ``listing`` for scenes and terms), the parser
(``rodsim.app.cli.parser``), what every command shares
(``rodsim.app.cli.common``), the one scene → output → solve → print → write path of
run, track, fit and reach (``rodsim.app.cli.pipeline``), and ``main`` /
``entry`` (``rodsim.app.cli.main``). Nothing here imports numpy or the solvers at
module level: ``rodsim --help`` stays lean (rodsim/app/lean.py).
"""

from __future__ import annotations

from rodsim.app.cli.main import entry, main
from rodsim.app.cli.parser import build_parser

__all__ = ["main", "entry", "build_parser"]
