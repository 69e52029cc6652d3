"""Types a checker can see (issue 21 item 3): the options of the scene's tables and the terms
are hand-declared dataclasses checked here against their ``Parameter`` declarations, so the
two cannot drift; an integrator's options are declared once, on its dataclass's fields, and
its parameters made from them; mypy runs clean on the whole package (pyproject.toml's
``[tool.mypy]``; issue 38 item 5)."""

from __future__ import annotations

import ast
import dataclasses
import inspect
from dataclasses import dataclass, field

import pytest

from rodsim.core.rod.rod import ROD_PARAMETERS, RodOptions
from rodsim.core.scene import SOLVER_PARAMETERS, SolverSettings
from rodsim.core.schema import (
    Options,
    Parameter,
    declared_parameters,
    option,
    options_mismatch,
    shared_option,
)
from rodsim.core.supports import (
    BASE_PARAMETERS,
    SUPPORT_PARAMETERS,
    BaseOptions,
    SupportOptions,
)
from rodsim.core.tendon import TENDON_PARAMETERS, TendonOptions
from rodsim.core.terms import registered_terms
from rodsim.core.terms.base import RodTerm
from rodsim.solvers import registered_integrators

TABLES = [(SolverSettings, SOLVER_PARAMETERS), (RodOptions, ROD_PARAMETERS),
          (TendonOptions, TENDON_PARAMETERS), (BaseOptions, BASE_PARAMETERS),
          (SupportOptions, SUPPORT_PARAMETERS)]


@pytest.mark.parametrize(("cls", "parameters"), TABLES, ids=lambda x: getattr(x, "__name__", ""))
def test_each_declared_table_type_matches_its_parameters(cls, parameters):
    assert issubclass(cls, Options)
    assert options_mismatch(cls, parameters) == []


@pytest.mark.parametrize("name", sorted(registered_terms()))
def test_each_term_declares_options_that_match_its_parameters(name):
    """Every registered term declares its Options class (visible to a type checker) and it
    agrees with the term's ``parameters``; a variant of another term's scene key
    (lumen_conserving, tendon_string_displacement) shares that term's."""
    term = registered_terms()[name]
    assert term.Options.__module__ == term.__module__ or term.key != term.name, (
        f"term {name!r}: declare its Options beside the class")
    assert options_mismatch(term.Options, term.parameters) == []


@pytest.mark.parametrize("name", sorted(registered_integrators()))
def test_each_integrator_has_declared_options_that_match_its_parameters(name):
    """Every registered integrator declares its options class beside it, in its own file
    (``Options = ...`` in the class; not the class made from its parameters when none is
    declared), and it agrees with the integrator's ``parameters``."""
    cls = registered_integrators()[name]
    assert "Options" in cls.__dict__, f"integrator {name!r}: declare its Options in the class"
    assert cls.Options.__module__ == cls.__module__, (
        f"integrator {name!r}: declare its Options beside the class")
    assert options_mismatch(cls.Options, cls.parameters) == []


@pytest.mark.parametrize("name", sorted(registered_integrators()))
def test_each_integrator_option_is_written_once(name):
    """An integrator's options are declared once, on its ``Options`` fields
    (``rodsim.core.schema.option``): its ``parameters`` (scene validation, ``--help``,
    docs/scenes.md) are made from them, never written beside them."""
    cls = registered_integrators()[name]
    tree = ast.parse(inspect.getsource(cls))
    written = [node for node in ast.walk(tree) if isinstance(node, ast.Assign | ast.AnnAssign)
               and any(isinstance(t, ast.Name) and t.id == "parameters"
                       for t in (node.targets if isinstance(node, ast.Assign) else [node.target]))]
    assert not written, (
        f"integrator {name!r}: declare each option once, by its Options field (option(...))")
    assert cls.parameters == declared_parameters(cls.Options)


def test_options_declared_on_fields_make_their_parameters():
    """``option`` puts a parameter's declaration on a field; ``declared_parameters`` reads
    name and kind from the field, a required field has no default, a list default is a
    fresh list per instance, a subclass changes a default with a plain value, another class
    shares a field with ``shared_option``; an undeclared field is named."""

    @dataclass(frozen=True, kw_only=True)
    class Base(Options):
        h: float = option(0.3, "s", "time step", 0.0, 1e3, exclusive_minimum=True)
        steps: int = option(None, "-", "steps", 1, 10)
        origin: list[float] = option([0.0, 0.0, 0.0], "m", "origin", length=3)
        method: str = option("a", "-", "method", choices=("a", "b"))

    expected = (Parameter("h", "float", 0.3, "s", "time step", 0.0, 1e3,
                          exclusive_minimum=True),
                Parameter("steps", "int", None, "-", "steps", 1, 10),
                Parameter("origin", "vector", [0.0, 0.0, 0.0], "m", "origin", length=3),
                Parameter("method", "str", "a", "-", "method", choices=("a", "b")))
    assert declared_parameters(Base) == expected
    assert options_mismatch(Base, expected) == []
    one, two = Base(steps=2), Base(steps=3)
    assert one.origin == [0.0, 0.0, 0.0] and one.origin is not two.origin

    @dataclass(frozen=True, kw_only=True)
    class Longer(Base):
        h: float = 0.1

    assert declared_parameters(Longer)[0] == dataclasses.replace(expected[0], default=0.1)

    @dataclass(frozen=True, kw_only=True)
    class Sharing(Options):
        method: str = shared_option(Base, "method")

    assert declared_parameters(Sharing) == (expected[3],)

    @dataclass(frozen=True, kw_only=True)
    class Undeclared(Options):
        h: float = 0.3

    with pytest.raises(TypeError, match=r"Undeclared\.h: declare the option with"):
        declared_parameters(Undeclared)


def test_a_drifted_declaration_is_named():
    """The check reports each kind of drift: a renamed or missing field, a wrong annotation,
    a wrong or missing default, a positional field."""
    parameters = (Parameter("h", "float", 0.3), Parameter("steps", "int", None),
                  Parameter("origin", "vector", [0.0, 0.0, 0.0], length=3))

    @dataclass(frozen=True, kw_only=True)
    class Agrees(Options):
        h: float = 0.3
        steps: int
        origin: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])

    assert options_mismatch(Agrees, parameters) == []

    @dataclass(frozen=True, kw_only=True)
    class Drifted(Options):
        h: int = 3
        steps: int = 5
        origin: list[str] = field(default_factory=list)

    problems = options_mismatch(Drifted, parameters)
    assert len(problems) == 5, problems
    assert any("h: annotated" in p for p in problems)
    assert any("h: default 3 != 0.3" in p for p in problems)
    assert any("steps: default 5 != None" in p for p in problems)

    @dataclass(frozen=True)
    class Positional(Options):
        h: float = 0.3
        steps: int = 0

    problems = options_mismatch(Positional, parameters)
    assert any("fields ['h', 'steps'] != parameters ['h', 'steps', 'origin']" in p
               for p in problems)
    assert any("h: not keyword-only" in p for p in problems)


def test_a_term_declaring_options_that_drift_is_refused_when_defined():
    with pytest.raises(TypeError, match=r"its Options does not match its parameters: "
                                        r"K: annotated <class 'int'>"):
        class Unregistered(RodTerm):  # no ``name``: never registered
            parameters = (Parameter("K", "float", 1.0),)

            @dataclass(frozen=True, kw_only=True)
            class Options(Options):
                K: int = 1

            def element_forces(self, x):
                return x


def test_declared_options_are_what_the_scene_hands_out():
    import rodsim

    scene = rodsim.load_scene("tdcr-two-segment")
    assert type(scene.solver) is SolverSettings
    assert all(type(options) is RodOptions for options in scene.rods.values())
    assert all(type(options) is TendonOptions for options in scene.tendons.values())
    assert dataclasses.asdict(scene.solver)["integrator"] == scene.data["solver"]["integrator"]


@pytest.mark.slow
def test_mypy_runs_clean_on_the_whole_package():
    """``python -m mypy`` with pyproject.toml's ``[tool.mypy]``, whose ``files`` is the whole
    package ``rodsim``. Measured (180 files): 22 s of CPU with an empty cache (a fresh
    clone), under 1 s with mypy's cache (.mypy_cache) warm."""
    import subprocess
    import sys
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    config = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))
    assert config["tool"]["mypy"]["files"] == ["rodsim"]
    assert any(item.startswith("mypy")
               for item in config["project"]["optional-dependencies"]["test"])
    run = subprocess.run([sys.executable, "-m", "mypy"], cwd=root, capture_output=True,
                         text=True, timeout=600, check=False)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert "Success: no issues found" in run.stdout
