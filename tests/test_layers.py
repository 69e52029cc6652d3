"""The package's layers import one way (docs/architecture.md): version → core → solvers → io
→ app, and no module imports itself back through a chain of others.

Every ``import`` and ``from … import`` is read from the source with :mod:`ast`, including
imports inside functions (a deferred import is still a dependency). Imports under
``if TYPE_CHECKING:`` are annotations only: the layer check leaves them out, the cycle check
counts them (two modules that need each other's types are one concept in two files, or
share a type that belongs in a third), and the packages an import runs first (importing
``a.b.c`` runs ``a/__init__`` and ``a/b/__init__``).
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "rodsim"

#: Layer rank by module prefix (the longest matching prefix wins). A module may import
#: modules of its own rank or below.
LAYERS = {
    "rodsim.version": 0,
    "rodsim.data": 0,
    "rodsim.core": 1,
    "rodsim.solvers": 2,
    "rodsim.io": 3,
    "rodsim.app": 4,
    "rodsim.studies": 4,
    "rodsim": 5,  # the package root and ``python -m rodsim``: the assembly point
}


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def source_files() -> dict[str, Path]:
    """Every module of the package (the studies folder is the package rodsim.studies)."""
    files = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        files[module_name(path)] = path
    return files


MODULES = source_files()


def rank(module: str) -> int:
    best = max((prefix for prefix in LAYERS
                if module == prefix or module.startswith(prefix + ".")), key=len)
    return LAYERS[best]


def _type_checking_block(node: ast.AST) -> bool:
    return (isinstance(node, ast.If) and isinstance(node.test, ast.Name)
            and node.test.id == "TYPE_CHECKING")


def imported_modules(module: str, path: Path, type_only: bool = False) -> set[str]:
    """The rodsim modules ``module`` imports (``from a import b`` counts as ``a.b`` when that
    is a module, else ``a``); with ``type_only`` also those imported under
    ``if TYPE_CHECKING:``."""
    tree = ast.parse(path.read_text(), str(path))
    skip: set[int] = set()
    for node in ast.walk(tree):
        if _type_checking_block(node) and not type_only:
            skip.update(id(child) for child in ast.walk(node))
    found: set[str] = set()
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names if alias.name.startswith("rodsim"))
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            if not base.startswith("rodsim"):
                continue
            for alias in node.names:
                candidate = f"{base}.{alias.name}"
                found.add(candidate if candidate in MODULES else base)
    found.discard(module)
    return found


@functools.cache
def graph() -> dict[str, set[str]]:
    """The rodsim modules each module imports at run time (read once per process, by the
    first test that needs it: not at collection, which every worker does)."""
    return {module: imported_modules(module, path) for module, path in MODULES.items()}


@functools.cache
def typed_graph() -> dict[str, set[str]]:
    """:func:`graph` with the type-only imports."""
    return {module: imported_modules(module, path, type_only=True)
            for module, path in MODULES.items()}


def test_the_layer_map_covers_every_module():
    assert "rodsim.core.model" in MODULES and "rodsim.solvers.base" in MODULES
    for module in MODULES:
        rank(module)  # raises ValueError (max of nothing) for a module outside every layer


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_module_imports_a_higher_layer(module):
    upward = sorted(target for target in graph()[module] if rank(target) > rank(module))
    assert not upward, f"{module} (layer {rank(module)}) imports higher layers: {upward}"


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The cycles a depth-first search finds among ``graph``'s modules (one per back edge;
    none when there is no cycle)."""
    state: dict[str, int] = {}  # 1 on the current path, 2 finished
    path: list[str] = []
    cycles: list[list[str]] = []

    def visit(module: str) -> None:
        state[module] = 1
        path.append(module)
        for target in sorted(graph.get(module, ())):
            if state.get(target) == 1:
                cycles.append(path[path.index(target):] + [target])
            elif target not in state:
                visit(target)
        path.pop()
        state[module] = 2

    for module in sorted(graph):
        if module not in state:
            visit(module)
    return cycles


def with_packages(graph: dict[str, set[str]], modules=None) -> dict[str, set[str]]:
    """``graph`` with the imports Python makes first: importing ``a.b.c`` runs the packages
    ``a`` and ``a.b`` (their ``__init__``), so a module depends on every package above what
    it imports, but not on its own packages (which are run before it, and are no cycle
    with it)."""
    modules = MODULES if modules is None else modules
    out = {}
    for module, targets in graph.items():
        found = set(targets)
        for target in targets:
            parts = target.split(".")
            for i in range(1, len(parts)):
                package = ".".join(parts[:i])
                if package in modules and not module.startswith(package + "."):
                    found.add(package)
        found.discard(module)
        out[module] = found
    return out


def test_no_import_cycles_type_only_imports_included():
    """No cycle among the package's modules: type-only imports counted, and the packages
    each import runs first (``with_packages``)."""
    cycles = import_cycles(with_packages(typed_graph()))
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_the_checker_sees_a_cycle_through_a_package():
    """A package's ``__init__`` that imports a module which imports a sibling package's
    module back: no module imports the package by name, yet the import runs it."""
    graph = {"rodsim.app": {"rodsim.io.x"}, "rodsim.io": set(), "rodsim.io.x": {"rodsim.app.y"},
             "rodsim.app.y": set()}
    modules = set(graph)
    assert import_cycles(graph) == []
    assert import_cycles(with_packages(graph, modules)) == [
        ["rodsim.app", "rodsim.io.x", "rodsim.app"]]


def test_the_checker_sees_a_type_only_cycle(tmp_path):
    """Two modules that import each other, one of them only under ``if TYPE_CHECKING:``,
    are a cycle; the runtime imports alone are not."""
    folder = tmp_path / "rodsim" / "app"
    folder.mkdir(parents=True)
    (folder / "a.py").write_text("from rodsim.app.b import helper\n")
    (folder / "b.py").write_text("from typing import TYPE_CHECKING\n\nif TYPE_CHECKING:\n"
                                 "    from rodsim.app.a import Thing\n\n"
                                 "def helper(x: 'Thing') -> None:\n    pass\n")
    runtime = {m: imported_modules(m, folder / f"{m[-1]}.py") for m in ("rodsim.app.a",
                                                                         "rodsim.app.b")}
    typed = {m: imported_modules(m, folder / f"{m[-1]}.py", type_only=True)
             for m in ("rodsim.app.a", "rodsim.app.b")}
    assert runtime == {"rodsim.app.a": {"rodsim.app.b"}, "rodsim.app.b": set()}
    assert import_cycles(runtime) == []
    assert import_cycles(typed) == [["rodsim.app.a", "rodsim.app.b", "rodsim.app.a"]]


def test_the_checker_sees_an_upward_import(tmp_path):
    """The checker itself: a core module importing the app layer is reported."""
    fake = tmp_path / "rodsim" / "core" / "fake.py"
    fake.parent.mkdir(parents=True)
    fake.write_text("def f():\n    from rodsim.app.api import solve\n    return solve\n")
    tree_imports = imported_modules("rodsim.core.fake", fake)
    assert tree_imports == {"rodsim.app.api"}
    assert rank("rodsim.app.api") > rank("rodsim.core.fake")


def integrator_modules() -> set[str]:
    """The modules of rodsim.solvers that define a registered integrator."""
    from rodsim.solvers import registered_integrators

    return {cls.__module__ for cls in registered_integrators().values()}


SOLVER_MODULES = sorted(m for m in MODULES if m.startswith("rodsim.solvers."))


def test_the_integrator_modules_are_known():
    assert integrator_modules() >= {"rodsim.solvers.static", "rodsim.solvers.cvode",
                                    "rodsim.solvers.ida", "rodsim.solvers.paper_euler",
                                    "rodsim.solvers.scipy_ivp"}


@pytest.mark.parametrize("module", SOLVER_MODULES)
def test_no_solver_module_imports_an_integrator_module(module):
    """Integrators share parts (the template, the run state, Newton, the linear solves,
    pseudo-dynamics, penalties, tolerances, the SUNDIALS loop), never each other: no module
    of rodsim.solvers imports a module defining an integrator other than itself (issue 21;
    deferred imports count)."""
    siblings = sorted(graph()[module] & (integrator_modules() - {module}))
    assert not siblings, f"{module} imports integrator modules {siblings}: move what it " \
        "needs into a shared part"
