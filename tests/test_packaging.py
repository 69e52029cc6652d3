"""Every subpackage of rodsim is installed: pyproject.toml lists packages explicitly, and the
test suite imports from the source tree, so a folder missing from the list passes every
other test while ``pip install .`` ships without it (rodsim.app.inverse once did)."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_every_subpackage_is_listed_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])
    found = {"rodsim"} | {
        "rodsim." + path.parent.relative_to(ROOT / "rodsim").as_posix().replace("/", ".")
        for path in (ROOT / "rodsim").rglob("__init__.py") if path.parent != ROOT / "rodsim"}
    assert found <= listed, f"not installed by pip: {sorted(found - listed)}"


def test_the_benchmarks_are_not_part_of_the_library():
    """benchmarks/rodsim_bench imports rodsim, never the reverse; pip does not install it
    (`rodsim bench` loads it from the checkout: rodsim/app/bench_locator.py)."""
    import ast

    listed = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "packages"]
    assert not [p for p in listed if "bench" in p], listed
    assert not (ROOT / "rodsim" / "bench").exists()
    assert (ROOT / "benchmarks" / "rodsim_bench" / "__init__.py").is_file()
    for path in (ROOT / "rodsim").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            assert not any(n.split(".")[0] in ("rodsim_bench", "benchmarks") for n in names), (
                f"{path.relative_to(ROOT)} imports the benchmarks")
