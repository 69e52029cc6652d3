"""``rodsim scenes`` and ``rodsim terms``: what a scene can name."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from rodsim.app.cli.common import EXIT_OK

if TYPE_CHECKING:
    from rodsim.core.terms import Term

__all__ = ["cmd_scenes", "cmd_terms"]


def cmd_scenes(args: argparse.Namespace) -> int:
    from rodsim.core.scene import Scene, scene_paths

    for name, path in scene_paths().items():
        print(f"{name:<24s} {Scene.load(path).description}")
    return EXIT_OK


def cmd_terms(args: argparse.Namespace) -> int:
    from rodsim.core.terms import registered_terms

    for name, term in registered_terms().items():
        print(f"{term_label(name, term):<20s} {term.equation}  [{term_place(term)}]")
        for parameter in () if term.scope == "support" else term.parameters:
            print(f"    {parameter.help()}")
    return EXIT_OK


def term_label(name: str, term: type[Term]) -> str:
    """The scene key a term answers, with the variant's registry name when several terms
    share the key (the lumen: ``lumen (lumen_conserving)``, chosen by the tendon's
    coupling)."""
    return term.key if term.key == name else f"{term.key} ({name})"


def term_place(term: type[Term]) -> str:
    """Where a scene asks for the term: a rod's or a tendon's ``terms`` list, or a table
    of its own (contact: ``[obstacles.<name>]``), or a support kind's (the elastic base:
    ``rods.<rod>.clamp``, its keys in ``[rods.<rod>.base]``)."""
    if term.scene_table:
        return f"[{term.scene_table}.<name>]"
    if term.scope == "support":
        return "rods.<rod>.clamp: added by a support kind, its keys in [rods.<rod>.base]"
    return ("rods.<rod>" if term.scope == "rod" else "tendons.<tendon rod>") + ".terms"

