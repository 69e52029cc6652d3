"""Regenerate the scene-key reference in docs/scenes.md from the code's declarations.

    python docs/generate_scene_reference.py          # rewrite docs/scenes.md
    python docs/generate_scene_reference.py --check  # exit 1 if docs/scenes.md is stale

Reads rodsim.core.rod.rod.ROD_PARAMETERS, rodsim.core.supports.all_base_parameters() and
SUPPORT_PARAMETERS, rodsim.core.damping.DAMPING_PARAMETERS,
rodsim.core.tendon.TENDON_PARAMETERS,
rodsim.core.scene.SOLVER_PARAMETERS, every registered term (``parameters``, ``equation``,
``scope``) and every registered integrator (``parameters``, ``summary``,
``quaternion_norm``), and replaces the text between the markers
``<!-- BEGIN GENERATED -->`` and ``<!-- END GENERATED -->``. Everything else in the file is
hand-written and left alone.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import re
import sys
from pathlib import Path

from rodsim.core.damping_options import DAMPING_PARAMETERS
from rodsim.core.rod.rod import ROD_PARAMETERS
from rodsim.core.rod.sections import INHERITED, SECTION_PARAMETERS
from rodsim.core.scene import SOLVER_PARAMETERS
from rodsim.core.schema import Parameter
from rodsim.core.supports import SUPPORT_PARAMETERS, all_base_parameters
from rodsim.core.terms import registered_terms, term_keys
from rodsim.solvers import registered_integrators

try:  # tendon scenes ([tendons.<rod>] tables)
    from rodsim.core.tendon import TENDON_PARAMETERS
except ImportError:  # pragma: no cover - a rodsim without tendons
    TENDON_PARAMETERS = None

BEGIN = "<!-- BEGIN GENERATED -->"
END = "<!-- END GENERATED -->"
TARGET = Path(__file__).resolve().parent / "scenes.md"


def toml_value(value: object) -> str:
    """A default as it would be written in a scene file."""
    if value is None:
        return "*required*"
    if isinstance(value, bool):
        return "`true`" if value else "`false`"
    if isinstance(value, str):
        return f"`{json.dumps(value)}`"
    if isinstance(value, list | tuple):
        return "`[" + ", ".join(json.dumps(v) for v in value) + "]`"
    return f"`{value!r}`"


def allowed(parameter: Parameter, term_names: list[str]) -> str:
    """Allowed values, without the unit (it has its own column)."""
    if parameter.name == "terms" and parameter.choices is None:
        # A term list is checked against the registry when a scene is resolved.
        return "list of distinct names from: " + ", ".join(f"`{t}`" for t in term_names)
    if parameter.choices is not None:
        return "one of " + ", ".join(f"`{json.dumps(c)}`" for c in parameter.choices)
    return dataclasses.replace(parameter, unit="-").allowed


#: A scene table's name with a placeholder, ``[rods.<name>.base]``, written in a meaning: shown
#: as code, or a Markdown renderer (the docs site) would take ``<name>`` for an HTML tag.
TABLE_NAME = re.compile(r"(?<!`)(\[\[?[\w.]*<[\w.<>]+\]\]?)(?!`)")


def meaning(doc: str) -> str:
    """A parameter's doc as a table cell."""
    return TABLE_NAME.sub(r"`\1`", doc.replace("|", "\\|"))


def table(parameters: tuple[Parameter, ...], term_names: list[str] = (),
          inherited: tuple[str, ...] = ()) -> list[str]:
    if not parameters:
        return ["No parameters.", ""]
    lines = ["| key | default | unit | allowed | meaning |", "|---|---|---|---|---|"]
    for p in parameters:
        doc = meaning(p.doc)
        default = "the rod's" if p.name in inherited else toml_value(p.default)
        if p.name == "stretch_modulus" and not inherited:  # rodsim/core/scene.py fills it
            default = "`youngs_modulus`"
        if p.name.startswith("retardation_time_") and p.name != "retardation_time_shear":
            default = "`retardation_time`"  # rodsim/core/damping_options.py follows it
        lines.append(f"| `{p.name}` | {default} | {p.unit} "
                     f"| {allowed(p, list(term_names))} | {doc} |")
        for item in p.items or ():  # the keys of each table of a list of tables
            doc = meaning(item.doc)
            lines.append(f"| `{p.name}[].{item.name}` | {toml_value(item.default)} "
                         f"| {item.unit} | {allowed(item, [])} | {doc} |")
    return [*lines, ""]


def term_tables(terms: dict, scope: str, prefix: str) -> list[str]:
    """One table per scene key; a key with variants (the lumen's couplings, selected by the
    tendon's ``coupling``) gets one table per variant."""
    out = []
    for key in sorted({t.key for t in terms.values() if t.scope == scope}):
        variants = [t for _, t in sorted(terms.items()) if t.key == key]
        if len(variants) > 1 and all(t.parameters == variants[0].parameters
                                     for t in variants):
            out += [f"### `[{prefix}.{key}]` — " + "; ".join(
                f"{t.selection}: {t.equation}" for t in variants), ""]
            out += ["Terms " + ", ".join(f"`{t.name}` ({t.selection}, "
                                         f"`{t.__module__.replace('.', '/')}.py`)"
                                         for t in variants) + ".", ""]
            out += table(variants[0].parameters)
            continue
        for term in variants:
            out += [f"### `[{prefix}.{key}]` — {term.equation}", ""]
            if len(variants) > 1:
                out += [f"With `coupling = \"{term.coupling}\"` (term `{term.name}`, "
                        f"`{term.__module__.replace('.', '/')}.py`).", ""]
            out += table(term.parameters)
    return out


def reference() -> str:
    terms = registered_terms()
    integrators = registered_integrators()
    scopes = {t.scope for t in terms.values()}
    rod_terms = term_keys("rod")
    out = [
        "<!-- Generated by docs/generate_scene_reference.py from the code's parameter "
        "declarations; do not edit by hand. -->",
        "",
        "### `[rods.<name>]`",
        "",
        *table(ROD_PARAMETERS, rod_terms),
        "### `[[rods.<name>.sections]]`",
        "",
        "Optional spans of a rod with their own material and cross-section; when given they "
        "must cover the rod, in order (docs/model.md, \"Sections\").",
        "",
        *table(SECTION_PARAMETERS, inherited=INHERITED),
        "### `[rods.<name>.base]` — the base support (rodsim/core/supports.py)",
        "",
        "Not for a tendon rod: its base is its lumen's entrance and moves with its "
        "catheter's base.",
        "",
        *table(all_base_parameters()),
        "### `[rods.<name>.supports.<support>]` — a node held in place "
        "(rodsim/core/supports.py)",
        "",
        "Any number, each named: a pin (position), or with `orientation = true` a clamp "
        "(position and frame: the frame elements of l/2 on both sides of the node, "
        "rodsim/core/terms/bend_twist.py). Not for a tendon rod.",
        "",
        *table(SUPPORT_PARAMETERS),
        "### `[rods.<name>.damping]` — physical damping in physical time "
        "(rodsim/core/damping.py)",
        "",
        "Optional; read by `rodsim.simulate` and `rodsim.modes` only (docs/dynamics.md), "
        "never by the equilibrium solvers.",
        "",
        *table(DAMPING_PARAMETERS),
        *term_tables(terms, "rod", "rods.<name>"),
    ]
    if TENDON_PARAMETERS is not None:
        tendon_terms = term_keys("tendon")
        out += ["### `[tendons.<rod>]`", "", *table(TENDON_PARAMETERS, tendon_terms),
                *term_tables(terms, "tendon", "tendons.<rod>")]
    for scope in sorted(scopes - {"rod", "tendon", "obstacle", "support"}):
        out += term_tables(terms, scope, f"{scope}s.<...>")
    if "obstacle" in scopes:
        from rodsim.core.obstacles import COMMON_PARAMETERS, registered_obstacles

        out += ["### `[obstacles.<name>]`", "",
                "A rigid obstacle and the rods it acts on; the contact term "
                "(docs/contact.md) is added for each of them. Every obstacle has:", "",
                *table(COMMON_PARAMETERS)]
        for kind, obstacle in sorted(registered_obstacles().items()):
            out += [f"#### `type = \"{kind}\"`", "", *table(obstacle.parameters)]
    out += ["### `[solver]`", "", *table(SOLVER_PARAMETERS)]
    for name, integrator in integrators.items():
        summary = integrator.summary[:1].upper() + integrator.summary[1:]
        out += [f"### `[solver.{name}]`", "",
                f"{summary}. Quaternion norm: {integrator.quaternion_norm}.", "",
                *table(integrator.parameters)]
    return "\n".join(out).rstrip() + "\n"


def rewrite(text: str) -> str:
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        raise SystemExit(f"{TARGET}: markers {BEGIN} ... {END} not found")
    return text[:start + len(BEGIN)] + "\n" + reference() + text[end:]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="only check that docs/scenes.md is up to date (exit 1 if not)")
    args = parser.parse_args(argv)
    text = TARGET.read_text(encoding="utf-8")
    new = rewrite(text)
    if args.check:
        if new != text:
            print(f"{TARGET} is out of date: run python docs/generate_scene_reference.py",
                  file=sys.stderr)
            return 1
        return 0
    if new != text:
        TARGET.write_text(new, encoding="utf-8")
        print(f"rewrote the generated section of {TARGET}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
