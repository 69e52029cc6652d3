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
