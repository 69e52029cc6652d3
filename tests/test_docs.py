"""The generated parts of the docs match the code they describe."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_scene_reference_in_docs_is_current():
    """docs/scenes.md's key tables are generated from the parameter declarations; a changed
    default, unit or range must be regenerated (python docs/generate_scene_reference.py)."""
    script = ROOT / "docs" / "generate_scene_reference.py"
    run = subprocess.run([sys.executable, str(script), "--check"], capture_output=True,
                         text=True, check=False)
    assert run.returncode == 0, run.stdout + run.stderr


ARCHITECTURE = ROOT / "docs" / "architecture.md"

#: A repository path as docs/architecture.md writes them: from a top-level folder of the
#: repository, with no placeholder (``rodsim/core/terms/<term>.py`` is a pattern, not a file).
PATH = re.compile(r"(?<![\w/.])(?:rodsim|tests|docs|studies|data|benchmarks)/[\w./-]*")


def architecture_paths() -> list[str]:
    text = ARCHITECTURE.read_text(encoding="utf-8")
    paths = []
    for match in PATH.finditer(text):
        end = match.end()
        if end < len(text) and text[end] == "<":
            continue
        paths.append(match.group().rstrip(".,"))
    return paths


def test_every_path_in_the_architecture_page_exists():
    """docs/architecture.md is the newcomer's map from equations and layers to files: a file
    moved or renamed without updating the map fails here."""
    paths = architecture_paths()
    assert len(paths) > 40, paths  # the map names the files, not just folders
    missing = sorted({p for p in paths if not (ROOT / p).exists()})
    assert not missing, f"docs/architecture.md names files that do not exist: {missing}"


def _equation_numbers(text: str) -> set[int]:
    """Numbers of the paper equations cited as "Eq. (n)", "Eqs. (a)–(b)", "Eqs. 3–7",
    "Eqs. (25)–(27), (33)–(35)" …: every number, ranges expanded."""
    numbers: set[int] = set()
    for cite in re.finditer(r"Eqs?\.\s*((?:\(?\d+\)?(?:\s*[–-]\s*\(?\d+\)?)?(?:,\s*)?)+)",
                            text):
        for a, b in re.findall(r"(\d+)\)?(?:\s*[–-]\s*\(?(\d+))?", cite.group(1)):
            numbers.update(range(int(a), int(b or a) + 1))
    return numbers


def test_every_equation_the_code_cites_is_in_the_architecture_map():
    """Each paper equation a module of the package cites has a row in the equation → file
    table of docs/architecture.md."""
    table = "\n".join(line for line in ARCHITECTURE.read_text(encoding="utf-8").splitlines()
                      if line.startswith("| Eq"))
    mapped = _equation_numbers(table)
    cited = set()
    for path in (ROOT / "rodsim").rglob("*.py"):
        cited |= _equation_numbers(path.read_text(encoding="utf-8"))
    assert cited, "no equation citations found in rodsim/"
    unmapped = sorted(cited - mapped)
    assert not unmapped, f"equations cited in rodsim/ but not in docs/architecture.md: {unmapped}"


def test_the_error_examples_in_the_scene_docs_are_what_the_cli_prints(cli, capsys, tmp_path,
                                                                       monkeypatch):
    """Each ``$ rodsim …`` example of docs/scenes.md followed by a ``rodsim: error:`` line
    prints that line (exit 2); the docs once showed an error for a command that runs."""
    import re
    import shlex

    text = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    examples = re.findall(r"^\s*\$ rodsim (.+)\n\s*(rodsim: error: .+)$", text, re.MULTILINE)
    assert len(examples) >= 2, examples
    monkeypatch.chdir(tmp_path)
    for command, error in examples:
        assert cli(shlex.split(command)) == 2, command
        assert capsys.readouterr().err.strip() == error.strip(), command


def test_ci_runs_the_readme_test_command():
    """.ci/run runs the suite exactly as the README tells a newcomer to, then the tests
    marked slow that the README's command leaves out (tests/conftest.py), and fails if
    either run does."""
    import re

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    documented = re.search(r'pip install "\.\[test\]" && (python -m pytest[^\n]*)', readme)
    assert documented, "the README's test command is not where it was"
    command = re.escape(documented[1])
    assert re.search(rf"^{command} \|\| status=\$\?$", ci, re.MULTILINE), (
        f".ci/run does not run {documented[1]!r}")
    assert re.search(rf"^{command} -m slow --runslow \|\| status=\$\?$", ci, re.MULTILINE), (
        ".ci/run does not run the tests marked slow")
    assert re.search(r'^exit "\$status"$', ci, re.MULTILINE)
    assert "--runslow" in readme and "-m slow --runslow" in readme


def test_the_gallery_is_current():
    """docs/gallery.md shows every shipped scene and example script, with a figure for each
    scene; a scene or example added, renamed or redescribed must be regenerated
    (python docs/generate_gallery.py, with --figures for a new or changed scene)."""
    run = subprocess.run([sys.executable, str(ROOT / "docs" / "generate_gallery.py"), "--check"],
                         capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stdout + run.stderr


def test_ci_installs_the_system_library_the_readme_names():
    """The CF-conformance tests skip without libudunits2: README names the package that
    turns them on, .ci/run installs that package (when it can) before the test runs, and
    the skip message names it too."""
    import re

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    skip = (ROOT / "tests" / "test_cf_archives.py").read_text(encoding="utf-8")
    named = re.search(r"`apt-get install (libudunits2[\w.-]*)`", readme)
    assert named, "README no longer says which system library the CF tests need"
    package = named[1]
    install = ci.find(f"apt-get install -y -q {package}")
    assert install >= 0, f".ci/run does not install {package}"
    assert install < ci.index("python -m pytest"), "installed after the tests ran"
    assert f"apt-get install {package}" in skip
