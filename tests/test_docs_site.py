"""The documentation site (mkdocs.yml: the user guide in docs/*.md and the API reference in
docs/api/, built from the docstrings by mkdocstrings) builds with ``mkdocs build --strict``:
a broken link between pages, a figure that is not there, a renamed function, a moved module
or a docstring the parser cannot read fails here. Its navigation holds every page of docs/.
The tools come with the test and docs extras (pip install ".[test]" or ".[docs]");
elsewhere the build test skips, saying so."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
#: A Sphinx cross-reference role (``:func:`x```, ``:class:`~a.B```, …): mkdocstrings shows it
#: as raw text, so docstrings write a plain code span (``x``) instead.
ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|data|attr|exc|obj|const|ref):`")


def nav_pages(nav: list) -> list[str]:
    """The Markdown files named in a mkdocs navigation, in order."""
    pages = []
    for entry in nav:
        value = next(iter(entry.values())) if isinstance(entry, dict) else entry
        pages.extend(nav_pages(value) if isinstance(value, list) else [value])
    return pages


def config() -> dict:
    yaml = pytest.importorskip("yaml", reason="PyYAML comes with mkdocs: pip install '.[docs]'")
    return yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))


def test_the_navigation_holds_every_page_of_the_docs_folder():
    site = config()
    assert site["docs_dir"] == "docs" and site["strict"] is True
    pages = nav_pages(site["nav"])
    assert len(pages) == len(set(pages)), "a page is in the navigation twice"
    present = sorted(p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md"))
    assert sorted(pages) == present, (
        f"not in mkdocs.yml's nav: {sorted(set(present) - set(pages))}; "
        f"in the nav but missing: {sorted(set(pages) - set(present))}")
    for page in ("index.md", "getting-started.md", "gallery.md", "scenes.md", "model.md",
                 "tendon.md", "contact.md", "inverse.md", "dynamics.md", "studies.md",
                 "batch.md", "archive.md", "reliability.md", "benchmarks.md",
                 "architecture.md", "api/index.md"):
        assert page in pages, page


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    pytest.importorskip("mkdocs", reason="mkdocs is not installed: it is in the test and docs "
                        "extras (pip install '.[docs]')")
    pytest.importorskip("mkdocstrings_handlers.python", reason="mkdocstrings[python] is not "
                        "installed: it is in the test and docs extras (pip install '.[docs]')")
    folder = tmp_path_factory.mktemp("docs") / "site"
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f",
                          str(ROOT / "mkdocs.yml"), "-d", str(folder)], capture_output=True,
                         text=True, timeout=300, check=False)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    return folder


@pytest.mark.slow  # mkdocs builds the site in a new process: 3.1 s of CPU; the
# navigation's check (every page of docs/ in it) runs every time
def test_the_site_builds_strictly_with_the_user_guide_and_the_api(site):
    for page in nav_pages(config()["nav"]):
        stem = page.removesuffix(".md")
        built = site / ("index.html" if stem == "index" else
                        f"{stem.removesuffix('/index')}/index.html")
        assert built.is_file(), page
    guide = (site / "getting-started" / "index.html").read_text(encoding="utf-8")
    assert "rodsim simulate table1-50g" in guide
    # The API reference holds the docstring text itself, not only the headings.
    api = (site / "api" / "inverse" / "index.html").read_text(encoding="utf-8")
    assert "Values of the scene keys" in api and "rodsim.app.inverse.reach.reach" in api
    # The figures the pages show are copied beside them.
    assert (site / "figures" / "fig7b.png").is_file()
    # The gallery shows every shipped scene's figure, and each is in the site.
    from rodsim.core.scene import scene_paths

    gallery = (site / "gallery" / "index.html").read_text(encoding="utf-8")
    for scene in scene_paths():
        assert f"figures/gallery/{scene}.png" in gallery, scene
        assert (site / "figures" / "gallery" / f"{scene}.png").is_file(), scene


def test_no_docstring_in_the_package_holds_a_raw_sphinx_role():
    """Every docstring of rodsim/ (modules, classes, functions, and the strings documenting
    attributes) writes names as code spans: the site renders Markdown, not reStructuredText."""
    found = []
    for path in sorted((ROOT / "rodsim").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if (isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
                    and isinstance(node.value.value, str)):
                found += [f"{path.relative_to(ROOT)}:{node.lineno}: {role.group()}…"
                          for role in ROLE.finditer(node.value.value)]
    assert len(list((ROOT / "rodsim").rglob("*.py"))) > 100
    assert not found, "write ``name``, not a Sphinx role:\n" + "\n".join(found[:20])
