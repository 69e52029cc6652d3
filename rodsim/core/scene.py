"""Scenes: TOML files describing rods, their terms, tendons and the solver settings.

A scene is validated once into a *resolved* dict in which every default of the rods, terms,
tendons and generic solver settings is filled in; that dict (as JSON) is what archives store
and what ``rodsim rerun`` reads back. The ``[solver.<integrator>]`` tables are kept as given:
each integrator validates and completes its own options
(``rodsim.solvers.base.Integrator.options_of``), so this module never imports the
solvers (docs/architecture.md).
Any problem raises ``rodsim.core.schema.SceneError`` with a one-line message naming the key
and the allowed values. Layout of a scene file (docs/scenes.md has the full reference)::

    name = "hanging-mass-50g"
    [rods.catheter]            # one table per rod
    length = 0.12              # m
    ...
    terms = ["stretch", "bend_twist", "centerline", "tip_load"]
    [rods.catheter.tip_load]   # parameters of one of the rod's terms
    mass = 0.05                # kg
    [rods.catheter.base]       # the base support's place (rodsim/core/supports.py)
    insertion = 0.0            # m
    [tendons.tendon]           # a rod routed through a lumen of another (tendon scenes)
    catheter = "catheter"
    [tendons.tendon.lumen]     # parameters of one of the tendon's coupling terms
    K_L = 1000.0               # N/m
    [solver]                   # integrator and stopping rule
    integrator = "cvode"       # unset: static (rodsim/core/integrator_default.py)
    [solver.paper]             # options of one integrator
    h = 0.3
    [program."tip_load.mass"]  # a value varying in time (rodsim simulate; core/program.py)
    amplitude = 0.01           # the key's unit
    frequency = 2.0            # Hz
"""

from __future__ import annotations

import copy
import difflib
import json
import tomllib
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rodsim.core.anchors import check_joints
from rodsim.core.damping_options import resolve_damping
from rodsim.core.integrator_default import DEFAULT_INTEGRATOR
from rodsim.core.names import check_rod_name, check_scene_name
from rodsim.core.program import resolve_program
from rodsim.core.rod.rod import ROD_PARAMETERS, RodOptions
from rodsim.core.rod.sections import resolve_sections
from rodsim.core.scene_file import parse_toml, read_scene_text
from rodsim.core.scene_keys import (
    assign,
    damping_keys,
    drop_unlisted_term_tables,
    integrator_option,
    parse_value,
    resolve_key,
)
from rodsim.core.schema import (
    PATH_WIDTH,
    Options,
    Parameter,
    SceneError,
    shown,
    shown_path,
    validate_table,
)
from rodsim.core.supports import (
    BASE_PARAMETERS,
    BaseOptions,
    refuse_support_terms,
    resolve_base,
    resolve_supports,
    support_kind,
)
from rodsim.core.tendon import (
    STRING_TERMS,
    TENDON_PARAMETERS,
    TendonOptions,
    check_tendon,
    physical_default,
)

if TYPE_CHECKING:
    from rodsim.core.terms.base import Term

__all__ = ["Scene", "SceneError", "SOLVER_PARAMETERS", "OBSTACLE_INTEGRATOR", "SolverSettings",
           "default_scene_path",
           "scene_paths"]

#: The integrator of a scene with obstacles that names none (``solver.integrator`` unset):
#: on a rod pressed against an obstacle, IDA reached equilibrium in 0.04–0.2 s where CVODE
#: took up to 4 s, and never slower by more than 0.06 s (measured on twelve variants of
#: tip-on-tissue and ten other contact scenes: docs/contact.md, "Which integrator").
OBSTACLE_INTEGRATOR = "ida"

SOLVER_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("integrator", "str", DEFAULT_INTEGRATOR, "-",
              "integrator used by `rodsim run`: a registered name (each has a "
              "[solver.<name>] table in docs/scenes.md); unset in a scene with obstacles, "
              f"{OBSTACLE_INTEGRATOR} (docs/contact.md)"),
    Parameter("tolerance", "float", 1e-9, "-",
              "equilibrium reached when the scaled force residual is below this "
              "(forces / load scale F_ref, quaternion forces / (F_ref L))",
              0.0, 1.0, exclusive_minimum=True),
    Parameter("max_wall_time", "float", 600.0, "s", "give up after this much wall time",
              0.0, 1e6, exclusive_minimum=True),
    Parameter("kernels", "str", "auto", "-",
              "force and Jacobian evaluation: 'compiled' (numba kernels, cached on disk), "
              "'numpy' (the readable reference; same numbers to round-off), 'tiered' (numpy "
              "until its evaluations have cost, nominally and never by the clock, what loading "
              "the compiled kernels would, about 0.25 s of CPU, then compiled) or 'auto': "
              "tiered for `rodsim run` (one solve in a fresh process), compiled everywhere else",
              choices=("auto", "compiled", "numpy", "tiered")),
)

@dataclass(frozen=True, kw_only=True)
class SolverSettings(Options):
    """The generic solver settings of a scene ([solver]), typed: one field per
    ``SOLVER_PARAMETERS`` (checked by tests/test_types.py); each integrator's own
    ``[solver.<name>]`` options are its ``Options``
    (``rodsim.solvers.base.Integrator.options_of``)."""

    integrator: str = DEFAULT_INTEGRATOR
    tolerance: float = 1e-9
    max_wall_time: float = 600.0
    kernels: str = "auto"

_TOP_KEYS = ("name", "description", "rods", "tendons", "obstacles", "solver", "program")



def scene_paths() -> dict[str, Path]:
    """Shipped scene files by name (file stem): the repository's ``data/`` folder, installed
    as the package ``rodsim.data``."""
    folder = Path(str(resources.files("rodsim.data")))
    return {p.stem: p for p in sorted(folder.glob("*.toml"))}


def default_scene_path() -> Path:
    """The scene ``rodsim run`` uses without argument: Table 1 with the 50 g mass."""
    return scene_paths()[DEFAULT_SCENE]


#: Name of the scene ``rodsim run`` uses without argument.
DEFAULT_SCENE = "table1-50g"


@dataclass(frozen=True)
class Scene:
    """A validated scene.

    Attributes
    ----------
    data
        The resolved scene: every table validated and every default filled in.
    source
        The scene file's text, verbatim (empty when built from a dict).
    """

    data: dict[str, Any]
    source: str = ""

    @classmethod
    def load(cls, path: str | Path) -> Scene:
        """Read and validate a TOML scene file, or a shipped scene by name."""
        path = Path(path)
        if "\0" in str(path):
            raise SceneError(f"cannot read scene {shown(str(path))}: a NUL in the path")
        try:
            missing = not path.exists() and not path.is_symlink()
        except OSError as exc:  # a name too long for the system
            raise SceneError(f"cannot read scene {shown_path(path)}: "
                             f"{exc.strerror or type(exc).__name__}") from None
        if missing:
            shipped = scene_paths()
            if path.suffix == "" and str(path) in shipped:
                path = shipped[str(path)]
            else:
                close = difflib.get_close_matches(str(path), list(shipped), n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise SceneError(f"{shown(str(path), width=PATH_WIDTH, bare=True)} is neither a "
                                 f"shipped scene nor a file{hint}; shipped scenes: "
                                 f"{', '.join(shipped)}",
                                 key=str(path), allowed=tuple(shipped),
                                 reason="no such scene")
        text = read_scene_text(path)
        raw = parse_toml(text, shown(str(path), width=PATH_WIDTH, bare=True))
        _files_beside(raw, path.parent)
        return cls(resolve(raw), text)

    @classmethod
    def from_dict(cls, raw: Mapping[str, Any]) -> Scene:
        """Validate a scene given as a (possibly partial) dict."""
        try:
            return cls(resolve(copy.deepcopy(dict(raw))))
        except RecursionError:
            raise SceneError("scene: nested too deeply") from None

    @classmethod
    def from_json(cls, text: str, source: str = "") -> Scene:
        """Rebuild a scene from ``to_json`` (as stored in archives)."""
        try:
            raw = json.loads(text)
        except (ValueError, RecursionError):
            raise SceneError("stored scene: not valid JSON, or nested too deeply") from None
        if not isinstance(raw, dict):
            raise SceneError(f"stored scene: not a JSON object (got {type(raw).__name__})")
        return cls.from_dict(raw).with_source(source)

    def with_source(self, source: str) -> Scene:
        """The same scene, with ``source`` as its file text."""
        return Scene(self.data, source)

    def to_json(self) -> str:
        """The resolved scene as canonical JSON (sorted keys)."""
        return json.dumps(self.data, sort_keys=True)

    @property
    def name(self) -> str:
        return str(self.data["name"])

    @property
    def description(self) -> str:
        return str(self.data["description"])

    @property
    def solver(self) -> SolverSettings:
        """The generic solver settings, a ``SolverSettings`` (a view of ``data``)."""
        return SolverSettings.of(self.data["solver"])

    @property
    def rods(self) -> dict[str, RodOptions]:
        """Each rod's own values by name, as ``rodsim.core.rod.rod.RodOptions`` (views
        of ``data``; the per-term sub-tables are read with ``term_options``)."""
        return {name: RodOptions.of(table) for name, table in self.data["rods"].items()}

    @property
    def tendons(self) -> dict[str, TendonOptions]:
        """Each tendon's own values by its rod's name, as
        ``rodsim.core.tendon.TendonOptions`` (views of ``data``)."""
        return {name: TendonOptions.of(table) for name, table in self.data["tendons"].items()}

    def base_options(self, rod: str) -> BaseOptions:
        """The base support's values of rod ``rod`` ([rods.<rod>.base]: insertion,
        rotation) as a ``rodsim.core.supports.BaseOptions``; the defaults for a tendon
        rod, whose base follows its catheter's."""
        return BaseOptions.of(self.data["rods"][rod].get("base") or
                              {p.name: p.default for p in BASE_PARAMETERS})

    def support_tables(self, rod: str) -> dict[str, Any]:
        """The validated ``[rods.<rod>.supports.<name>]`` tables of rod ``rod`` by name
        (none: an empty dict)."""
        return self.data["rods"][rod].get("supports", {})

    def term_options(self, owner: str, name: str, term: str) -> Any:
        """The options of term ``term`` (its scene key) of rod or tendon ``name`` (``owner``
        is ``"rods"`` or ``"tendons"``), as the term's ``Options`` (a view of ``data``);
        ``None`` when that table does not list the term."""
        table = self.data[owner][name]
        if term not in table["terms"]:
            return None
        return self.term_type(owner, name, term).Options.of(table[term])

    def term_type(self, owner: str, name: str, term: str) -> type[Term]:
        """The term class the scene key ``term`` of rod or tendon ``name`` builds (the
        tendon's ``coupling`` picks the lumen's, ``rodsim.core.terms.term_class``)."""
        from rodsim.core.terms import term_class

        return term_class(term, self.data[owner][name])

    def full_key(self, key: str, prefer: str = "") -> str:
        """The full dotted key that ``key`` names (the short forms of ``with_overrides``;
        SceneError for an unknown or ambiguous key)."""
        return resolve_key(self.data, key, prefer)

    def get(self, key: str) -> Any:
        """Value at a dotted key, with the same short forms as ``with_overrides``."""
        node: Any = self.data
        for part in resolve_key(self.data, key).split("."):
            node = node[int(part)] if isinstance(node, list) else node[part]
        return node

    def with_overrides(self, assignments: Iterable[str], prefer: str = "",
                       known_keys: Iterable[str] = ()) -> Scene:
        """A new scene with ``key=value`` assignments applied in order.

        ``key`` is a dotted path (``rods.catheter.nodes``) or any unambiguous suffix of one
        (``nodes``, ``tip_load.mass``); a suffix that matches several keys resolves to the one
        under ``prefer`` if exactly one is (the CLI prefers ``solver.<chosen integrator>``;
        by default, the scene's own ``solver.<solver.integrator>``).
        ``value`` is parsed as a TOML value (``80``, ``1e4``, ``"corde"``, ``[0, 1, 0]``) and
        falls back to a plain string. Each assignment is validated before the next is
        resolved, so a later key may refer to a term an earlier one added. ``known_keys`` are
        full keys that may be set although the scene does not hold them yet (the integrators'
        options, which ``rodsim.load_scene`` passes so that their short forms work too);
        so may every rod's damping values (``rods.<rod>.damping.retardation_time``,
        ``damping.drag`` on a one-rod scene), which only ``simulate`` and ``modes`` read.
        An assignment whose key or value cannot be read raises SceneError with
        ``assignment`` set (the CLI words it as its ``--set`` flag).
        """
        known = tuple(known_keys)
        data = copy.deepcopy(self.data)
        given: dict[str, str] = {}  # full key -> the assignment that set it
        for assignment in assignments:
            key, sep, text = assignment.partition("=")
            key = key.strip()
            if not sep or not key:
                raise SceneError(f"override {shown(assignment)}: expected key=value",
                                 value=assignment, allowed="key=value",
                                 reason="expected key=value", assignment=assignment)
            preferred = prefer or f"solver.{data['solver']['integrator']}"
            try:
                full_key = resolve_key(data, key, preferred,
                                        known + integrator_option(key) + damping_keys(data))
                value = parse_value(text.strip())
            except SceneError as exc:
                exc.assignment = assignment
                raise
            follower = self._defaulted_stretch(full_key, data)
            data = assign(data, full_key, value)
            if follower and isinstance(value, (int, float)) and not isinstance(value, bool):
                data = assign(data, follower, value)  # E_s defaulted from E_b follows it
            given[full_key] = assignment
            if full_key.endswith(".terms"):
                drop_unlisted_term_tables(data, full_key)
            # Validate as we go so a later key can name a term an earlier one added; a scene
            # that is only invalid half-way (e.g. switching two linked values) is checked
            # again once every assignment is applied.
            try:
                data = resolve(data)
            except SceneError:
                pass
        try:
            return Scene(resolve(data), self.source)
        except SceneError as exc:
            raise _blame_what_was_set(exc, given) from None

    def _defaulted_stretch(self, key: str, data: Mapping[str, Any]) -> str | None:
        """The full key of a rod's ``stretch_modulus`` when ``key`` is that rod's
        ``youngs_modulus`` and the stretch modulus defaulted from it (the scene file's rod
        table does not give it, and it still equals E_b): an override of E_b then moves E_s
        too, as the same scene file with the new E_b would."""
        parts = key.split(".")
        if len(parts) != 3 or parts[0] != "rods" or parts[2] != "youngs_modulus":
            return None
        rod = data["rods"][parts[1]]
        if not self.source or rod.get("stretch_modulus") != rod.get("youngs_modulus"):
            return None
        try:
            table = tomllib.loads(self.source).get("rods", {}).get(parts[1])
        except tomllib.TOMLDecodeError:
            return None
        if not isinstance(table, Mapping) or "stretch_modulus" in table:
            return None
        return f"rods.{parts[1]}.stretch_modulus"

    def with_values(self, values: Mapping[str, Any]) -> Scene:
        """A new scene with already-typed values at dotted keys (used by studies); a full
        ``solver.<integrator>.<option>`` key may be set although the scene does not hold it."""
        data = copy.deepcopy(self.data)
        for key, value in values.items():
            data = assign(data, resolve_key(data, key, known=integrator_option(key)), value)
        return Scene(resolve(data), self.source)


def cross_table_culprit(exc: SceneError, given: Collection[str]) -> tuple[str, str] | None:
    """(the key in ``given`` to blame, why) when ``exc`` is a cross-table rule that failed on
    a value that is not in ``given`` (``exc.key``, the scene's own) because of one that is
    (in ``exc.related``); else None. ``given``: the dotted keys the user set (issue 23:
    such errors were blamed on values the user never gave)."""
    if exc.key is None or exc.key in given:
        return None
    culprits = [key for key in exc.related if key in given]
    if not culprits:
        return None
    return culprits[0], (f"makes {exc.key} = {exc.value!r} (the scene's value, not set) "
                         f"invalid; allowed: {exc.allowed}; change {exc.key} too, or choose "
                         "another value")


def _blame_what_was_set(exc: SceneError, given: Mapping[str, str]) -> SceneError:
    """``exc`` reworded by ``cross_table_culprit`` to name the assignment (as the user
    wrote it, from ``given``: full key -> assignment) that broke the rule."""
    found = cross_table_culprit(exc, given)
    if found is None:
        return exc
    culprit, reason = found
    assignment = given[culprit]
    return SceneError(f"{culprit} = {assignment.partition('=')[2].strip()} {reason}",
                      key=culprit, value=exc.value, allowed=exc.allowed, reason=reason,
                      assignment=assignment,
                      related=(exc.key,) if exc.key is not None else ())


def resolve(raw: Mapping[str, Any]) -> dict[str, Any]:
    """Validate a raw scene dict and fill every default (raises ``SceneError``)."""
    for key in raw:
        if key not in _TOP_KEYS:
            raise SceneError(f"{shown(key, bare=True)}: unknown top-level key; known keys: "
                             f"{', '.join(_TOP_KEYS)}")
    name = check_scene_name(raw.get("name", "unnamed"))
    description = raw.get("description", "")
    if not isinstance(description, str):
        raise SceneError(f"description = {shown(description)}: must be a string")
    rods_raw: Any = raw.get("rods")
    tendons_raw: Any = raw.get("tendons", {})
    if tendons_raw:  # a tendon without a coupling is a string (docs/tendon.md)
        rods_raw, tendons_raw = physical_default(rods_raw, tendons_raw)
    rods = _resolve_rods(rods_raw)
    tendons = _resolve_tendons(tendons_raw, rods)
    joiners: dict[str, str] = {}  # rod -> the key of its term that joins it to another rod
    for rod, table in rods.items():
        _resolve_rod_parts(rod, table, rod in tendons)
        joiner = _check_rod(rod, table, rod in tendons)
        if joiner is not None:
            joiners[rod] = joiner
    check_joints(rods, tendons, joiners)
    solver_raw = raw.get("solver", {})
    solver = _resolve_solver(solver_raw)
    out = {"name": name, "description": description, "rods": rods, "tendons": tendons,
           "solver": solver}
    if "obstacles" in raw:  # only then: a scene without obstacles resolves as before
        from rodsim.core.obstacles import resolve_obstacles

        out["obstacles"] = resolve_obstacles(raw["obstacles"], rods, tendons)
        if "integrator" not in solver_raw:
            solver["integrator"] = OBSTACLE_INTEGRATOR
    if "program" in raw:  # only then: a scene without programs resolves as before
        out["program"] = resolve_program(raw["program"])
    return out


def _resolve_rods(rods_raw: Any) -> dict[str, dict[str, Any]]:
    """The ``[rods.<name>]`` tables validated, each with its terms' tables and its
    ``sections`` (the ``base``, ``supports`` and ``damping`` sub-tables are left to
    ``_resolve_rod_parts``). A rod table that gives E_b without E_s is an ideal material:
    E_s = E_b."""
    from rodsim.core.terms import term_keys

    if not isinstance(rods_raw, Mapping) or not rods_raw:
        raise SceneError("rods: a scene needs at least one [rods.<name>] table")
    for rod in rods_raw:
        check_rod_name(rod, "rods")
    rod_terms = term_keys("rod")
    rods = {}
    for rod, table in rods_raw.items():
        given = isinstance(table, Mapping) and "sections" in table
        own = {k: v for k, v in table.items() if k != "sections"} if given else table
        if (isinstance(own, Mapping) and "youngs_modulus" in own
                and "stretch_modulus" not in own):  # E_s = E_b, an ideal material
            own = {**own, "stretch_modulus": own["youngs_modulus"]}
        refuse_support_terms(rod, own)  # a support's term, named as a term: its kind
        rods[rod] = _resolve_with_terms(own, ROD_PARAMETERS, rod_terms, f"rods.{rod}",
                                        extra_tables=("base", "supports", "damping"))
        if given:  # only then: a uniform rod's resolved table is unchanged
            rods[rod]["sections"] = resolve_sections(table["sections"], rods[rod],
                                                     f"rods.{rod}")
    return rods


def _resolve_tendons(tendons_raw: Any, rods: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """The ``[tendons.<rod>]`` tables validated, each with its terms' tables, each term's
    options checked against the tendon and the tendon against its rods (``check_tendon``).
    A string tendon's default term list is ``STRING_TERMS``."""
    from rodsim.core.terms import term_class, term_keys

    if not isinstance(tendons_raw, Mapping):
        raise SceneError("tendons: expected tables [tendons.<tendon rod name>]")
    tendon_terms = term_keys("tendon")
    tendons = {}
    for rod, table in tendons_raw.items():
        prefix = f"tendons.{check_rod_name(rod, 'tendons')}"
        if (isinstance(table, Mapping) and table.get("coupling") == "string"
                and "terms" not in table):
            table = {**table, "terms": list(STRING_TERMS)}  # a string tendon's default term
        tendons[rod] = _resolve_with_terms(table, TENDON_PARAMETERS, tendon_terms, prefix)
        kinds = {term: term_class(term, tendons[rod]) for term in tendons[rod]["terms"]}
        term_options = {term: kinds[term].Options.of(tendons[rod][term])
                        for term in tendons[rod]["terms"]}
        for term, term_opts in term_options.items():
            kinds[term].check_scene(term_opts, tendons[rod], f"{prefix}.{term}")
        check_tendon(rod, tendons[rod], rods, prefix, tendons_raw.keys(), term_options)
    return tendons


def _resolve_rod_parts(rod: str, table: dict[str, Any], pulled: bool) -> None:
    """Resolve rod ``rod``'s ``base``, ``supports`` and ``damping`` sub-tables in place
    (``pulled``: a tendon is pulled along the rod); a table without them is left as it
    is."""
    base = resolve_base(rod, table, pulled)
    if base is not None:
        table["base"] = base
    if "supports" in table:
        table["supports"] = resolve_supports(rod, table, pulled)
    damping = resolve_damping(rod, table)
    if damping is not None:  # only then: a scene without damping resolves as before
        table["damping"] = damping


def _check_rod(rod: str, table: Mapping[str, Any], pulled: bool) -> str | None:
    """The rules of one resolved rod table: at least one term, a radius below the length,
    each rod-scope term's own check, exactly one way of holding the base (a ``free``
    rod needs a term that holds it, an ``orientation`` clamp a tendon pulled at the base).
    Returns the key of the rod's term that joins it to another rod (the last listed, if
    several do), or None."""
    from rodsim.core.terms import registered_terms, term_class, term_keys

    options = RodOptions.of(table)
    if not options.terms:
        raise SceneError(f"rods.{rod}.terms = []: a rod needs at least one term; allowed: "
                         "a list of distinct names from: " + ", ".join(term_keys("rod")))
    if options.radius >= options.length:
        raise SceneError(f"rods.{rod}.radius = {options.radius!r}: not below the length "
                         f"{options.length!r} m; allowed: radius < length (a slender rod)",
                         key=f"rods.{rod}.radius", value=options.radius,
                         allowed="radius < length (a slender rod)",
                         reason="cross-table rule", related=(f"rods.{rod}.length",))
    for term_name in options.terms:
        kind = term_class(term_name, table)
        if kind.scope == "rod":
            kind.check_scene(kind.Options.of(table[term_name]), options,
                             f"rods.{rod}.{term_name}")
    holders = [name for name in options.terms if term_class(name, table).holds_base]
    joining = [name for name in options.terms if term_class(name, table).joins_rods]
    if len(holders) > 1:
        raise SceneError(f"rods.{rod}.terms: {' and '.join(holders)} would both hold the "
                         "base; allowed: one of them")
    holder_terms = [kind.key for kind in registered_terms().values() if kind.holds_base]
    support_kind(options.clamp).check_base(rod, holders, pulled,  # 'free' needs a holder
                                           holder_terms)
    return joining[-1] if joining else None


def _resolve_solver(solver_raw: Any) -> dict[str, Any]:
    """The ``[solver]`` table validated: its generic parameters, and each
    ``[solver.<integrator>]`` options table kept as a dict (checked by the integrator)."""
    if not isinstance(solver_raw, Mapping):
        raise SceneError(f"solver: expected a table, got {type(solver_raw).__name__}")
    generic = {p.name for p in SOLVER_PARAMETERS}
    option_tables = tuple(key for key in solver_raw if key not in generic)
    solver = validate_table(solver_raw, SOLVER_PARAMETERS, "solver", allow_extra=option_tables)
    for integrator_name in option_tables:
        if not isinstance(solver[integrator_name], Mapping):
            raise SceneError(f"solver.{shown(integrator_name, bare=True)}: unknown key; known "
                             "keys: " + ", ".join(sorted(generic)) + ", or a table "
                             "[solver.<integrator>] of one integrator's options")
        solver[integrator_name] = dict(solver[integrator_name])
    return solver


def _resolve_with_terms(table: Any, parameters: tuple[Parameter, ...], term_names: list[str],
                        prefix: str, extra_tables: tuple[str, ...] = ()) -> dict[str, Any]:
    """Validate a table that lists terms (a rod or a tendon) and its per-term sub-tables
    (``extra_tables``: other sub-tables it may hold, validated by the caller), each against
    the parameters of the term class its key selects in the validated table."""
    from rodsim.core.terms import term_class

    declared = tuple(
        p if p.name != "terms" else Parameter(p.name, p.kind, p.default, p.unit, p.doc,
                                              choices=tuple(term_names))
        for p in parameters)
    resolved = validate_table(table, declared, prefix,
                              allow_extra=tuple(term_names) + extra_tables)
    for term_name in term_names:
        if term_name in resolved and term_name not in resolved["terms"]:
            raise SceneError(f"{prefix}.{term_name}: parameters given for a term that "
                             f"{prefix}.terms does not list")
    for term_name in resolved["terms"]:
        resolved[term_name] = validate_table(resolved.get(term_name, {}),
                                             term_class(term_name, resolved).parameters,
                                             f"{prefix}.{term_name}")
    return resolved


def _files_beside(raw: Any, folder: Path) -> None:
    """Make an obstacle's relative ``file`` (a vessel's csv centerline) relative to the scene
    file's folder when it exists there."""
    obstacles = raw.get("obstacles") if isinstance(raw, Mapping) else None
    if not isinstance(obstacles, Mapping):
        return
    for table in obstacles.values():
        file = table.get("file") if isinstance(table, dict) else None
        if isinstance(file, str) and file and "\0" not in file and not Path(file).is_absolute():
            beside = folder / file
            if beside.is_file():
                table["file"] = str(beside)
