"""What a new user meets first (issue 14, "rough edges"): where the default archive goes,
the progress line on a narrow terminal and at the end, an unknown scene name, the study
list's order, ``plot --help``, and library errors worded without the CLI's flags."""

from __future__ import annotations

import ast
import io
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

import rodsim
from rodsim.app.cli import build_parser
from rodsim.app.progress import ProgressPrinter
from rodsim.core.scene import scene_paths
from rodsim.core.schema import SceneError

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "rodsim"


def test_run_without_o_writes_into_runs_and_git_ignores_it(tmp_path, monkeypatch, cli, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli(["run", "--integrator", "static", "--set", "nodes=6"]) == 0
    assert "archive     runs/table1-50g-static.nc" in capsys.readouterr().out
    assert sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*")) == [
        "runs", "runs/table1-50g-static.nc"]
    if shutil.which("git") is None or not (ROOT / ".gitignore").is_file():
        pytest.skip("no git, or not a checkout")
    for path in ("runs/table1-50g-cvode.nc", "table1-50g-cvode.nc", "fig7b-full.nc.parts/x"):
        check = subprocess.run(["git", "-C", str(ROOT), "check-ignore", "-q", "--no-index",
                                path], check=False)
        assert check.returncode == 0, f"{path} is not covered by .gitignore"


def test_an_unwritable_default_folder_is_a_one_line_error(tmp_path, monkeypatch, cli, capsys):
    (tmp_path / "runs").write_text("a file where the folder would go")
    monkeypatch.chdir(tmp_path)
    assert cli(["run", "--integrator", "static", "--set", "nodes=6"]) == 2
    err = capsys.readouterr().err
    assert "runs" in err and "-o" in err and err.count("\n") == 1, err


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def written_lines(stream: Terminal) -> list[str]:
    """The successive states of an in-place progress line."""
    return [chunk for chunk in stream.getvalue().split("\r") if chunk]


def test_progress_line_fits_the_terminal_width(monkeypatch):
    monkeypatch.setattr(shutil, "get_terminal_size",
                        lambda fallback=(80, 24): os.terminal_size((80, 24)))
    stream = Terminal()
    printer = ProgressPrinter(stream, delay=0.0, interval=0.0)
    printer(0.5, "a status line far longer than an 80-column terminal is wide " * 3)
    printer(None, "short")
    printer.close()
    lines = written_lines(stream)
    assert len(lines) == 2
    assert all(len(line.rstrip("\n")) == 79 for line in lines), [len(x) for x in lines]


def test_the_last_progress_line_reports_completion():
    """Rate limiting once dropped the final call: "98.3% 59/60" stayed on the screen."""
    stream = Terminal()
    printer = ProgressPrinter(stream, delay=0.0, interval=1e9)
    for done in range(61):
        printer(done / 60, f"convergence: {done}/60 done")
    printer.close()
    lines = written_lines(stream)
    assert len(lines) == 2, lines  # the first call, then the final one despite the interval
    assert "100.0% convergence: 60/60 done" in lines[-1] and lines[-1].endswith("\n")


def test_an_unknown_scene_name_lists_the_shipped_ones(tmp_path, monkeypatch, cli, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli(["run", "table1-500g"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "No such file" not in err, err
    assert "table1-500g is neither a shipped scene nor a file" in err
    assert "did you mean 'table1-50g'?" in err
    assert all(name in err for name in scene_paths()), err
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(SceneError) as info:
        rodsim.load_scene("table1-500g")
    assert info.value.allowed == tuple(scene_paths()) and info.value.key == "table1-500g"


def test_studies_are_listed_in_natural_order(cli, capsys):
    assert cli(["study"]) == 0
    names = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    figures = [n for n in names if re.fullmatch(r"fig\d+[a-z]?", n)]
    assert figures == sorted(figures, key=lambda n: (int(re.sub(r"\D", "", n)), n)), figures
    assert figures.index("fig6") < figures.index("fig22")


def test_plot_help_describes_the_command(cli, capsys):
    with pytest.raises(SystemExit):
        cli(["plot", "--help"])
    out = capsys.readouterr().out
    assert "from the archive alone" in out, out


# Library errors in the library's words, the CLI's words in the CLI ------------------------

@pytest.mark.parametrize(("assignment", "reason", "key", "allowed"), [
    ("nodes80", "expected key=value", None, "key=value"),
    ("colour=3", "unknown key", "colour", ()),
    ("nodse=3", "unknown key", "nodse", ("nodes",)),
])
def test_override_errors_carry_fields_and_no_cli_flags(assignment, reason, key, allowed, cli,
                                                       capsys, tmp_path):
    scene = rodsim.load_scene("table1-50g")
    with pytest.raises(SceneError) as info:
        scene.with_overrides([assignment])
    error = info.value
    assert (error.reason, error.key, error.allowed, error.assignment) == (
        reason, key, allowed, assignment)
    assert "--" not in str(error) and "rodsim run" not in str(error), str(error)
    # The CLI words the same error with its flag.
    assert cli(["run", "--integrator", "static", "--set", assignment,
                "-o", str(tmp_path / "x.nc")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"rodsim: error: --set {assignment}: "), err


def test_an_ambiguous_override_lists_the_candidates_as_a_field(tmp_path, cli, capsys):
    scene = rodsim.load_scene("table3-catheter1")
    with pytest.raises(SceneError, match="ambiguous key nodes") as info:
        scene.with_overrides(["nodes=20"])
    assert info.value.allowed == ("rods.catheter.nodes", "rods.tendon.nodes")
    assert "--set" not in str(info.value)
    assert cli(["run", "table3-catheter1", "--set", "nodes=20",
                "-o", str(tmp_path / "x.nc")]) == 2
    assert "--set nodes=20: nodes is ambiguous, could be rods.catheter.nodes, " \
           "rods.tendon.nodes" in capsys.readouterr().err


def test_a_value_error_has_key_value_and_allowed():
    with pytest.raises(SceneError) as info:
        rodsim.load_scene("table1-50g", ["nodes=2"])
    error = info.value
    assert (error.key, error.value, error.reason) == ("rods.catheter.nodes", 2, "out of range")
    assert error.allowed == "an integer >= 3 and <= 200000"


def _strings(path: Path) -> list[str]:
    """The string constants of a module, docstrings and comments left out."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docstrings = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                docstrings.add(id(body[0].value))
    return [node.value for node in ast.walk(tree) if isinstance(node, ast.Constant)
            and isinstance(node.value, str) and id(node) not in docstrings]


def test_the_library_layers_name_no_cli_flag():
    """rodsim/core, solvers and io speak Python (dotted scene keys, integrator names); the
    CLI's flags (--set, --integrator, …) are the CLI's to word (rodsim/app/cli/)."""
    parser = build_parser()
    flags = {option for action in parser._actions for option in action.option_strings}
    for sub in parser._subparsers._group_actions[0].choices.values():
        flags |= {option for action in sub._actions for option in action.option_strings}
    flags = {flag for flag in flags if flag.startswith("--")}
    found = []
    for layer in ("core", "solvers", "io"):
        for path in sorted((PACKAGE / layer).rglob("*.py")):
            for text in _strings(path):
                found += [f"{path.relative_to(ROOT)}: {flag} in {text[:60]!r}" for flag in flags
                          if re.search(rf"{re.escape(flag)}\b", text)]
    assert not found, "\n".join(found)


def test_a_status_held_back_by_the_interval_is_shown_on_close():
    """A solver's last report (e.g. its final Newton iteration) may fall inside the interval;
    close() shows it, so the screen never ends on an older one. Reports at completion after
    the first are rate-limited like any other (no flood of 100 % lines in a log)."""
    stream = Terminal()
    printer = ProgressPrinter(stream, delay=0.0, interval=1e9)
    printer(0.2, "load 0.2")
    printer(1.0, "load 1, Newton iteration 1")
    for iteration in range(2, 20):
        printer(1.0, f"load 1, Newton iteration {iteration}")
    lines = written_lines(stream)
    assert [line.split("] ")[1].strip() for line in lines] == [
        "20.0% load 0.2", "100.0% load 1, Newton iteration 1"]
    printer.close()
    assert "Newton iteration 19" in written_lines(stream)[-1]
    quiet = Terminal()
    silent = ProgressPrinter(quiet, delay=1e9)
    silent(0.5, "under the delay")
    silent.close()
    assert quiet.getvalue() == ""
