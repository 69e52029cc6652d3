"""The package's layers import one way (docs/architecture.md): version → core → solvers → io
→ app, and no module imports itself back through a chain of others.

Every ``import`` and ``from … import`` is read from the source with :mod:`ast`, including
imports inside functions (a deferred import is still a dependency); imports under
``if TYPE_CHECKING:`` are annotations only and are left out.
"""

from __future__ import annotations

import ast
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


def imported_modules(module: str, path: Path) -> set[str]:
    """The rodsim modules ``module`` imports (``from a import b`` counts as ``a.b`` when that
    is a module, else ``a``)."""
    tree = ast.parse(path.read_text(), str(path))
    skip: set[int] = set()
    for node in ast.walk(tree):
        if _type_checking_block(node):
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


GRAPH = {module: imported_modules(module, path) for module, path in MODULES.items()}


def test_the_layer_map_covers_every_module():
    assert "rodsim.core.model" in MODULES and "rodsim.solvers.base" in MODULES
    for module in MODULES:
        rank(module)  # raises ValueError (max of nothing) for a module outside every layer


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_module_imports_a_higher_layer(module):
    upward = sorted(target for target in GRAPH[module] if rank(target) > rank(module))
    assert not upward, f"{module} (layer {rank(module)}) imports higher layers: {upward}"


def test_no_import_cycles():
    """Depth-first search for a back edge among the package's modules."""
    state: dict[str, int] = {}  # 1 on the current path, 2 finished
    path: list[str] = []
    cycles: list[list[str]] = []

    def visit(module: str) -> None:
        state[module] = 1
        path.append(module)
        for target in sorted(GRAPH.get(module, ())):
            if state.get(target) == 1:
                cycles.append(path[path.index(target):] + [target])
            elif target not in state:
                visit(target)
        path.pop()
        state[module] = 2

    for module in sorted(GRAPH):
        if module not in state:
            visit(module)
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


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
    siblings = sorted(GRAPH[module] & (integrator_modules() - {module}))
    assert not siblings, f"{module} imports integrator modules {siblings}: move what it " \
        "needs into a shared part"
