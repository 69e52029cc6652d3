"""The generated parts of the docs match the code they describe."""

from __future__ import annotations

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
    """.ci/run runs the suite exactly as the README tells a newcomer to."""
    import re

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    documented = re.search(r'pip install "\.\[test\]" && (python -m pytest[^\n]*)', readme)
    assert documented, "the README's test command is not where it was"
    assert re.search(rf"^{re.escape(documented[1])}$", ci, re.MULTILINE), (
        f".ci/run does not run {documented[1]!r}")
