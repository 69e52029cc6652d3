"""The API reference (mkdocs.yml, docs/api/) builds from the docstrings with no warning:
a renamed function, a moved module or a docstring the parser cannot read fails here. The
tools come with the test extra (pip install ".[test]"); elsewhere the test skips."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def test_the_api_reference_builds_strictly(tmp_path):
    pytest.importorskip("mkdocs", reason="mkdocs is in the test extra: pip install '.[test]'")
    pytest.importorskip("mkdocstrings_handlers.python",
                        reason="mkdocstrings[python] is in the test extra")
    site = tmp_path / "site"
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f",
                          str(ROOT / "mkdocs.yml"), "-d", str(site)], capture_output=True,
                         text=True, timeout=300, check=False)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    page = (site / "inverse" / "index.html").read_text(encoding="utf-8")
    # The docstring text itself is in the page, not only the headings.
    assert "Values of the scene keys" in page and "rodsim.app.inverse.reach.reach" in page
