"""Dotted scene keys (``rods.catheter.nodes``, ``tip_load.force``): the keys a scene holds
and may take, a short key resolved to the one it ends, a value assigned at a key, and an
override's value parsed — what ``rodsim.core.scene.Scene.with_overrides`` (``--set``)
and ``rodsim.core.scene.Scene.get`` are made of."""

from __future__ import annotations

import difflib
import tomllib
from collections.abc import Mapping
from typing import Any

from rodsim.core.damping_options import DAMPING_PARAMETERS
from rodsim.core.schema import SceneError, shown

__all__ = ["leaf_keys", "integrator_option", "damping_keys", "resolve_key", "assign",
           "drop_unlisted_term_tables", "parse_value"]


def leaf_keys(node: Any, prefix: str = "") -> list[str]:
    """The dotted keys of every value under ``node``; the scene's ``[program]`` table is
    left out (its entries are keys themselves, set with ``--program``, not ``--set``)."""
    if isinstance(node, Mapping):
        out = []
        for key, value in node.items():
            if not prefix and key == "program":
                continue
            out += leaf_keys(value, f"{prefix}.{key}" if prefix else str(key))
        return out
    if isinstance(node, list) and node and all(isinstance(v, Mapping) for v in node):
        out = []
        for i, value in enumerate(node):
            out += leaf_keys(value, f"{prefix}.{i}")
        return out
    return [prefix]


def integrator_option(key: str) -> tuple[str, ...]:
    """``(key,)`` when ``key`` is a full ``solver.<integrator>.<option>`` key, which may be set
    although the scene does not hold it yet (the integrator validates it); else ``()``."""
    return (key,) if key.startswith("solver.") and key.count(".") == 2 else ()


def damping_keys(data: Mapping[str, Any]) -> tuple[str, ...]:
    """Every rod's ``rods.<rod>.damping.<value>`` key, which may be set although the scene
    has no damping table (read by ``rodsim simulate`` only; docs/dynamics.md)."""
    return tuple(f"rods.{rod}.damping.{parameter.name}" for rod in data.get("rods", {})
                 for parameter in DAMPING_PARAMETERS)


def resolve_key(data: Mapping[str, Any], key: str, prefer: str = "",
                 known: tuple[str, ...] = ()) -> str:
    leaves = leaf_keys(data)
    leaves += [k for k in known if k not in leaves]
    if key in leaves:
        return key
    matches = [leaf for leaf in leaves if leaf.endswith("." + key)]
    preferred = [leaf for leaf in matches if prefer and leaf.startswith(prefer + ".")]
    if len(matches) == 1:
        return matches[0]
    if len(preferred) == 1:
        return preferred[0]
    if not matches:
        names = sorted({leaf.rsplit(".", 1)[-1] for leaf in leaves} | set(leaves))
        close = difflib.get_close_matches(key, names, n=3)
        hint = f"; closest: {', '.join(close)}" if close else ""
        raise SceneError(f"unknown key {shown(key, bare=True)}: no scene key is it or ends "
                         f"with it (docs/scenes.md lists the keys){hint}", key=key,
                         allowed=tuple(close), reason="unknown key")
    raise SceneError(f"ambiguous key {shown(key, bare=True)}: could be {', '.join(matches)}",
                     key=key, allowed=tuple(matches), reason="ambiguous key")


def assign(data: dict[str, Any], key: str, value: Any) -> dict[str, Any]:
    node: Any = data
    parts = key.split(".")
    for part in parts[:-1]:
        node = node[int(part)] if isinstance(node, list) else node.setdefault(part, {})
    last = parts[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value
    return data


def drop_unlisted_term_tables(data: dict[str, Any], terms_key: str) -> None:
    """After an override ``<rod>.terms=[…]``: drop the parameter tables of the terms the new list
    leaves out (they came from the scene or its defaults; keeping them would refuse the
    removal as "parameters given for a term that terms does not list")."""
    from rodsim.core.terms import registered_terms

    node: Any = data
    for part in terms_key.split(".")[:-1]:
        node = node[part]
    listed = node["terms"] if isinstance(node["terms"], list) else []
    for term in {kind.key for kind in registered_terms().values()}:
        if term in node and term not in listed:
            del node[term]


def parse_value(text: str) -> Any:
    """An override's value: TOML if it parses as one, else the plain string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:
        raise SceneError(f"value {shown(text)}: nested too deeply", value=text,
                         reason="nested too deeply") from None
