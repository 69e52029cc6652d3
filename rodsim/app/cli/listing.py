"""``rodsim scenes`` and ``rodsim terms``: what a scene can name."""

from __future__ import annotations

import argparse

from rodsim.app.cli.common import EXIT_OK

__all__ = ["cmd_scenes", "cmd_terms"]


def cmd_scenes(args: argparse.Namespace) -> int:
    from rodsim.core.scene import Scene, scene_paths

    for name, path in scene_paths().items():
        print(f"{name:<24s} {Scene.load(path).description}")
    return EXIT_OK


def cmd_terms(args: argparse.Namespace) -> int:
    from rodsim.core.terms import registered_terms

    for name, term in registered_terms().items():
        where = "rods.<rod>" if term.scope == "rod" else "tendons.<tendon rod>"
        print(f"{name:<20s} {term.equation}  [{where}.terms]")
        for parameter in term.parameters:
            print(f"    {parameter.help()}")
    return EXIT_OK
