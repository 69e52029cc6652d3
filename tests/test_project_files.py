"""The files a user of the Python ecosystem looks for: the licence pyproject.toml declares,
a citation file naming the paper, the typing marker shipped with the package, a changelog."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def test_the_licence_file_is_the_one_pyproject_declares():
    assert PYPROJECT["project"]["license"] == {"text": "MIT"}
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License")
    assert "Permission is hereby granted, free of charge" in text


def test_citation_file_cites_the_paper_and_rodsim_at_its_version():
    text = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    assert re.search(r"^cff-version: 1\.2\.0$", text, re.MULTILINE)
    assert re.search(rf"^version: {re.escape(PYPROJECT['project']['version'])}$", text,
                     re.MULTILINE), "CITATION.cff's version differs from pyproject.toml's"
    assert "preferred-citation:" in text
    assert "Cosserat Rods for Modeling Tendon-Driven Robotic Catheter Systems" in text
    for author in ("Villard", "Waite", "Howe"):
        assert f"family-names: {author}" in text


def test_the_package_ships_its_typing_marker():
    """PEP 561: type checkers use rodsim's hints only if rodsim/py.typed is installed."""
    assert (ROOT / "rodsim" / "py.typed").is_file()
    assert "py.typed" in PYPROJECT["tool"]["setuptools"]["package-data"]["rodsim"]


def test_the_changelog_names_the_current_round():
    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert text.startswith("# Changelog")
    assert len(re.findall(r"^## ", text, re.MULTILINE)) >= 4
