"""Every command and snippet of README.md and docs/*.md runs (issue 22: the README's Python
snippet imported ``rerun`` from where it no longer was, and nothing noticed).

Each document's ```python and ```sh blocks are run in the order they appear, in one empty
folder per document (commands are written from the repository root: the few files they
name — a scene file, measured points — are made there first, below). A ``rodsim …`` command
runs in process through the CLI and must exit 0 (or the exit code its comment promises);
``python …`` runs in a subprocess; a Python block runs with ``exec`` (a ``>>>`` session as a
doctest). A command that cannot run as written here — it installs software, runs the suite
itself, or takes minutes — is in :data:`ADAPTED` with the reason and what runs instead; a
command in neither is run as written, and an entry of :data:`ADAPTED` no document contains
any more fails, so the table cannot go stale.
"""

from __future__ import annotations

import doctest
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCUMENTS = ["README.md", *sorted(p.relative_to(ROOT).as_posix()
                                  for p in (ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^```(python|sh)\n(.*?)^```", re.MULTILINE | re.DOTALL)

SKIP = None
#: command (as written, comments removed, whitespace collapsed) -> (what runs instead, or
#: SKIP; why).
ADAPTED: dict[str, tuple[str | None, str]] = {
    "python3 -m venv .venv": (SKIP, "creates the environment the tests already run in"),
    ". .venv/bin/activate": (SKIP, "activates the environment the tests already run in"),
    "pip install .": (SKIP, "installs software"),
    "pip install '.[test]'": (SKIP, "installs software"),
    "pip install '.[docs]'": (SKIP, "installs software"),
    "mkdocs build --strict": (SKIP, "builds the site: tests/test_docs_site.py does, into a "
                              "temporary folder"),
    "mkdocs serve": (SKIP, "serves the site until it is stopped"),
    "python -m pytest -q -n auto --dist worksteal": (
        SKIP, "runs the test suite this test is part of (.ci/run runs it: test_docs.py)"),
    "rodsim study fig17 --scheduler local": (
        "rodsim study fig17 --size small --scheduler local -o fig17.nc",
        "the full grid takes minutes; the small one exercises the same dask path"),
    "rodsim bench kernels": (
        SKIP, "the same small run as tests/test_bench.py::test_kernels_small_outputs"),
    "rodsim bench scaling --size full --commit": (
        SKIP, "the full benchmark takes minutes and writes into the checkout's committed "
        "results; the small size runs in test_bench.py"),
    "rodsim bench work-precision --size full --commit": (SKIP, "~14 min, into the checkout"),
    "rodsim bench stress --size full --commit": (SKIP, "~50 min, into the checkout"),
    "rodsim bench skip-work --size full --commit": (SKIP, "~3 min, into the checkout"),
    "rodsim bench startup --size full --commit": (SKIP, "~2 min, into the checkout"),
    "rodsim bench tracking --size full --commit": (SKIP, "into the checkout"),
    "rodsim bench workers --size full --commit": (SKIP, "~1 min, into the checkout"),
    "rodsim bench iterations --size full --commit": (SKIP, "~1 min, into the checkout"),
    "rodsim batch tdcr-two-segment --cases examples/cases.csv --scheduler tcp://host:8786": (
        SKIP, "needs a dask scheduler at that address (the dask path: tests/test_batch.py)"),
    "python benchmarks/single_rod.py": (
        "python {root}/benchmarks/single_rod.py --repeats 1 --output-dir single-rod",
        "its default output is the checkout's committed results, and repeats only refine "
        "timings"),
    "rodsim study fig6 --size full -o /tmp/fig6.nc": (
        "rodsim study fig6 --size small -o fig6.nc",
        "the full grid takes minutes, and /tmp is shared"),
    "rodsim plot /tmp/fig6.nc -o docs/figures/fig6 --format png": (
        "rodsim plot fig6.nc -o fig6 --format png",
        "the committed figure must not be overwritten by a test"),
}

#: Commands a document shows that are known to fail, with the reason: reported as expected
#: failures, not run. Empty: every command runs (the README's reach of four-tendons, once
#: out of reach after ~164 s, reaches its new target in seconds, issue 22 item 4).
KNOWN_FAILURES: dict[str, str] = {}


def blocks(document: str) -> list[tuple[str, str]]:
    """(language, text) of each python and sh block, in order."""
    return BLOCK.findall((ROOT / document).read_text(encoding="utf-8"))


def commands(text: str) -> list[str]:
    """The commands of a sh block: continuation lines joined, comments dropped, each
    ``a && b`` split, whitespace collapsed."""
    joined = re.sub(r"\\\n\s*", " ", text)
    found = []
    for line in joined.splitlines():
        words = shlex.split(line, comments=True)
        if not words:
            continue
        command = " ".join(shlex.quote(w) if w != "&&" else w for w in words)
        found.extend(part.strip() for part in command.split(" && "))
    return found


def every_command() -> set[str]:
    return {c for d in DOCUMENTS for language, text in blocks(d) if language == "sh"
            for c in commands(text)}


def test_the_adaptation_table_is_current():
    """Every adapted or known-failing command is still in a document."""
    stale = (set(ADAPTED) | set(KNOWN_FAILURES)) - every_command()
    assert not stale, f"no document contains these any more: {sorted(stale)}"


def _prepare(folder: Path) -> None:
    """The files the documents' commands name, in the folder they run in."""
    import rodsim

    (folder / "docs").mkdir()
    shutil.copy(ROOT / "docs" / "two-rods.toml", folder / "docs" / "two-rods.toml")
    # The example files the commands name (examples/my-scene.toml, shape.csv, cases.csv).
    (folder / "examples").mkdir()
    for name in ("my-scene.toml", "shape.csv", "cases.csv"):
        shutil.copy(ROOT / "examples" / name, folder / "examples" / name)
    # Measured points for the other fit examples: the scene solved with other values.
    photo = rodsim.solve("table1-50g", "static",
                         overrides=["youngs_modulus=5e6", "tip_load.force=[0.1, 0.0, 0.0]"])
    _write_points(folder / "photo.csv", photo.positions("catheter")[1:])


def _write_points(path: Path, xyz: np.ndarray) -> None:
    lines = ["x,y,z"] + [",".join(f"{v:.9g}" for v in row) for row in xyz]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _run_command(command: str, cli, capsys) -> None:
    if command in KNOWN_FAILURES:
        return
    if command in ADAPTED:
        replacement, _why = ADAPTED[command]
        if replacement is None:
            return
        command = replacement.format(root=ROOT)
    words = shlex.split(command)
    if words[0] == "rodsim":
        try:
            code = cli(words[1:])
        except SystemExit as exit_:  # --help: argparse exits
            code = exit_.code
        captured = capsys.readouterr()
        assert code == 0, f"{command!r} exited {code}: {captured.err[-1500:]}"
    elif words[0] == "python":
        environment = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
        run = subprocess.run([sys.executable, *words[1:]], capture_output=True, text=True,
                             timeout=600, env=environment, check=False)
        assert run.returncode == 0, f"{command!r}: {run.stderr[-1500:]}"
    else:
        raise AssertionError(f"no rule to run {command!r}: add it to ADAPTED with a reason")


def _run_python(text: str, namespace: dict, document: str) -> None:
    if text.lstrip().startswith(">>>"):
        test = doctest.DocTestParser().get_doctest(text, namespace, document, document, 0)
        runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS
                                       | doctest.NORMALIZE_WHITESPACE)
        runner.run(test, out=lambda report: pytest.fail(f"{document}:\n{report}"))
        assert runner.summarize(verbose=False).failed == 0
    else:
        exec(compile(text, document, "exec"), namespace)  # noqa: S102 (the docs' own code)


#: Python blocks that continue a page's running example: what they start from.
PRELUDES = {
    # "Select one rod with": the page's archive, ds, is the two-rod example's.
    ("docs/archive.md", 0): "from rodsim.io.archive import read_dataset\n"
                            "ds = read_dataset('two-rods.nc')\n",
}

#: Set-up commands a document's blocks read the output of, though the document names the
#: command only in its text: (command, why).
SETUP = {
    "docs/archive.md": [
        ("rodsim run docs/two-rods.toml --integrator static -o two-rods.nc",
         "the archive of the page's running example"),
        ("rodsim study fig7b --size small -o fig7b-full.nc",
         "'Reading a study archive' opens the full fig7b archive; the small grid has the "
         "same dimensions and N = 40 (the full one takes minutes)"),
    ],
}

#: > 5 s of CPU each (measured: README.md 19, docs/dynamics.md 14, docs/batch.md 8.5,
#: docs/inverse.md 6.5, docs/getting-started.md 6, docs/benchmarks.md 3.4-5): run first on
#: the parallel workers.
SLOW = {"README.md", "docs/dynamics.md", "docs/batch.md", "docs/inverse.md",
        "docs/getting-started.md", "docs/benchmarks.md"}


@pytest.mark.parametrize("document", [
    pytest.param(d, marks=pytest.mark.slow) if d in SLOW else d
    for d in DOCUMENTS if blocks(d)])
def test_every_command_and_snippet_runs(document, tmp_path, monkeypatch, cli, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    _prepare(tmp_path)
    for command, _why in SETUP.get(document, []):
        _run_command(command, cli, capsys)
    namespace: dict = {}
    python_blocks = 0
    for language, text in blocks(document):
        if language == "sh":
            for command in commands(text):
                _run_command(command, cli, capsys)
        else:
            prelude = PRELUDES.get((document, python_blocks), "")
            _run_python(prelude + text if prelude else text, namespace, document)
            python_blocks += 1
    known = [c for language, text in blocks(document) if language == "sh"
             for c in commands(text) if c in KNOWN_FAILURES]
    if known:
        pytest.xfail("; ".join(KNOWN_FAILURES[c] for c in known))


def test_every_complete_scene_in_the_docs_loads():
    """A ```toml block with rods (a whole scene file, as docs/scenes.md shows one) is a valid
    scene; fragments (a single tendon table) are left to the pages' prose."""
    import tomllib

    import rodsim

    found = 0
    for document in DOCUMENTS:
        text = (ROOT / document).read_text(encoding="utf-8")
        for block in re.findall(r"^```toml\n(.*?)^```", text, re.MULTILINE | re.DOTALL):
            table = tomllib.loads(block)
            if "rods" not in table:
                continue
            rodsim.load_scene(table)  # SceneError if a key, unit or value is wrong
            found += 1
    assert found >= 1
