"""Declarative parameter schemas: one ``Parameter`` per scene value.

Scene tables (rods, terms, couplings, integrators) each declare their parameters once, with
unit, default and allowed range; validation, ``--help`` texts and the docs all read the same
declaration. Every violation raises ``SceneError`` with a one-line message naming the
full key and what is allowed.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import numbers
import typing
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Self

__all__ = ["Parameter", "SceneError", "validate_table", "shown", "shown_path", "options_type",
           "is_integer",
           "register_with_options", "Options", "options_mismatch", "KIND_HINTS", "option",
           "shared_option", "declared_parameters", "OPTION_METADATA"]

#: Longest echo of a user's value in a message (longer ones are cut with "…").
SHOWN_WIDTH = 60


class SceneError(ValueError):
    """A scene value is missing, unknown, of the wrong type or outside its allowed range.

    ``str(error)`` is a one-line message in the library's terms (dotted scene keys, Python
    values). The fields let a front end word the error its own way (the CLI names its
    ``--set`` flag, for instance) without parsing the message; each is ``None`` when it
    does not apply.

    Attributes
    ----------
    key
        The dotted scene key concerned (as given by the user when it could not be resolved).
    value
        The offending value.
    allowed
        What is allowed instead: a description (``"an integer >= 3"``) or the tuple of
        valid names (keys, choices, shipped scenes).
    reason
        A short phrase for what is wrong (``"unknown key"``, ``"out of range"``, …).
    assignment
        The ``key=value`` text of ``rodsim.core.scene.Scene.with_overrides`` whose key or
        value could not be read, or that made another value invalid (``None`` for errors in
        the values themselves).
    related
        The other dotted keys a cross-table rule compares ``key`` with (radius against length,
        a tendon's length against its catheter's, a lumen offset against the radii): when only
        one of them was set, ``rodsim.core.scene.Scene.with_overrides`` names that one.
    """

    def __init__(self, message: str, *, key: str | None = None, value: Any = None,
                 allowed: str | tuple[str, ...] | None = None, reason: str | None = None,
                 assignment: str | None = None, related: tuple[str, ...] = ()) -> None:
        super().__init__(message)
        self.key = key
        self.value = value
        self.allowed = allowed
        self.reason = reason
        self.assignment = assignment
        self.related = related


def shown(value: Any, width: int = SHOWN_WIDTH, bare: bool = False) -> str:
    """``repr(value)`` for a one-line message, cut to ``width`` characters; with ``bare``, a
    printable string is shown as it is (a key in a dotted path), others escaped."""
    try:
        if bare and isinstance(value, str):
            text = value if value.isprintable() else repr(value)[1:-1]
        else:
            text = repr(value)
    except RecursionError:
        text = f"<deeply nested {type(value).__name__}>"
    return text if len(text) <= width else text[:width - 1] + "…"


#: Widest path echoed in a message [characters]: a longer one is cut (a 300-character
#: path was echoed whole).
PATH_WIDTH = 160


def shown_path(path: Any) -> str:
    """A file path for a one-line message: ``shown`` of its text, cut to
    ``PATH_WIDTH`` characters."""
    return shown(str(path), PATH_WIDTH)


_KIND_NAMES = {
    "float": "a number",
    "int": "an integer",
    "str": "a string",
    "bool": "true or false",
    "vector": "a list of numbers",
    "list": "a list of strings",
    "tables": "a list of tables",
}


@dataclass(frozen=True)
class Parameter:
    """One scene value.

    Parameters
    ----------
    name
        Key in its TOML table.
    kind
        ``float``, ``int``, ``str``, ``bool``, ``vector`` (list of floats), ``list`` (of str)
        or ``tables`` (a list of tables, TOML ``[[...]]``, each checked against ``items``).
    default
        Value used when the scene omits the key; ``None`` makes the key required.
    unit
        SI unit, shown in errors and help (``"-"`` for dimensionless).
    doc
        One-line description.
    minimum, maximum
        Allowed range (numbers); ``exclusive_minimum`` makes the lower bound strict.
    choices
        Allowed values for ``str`` parameters (or for the items of a ``list``): a tuple,
        or a sequence that reads a registry when asked (``rodsim.core.supports.CLAMPS``).
    length
        Required length of a ``vector``.
    items
        The parameters of each table of a ``tables`` value.
    """

    name: str
    kind: str
    default: Any
    unit: str = "-"
    doc: str = ""
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False
    choices: Sequence[str] | None = None
    length: int | None = None
    items: tuple[Parameter, ...] | None = None

    @property
    def allowed(self) -> str:
        """Human-readable description of the allowed values."""
        if self.choices is not None:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        parts = [_KIND_NAMES[self.kind]]
        if self.length is not None:
            parts.append(f"of length {self.length}")
        if self.kind == "vector" and (self.minimum is not None or self.maximum is not None):
            parts.append("with each component")
        low = None
        if self.minimum is not None:
            low = f"{'>' if self.exclusive_minimum else '>='} {self.minimum:g}"
        high = f"<= {self.maximum:g}" if self.maximum is not None else None
        bounds = " and ".join(b for b in (low, high) if b)
        if bounds:
            parts.append(bounds)
        if self.unit not in ("-", ""):
            parts.append(f"[{self.unit}]")
        return " ".join(parts)

    def help(self) -> str:
        """``name = default [unit]: doc`` for CLI help and docs."""
        unit = f" [{self.unit}]" if self.unit not in ("-", "") else ""
        default = "required" if self.default is None else repr(self.default)
        return f"{self.name} = {default}{unit}: {self.doc}"

    def check(self, value: Any, key: str) -> Any:
        """Return ``value`` converted to this parameter's kind, or raise ``SceneError``."""

        def fail(reason: str) -> SceneError:
            return SceneError(f"{key} = {shown(value)}: {reason}; allowed: {self.allowed}",
                              key=key, value=value, allowed=self.allowed, reason=reason)

        if self.kind in ("bool", "str", "list"):
            return self._check_names(value, fail)
        if self.kind == "tables":
            if not isinstance(value, (list, tuple)):
                raise fail("wrong type")
            return [validate_table(item, self.items or (), f"{key}.{i}")
                    for i, item in enumerate(value)]
        if self.kind == "vector":
            return self._check_vector(value, fail)
        return self._check_number(value, fail)

    def _check_names(self, value: Any, fail: Callable[[str], SceneError]) -> Any:
        """A ``bool``, a ``str`` (one of ``choices``, if declared) or a ``list`` of distinct
        strings (each one of ``choices``, if declared)."""
        if self.kind == "bool":
            if not isinstance(value, bool):
                raise fail("wrong type")
            return value
        if self.kind == "str":
            if not isinstance(value, str):
                raise fail("wrong type")
            if self.choices is not None and value not in self.choices:
                raise fail("unknown choice")
            return value
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise fail("wrong type")
        if self.choices is not None:
            for item in value:
                if item not in self.choices:
                    raise fail(f"unknown item {item!r}")
        if len(set(value)) != len(value):
            raise fail("repeated item")
        return list(value)

    def _check_vector(self, value: Any, fail: Callable[[str], SceneError]) -> list[float]:
        """A list of ``length`` finite numbers, each within the range, as floats."""
        if not isinstance(value, (list, tuple)) or not all(_is_number(v) for v in value):
            raise fail("wrong type")
        if self.length is not None and len(value) != self.length:
            raise fail(f"needs {self.length} values")
        if not all(math.isfinite(v) for v in value):
            raise fail("not finite")
        if not all(self._in_range(v) for v in value):
            raise fail("component out of range")
        return [float(v) for v in value]

    def _check_number(self, value: Any, fail: Callable[[str], SceneError]) -> int | float:
        """An ``int`` (a whole float too) or a finite ``float``, within the range."""
        number: int | float
        if self.kind == "int":
            if is_integer(value):  # numpy's integers too (a count from np.arange, …)
                number = int(value)
            elif isinstance(value, float) and value.is_integer():
                number = int(value)
            else:
                raise fail("wrong type")
        elif self.kind == "float":
            if not _is_number(value):
                raise fail("wrong type")
            number = float(value)
            if not math.isfinite(number):
                raise fail("not finite")
        else:  # pragma: no cover - programming error in a declaration
            raise ValueError(f"unknown parameter kind {self.kind!r}")
        if not self._in_range(number):
            raise fail("out of range")
        return number

    def _in_range(self, value: float) -> bool:
        if self.minimum is not None and (
                value < self.minimum or (self.exclusive_minimum and value == self.minimum)):
            return False
        return self.maximum is None or value <= self.maximum


def _is_number(value: Any) -> bool:
    """A real number, numpy's included (np.float32, np.int64: numpy registers them with
    ``numbers``); not a bool (numpy's bool is no number)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def is_integer(value: Any) -> bool:
    """A whole number of an integer type, numpy's included (np.int64); not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def validate_table(
    table: Mapping[str, Any],
    parameters: Iterable[Parameter],
    prefix: str,
    allow_extra: Sequence[str] = (),
) -> dict[str, Any]:
    """Check ``table`` against ``parameters`` and fill defaults.

    Unknown keys (not in ``parameters`` nor ``allow_extra``) are errors; the message lists the
    known keys. Returns a new dict with every declared parameter present.
    """
    if not isinstance(table, Mapping):
        raise SceneError(f"{prefix}: expected a table, got {type(table).__name__}",
                         key=prefix, value=table, allowed="a table", reason="not a table")
    params = {p.name: p for p in parameters}
    out: dict[str, Any] = {}
    for key in table:
        if key not in params and key not in allow_extra:
            known = tuple(sorted([*params, *allow_extra]))
            # friction on a rod tendon (docs/tendon.md, "Friction": only the string has it)
            hint = ("; friction is a key of tendons.<name>.tendon_string only (coupling = "
                    "\"string\"): the rod tendons are frictionless"
                    if key == "friction" and prefix.startswith("tendons.") else "")
            raise SceneError(f"{prefix}.{shown(key, bare=True)}: unknown key; known keys: "
                             f"{', '.join(known)}{hint}", key=f"{prefix}.{key}",
                             allowed=known, reason="unknown key")
    for name, param in params.items():
        key = f"{prefix}.{name}"
        if name in table:
            out[name] = param.check(table[name], key)
        elif param.default is None:
            raise SceneError(f"{key}: required value missing; allowed: {param.allowed}",
                             key=key, allowed=param.allowed, reason="required value missing")
        else:
            out[name] = param.default
    for name in allow_extra:
        if name in table:
            out[name] = table[name]
    return out


#: The Python type of a value of each parameter kind, after :meth:`Parameter.check`.
KIND_TYPES: dict[str, Any] = {"float": float, "int": int, "str": str, "bool": bool,
                              "vector": list, "list": list, "tables": list}


#: The annotation a hand-declared options field has for each parameter kind
#: (:func:`options_mismatch` compares them).
KIND_HINTS: dict[str, Any] = {"float": float, "int": int, "str": str, "bool": bool,
                              "vector": list[float], "list": list[str],
                              "tables": list[dict[str, Any]]}


class Options:
    """Base of the options dataclasses a type checker sees: a scene table's validated values
    as typed attributes. A hand-declared subclass is a frozen, keyword-only dataclass with one
    field per ``Parameter`` of the table, in the declaration's order, annotated with
    ``KIND_HINTS`` of its kind and defaulting to its default (no default: a required
    value); ``options_mismatch`` checks that, and a term or an integrator that declares
    its ``Options`` is checked when the class is defined (``register_with_options``).

    Example::

        @dataclass(frozen=True, kw_only=True)
        class BaseOptions(Options):
            insertion: float = 0.0
            rotation: float = 0.0
    """

    __dataclass_fields__: ClassVar[dict[str, Any]]

    @classmethod
    def of(cls, table: Mapping[str, Any]) -> Self:
        """The typed view of a validated table (``validate_table``'s dict): its declared
        values only; other keys (a rod's per-term sub-tables, the ``[solver.<integrator>]``
        tables) are left out."""
        return cls(**{f.name: table[f.name] for f in dataclasses.fields(cls)})


def options_mismatch(cls: type, parameters: Iterable[Parameter]) -> list[str]:
    """How the options dataclass ``cls`` differs from the ``parameters`` it types (empty:
    they agree): field names and order, annotations (``KIND_HINTS``), defaults (a
    required parameter: no default), frozen and keyword-only."""
    parameters = tuple(parameters)
    if not dataclasses.is_dataclass(cls):
        return [f"{cls.__name__} is not a dataclass"]
    problems = []
    if not cls.__dataclass_params__.frozen:  # type: ignore[attr-defined]
        problems.append("not frozen")
    fields = dataclasses.fields(cls)
    names, declared = [f.name for f in fields], [p.name for p in parameters]
    if names != declared:
        problems.append(f"fields {names} != parameters {declared}")
    hints = typing.get_type_hints(cls)
    for field in fields:
        parameter = next((p for p in parameters if p.name == field.name), None)
        if parameter is None:
            continue
        if hints[field.name] != KIND_HINTS[parameter.kind]:
            problems.append(f"{field.name}: annotated {hints[field.name]!r}, kind "
                            f"{parameter.kind!r} is {KIND_HINTS[parameter.kind]!r}")
        if not field.kw_only:
            problems.append(f"{field.name}: not keyword-only")
        if field.default is not dataclasses.MISSING:
            default = field.default
        elif field.default_factory is not dataclasses.MISSING:
            default = field.default_factory()
        else:
            default = None  # required
        if default != parameter.default or type(default) is not type(parameter.default):
            problems.append(f"{field.name}: default {default!r} != {parameter.default!r}")
    return problems


#: The key of an options field's metadata that holds its parameter's declaration
#: (``option``).
OPTION_METADATA = "rodsim.option"


def option(default: Any = None, unit: str = "-", doc: str = "", minimum: float | None = None,
           maximum: float | None = None, *, exclusive_minimum: bool = False,
           choices: Sequence[str] | None = None, length: int | None = None) -> Any:
    """A field of an options dataclass that declares its option once: its default (None:
    required), unit, one-line doc, range and choices, as ``Parameter`` takes them; the
    field's name and annotation (``KIND_HINTS``) give the parameter's name and kind
    (``declared_parameters`` makes the ``Parameter``). A subclass changes a default by
    declaring the field again with a plain value (``newton_switch: float = 0.03``)."""
    metadata = {OPTION_METADATA: {"unit": unit, "doc": doc, "minimum": minimum,
                                  "maximum": maximum, "exclusive_minimum": exclusive_minimum,
                                  "choices": choices, "length": length}}
    if default is None:
        return dataclasses.field(metadata=metadata)
    if isinstance(default, list):
        return dataclasses.field(default_factory=functools.partial(list, default),
                                 metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def shared_option(cls: type, name: str) -> Any:
    """A field declaring option ``name`` as the options dataclass ``cls`` declares it (its
    default and its ``option`` metadata), for another options class that shares it."""
    declared = _declaration(cls, name)
    field = next(f for f in dataclasses.fields(cls) if f.name == name)
    if field.default_factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=field.default_factory, metadata=declared)
    if field.default is not dataclasses.MISSING:
        return dataclasses.field(default=field.default, metadata=declared)
    return dataclasses.field(metadata=declared)


def _declaration(cls: type, name: str) -> Mapping[str, Any]:
    """The ``option`` metadata of field ``name`` of ``cls`` or, where ``cls`` only changes
    its default, of the nearest base class that declares it (TypeError: none does)."""
    for base in cls.__mro__:
        field = getattr(base, "__dataclass_fields__", {}).get(name)
        if field is not None and OPTION_METADATA in field.metadata:
            return field.metadata
    raise TypeError(f"{cls.__name__}.{name}: declare the option with "
                    "rodsim.core.schema.option(...) (its unit, doc and range)")


def declared_parameters(cls: type) -> tuple[Parameter, ...]:
    """The ``Parameter`` of each field of the options dataclass ``cls``, in field order,
    made from its ``option`` declaration: the name and kind from the field's name and
    annotation, the default from its default (required: none), the rest from its
    metadata. What an integrator's ``parameters`` are (``register_with_options``)."""
    kinds = {repr(hint): kind for kind, hint in KIND_HINTS.items()}
    hints = typing.get_type_hints(cls)
    parameters = []
    for field in dataclasses.fields(cls):
        declared = _declaration(cls, field.name)[OPTION_METADATA]
        if field.default is not dataclasses.MISSING:
            default = field.default
        elif field.default_factory is not dataclasses.MISSING:
            default = field.default_factory()
        else:
            default = None
        kind = kinds.get(repr(hints[field.name]))
        if kind is None:
            raise TypeError(f"{cls.__name__}.{field.name}: annotation {hints[field.name]!r} "
                            f"is no parameter kind's ({', '.join(map(repr, KIND_HINTS.values()))})")
        parameters.append(Parameter(field.name, kind, default, **declared))
    return tuple(parameters)


def _declares_options(cls: type) -> bool:
    """Whether every field of the dataclass ``cls`` carries an ``option`` declaration."""
    try:
        return dataclasses.is_dataclass(cls) and all(
            _declaration(cls, field.name) for field in dataclasses.fields(cls))
    except TypeError:
        return False


def register_with_options(cls: type, registry: dict[str, type], kind: str) -> None:
    """What a term or integrator class does when it is defined: take the ``Options`` class it
    declares (checked against its ``parameters``: TypeError naming each difference; a class
    that declares no ``parameters`` of its own and whose ``Options`` fields are each
    declared by ``option`` gets them from there, ``declared_parameters``: every integrator),
    or get one made by ``options_type``, as ``cls.Options``; and, when it declares its own
    ``name``, enter ``registry`` under it (TypeError if the name is taken). ``kind`` names the
    registry in messages ("term", "integrator")."""
    label = getattr(cls, "name", cls.__name__)
    if ("Options" in cls.__dict__ and "parameters" not in cls.__dict__
            and _declares_options(cls.__dict__["Options"])):
        # The options written once, on the dataclass's fields (``option``).
        cls.parameters = declared_parameters(cls.__dict__["Options"])  # type: ignore[attr-defined]
    parameters = cls.parameters  # type: ignore[attr-defined]
    if "Options" in cls.__dict__:
        problems = options_mismatch(cls.__dict__["Options"], parameters)
        if problems:
            raise TypeError(f"{kind} {label!r}: its Options does not match its parameters: "
                            + "; ".join(problems))
    else:
        cls.Options = options_type(  # type: ignore[attr-defined]
            f"{cls.__name__}Options", parameters,
            f"Options of the {label} {kind} (docs/scenes.md lists them).")
    if "name" in cls.__dict__:
        name = cls.__dict__["name"]
        if name in registry:
            raise TypeError(f"{kind} name {name!r} registered twice")
        registry[name] = cls


def options_type(name: str, parameters: Iterable[Parameter], doc: str = "") -> type[Options]:
    """A frozen dataclass named ``name`` with one typed field per parameter (its default
    where it has one), made at run time for a table without a hand-declared ``Options``
    class (a type checker sees only ``Options``), so that validated options are read
    as attributes, not string keys. Build an instance from ``validate_table``'s dict
    with the class method ``of(table)`` (which ignores keys that are not declared
    parameters)."""
    fields = [(p.name, KIND_TYPES[p.kind],
               dataclasses.field(default_factory=functools.partial(copy.deepcopy, p.default))
               if isinstance(p.default, list) else dataclasses.field(default=p.default))
              for p in parameters]
    cls = dataclasses.make_dataclass(name, fields, bases=(Options,), frozen=True)
    cls.__doc__ = doc or f"Validated options ({', '.join(f[0] for f in fields)})."
    return cls
