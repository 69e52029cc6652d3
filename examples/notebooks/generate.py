"""Write the notebooks in examples/notebooks/ from the example scripts they show.

    python examples/notebooks/generate.py           # rewrite every notebook
    python examples/notebooks/generate.py --check   # exit 1 if a notebook is stale

Each notebook is made from one script in examples/ (``SCRIPTS``), so the code lives in one
place: the script's docstring becomes the first (markdown) cell and each ``# %%`` section a
code cell (the cell markers of Jupytext's percent format, which editors such as VS Code and
Spyder also run cell by cell); a trailing ``# noqa`` comment is left out. The notebooks are
saved without outputs, with fixed cell ids, so a regenerated notebook is byte-identical when
its script has not changed (tests/test_notebooks.py checks it, and executes each one).
"""

from __future__ import annotations

import argparse
import ast
import re
import sys
from pathlib import Path

import nbformat

HERE = Path(__file__).resolve().parent
EXAMPLES = HERE.parent
#: The example scripts that are also notebooks (a few seconds each).
SCRIPTS = ("01_cantilever.py", "02_tendon_catheter.py", "07_track.py", "08_swing.py")
_NOQA = re.compile(r"\s*# noqa\b.*$")


def _markdown(docstring: str, stem: str) -> str:
    """The first cell: a title and the docstring with its code spans in Markdown."""
    number, _, name = stem.partition("_")
    heading = f"# Example {number}: {name.replace('_', ' ')}"
    return f"{heading}\n\n" + docstring.strip().replace("``", "`")


def notebook(script: Path) -> str:
    """The notebook of ``script`` as the text it is saved as."""
    source = script.read_text(encoding="utf-8")
    docstring = ast.get_docstring(ast.parse(source), clean=True)
    if docstring is None:
        raise SystemExit(f"{script.name}: no module docstring for the first cell")
    body = source.split("\n# %%", 1)
    if len(body) != 2:
        raise SystemExit(f"{script.name}: no '# %%' cell marker")
    cells = [nbformat.v4.new_markdown_cell(_markdown(docstring, script.stem))]
    for section in body[1].split("\n# %%"):
        lines = [_NOQA.sub("", line) for line in section.splitlines()[1:]]
        code = "\n".join(lines).strip("\n")
        if code:
            cells.append(nbformat.v4.new_code_cell(code))
    for number, cell in enumerate(cells):
        cell["id"] = f"{script.stem}-{number}"
    book = nbformat.v4.new_notebook(cells=cells, metadata={
        "kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"},
        "language_info": {"name": "python"}})
    nbformat.validate(book)
    return nbformat.writes(book) + "\n"


def target(script: str) -> Path:
    """Where the notebook of ``script`` is saved."""
    return HERE / (Path(script).stem + ".ipynb")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="exit 1 if a notebook differs from its script's, write nothing")
    args = parser.parse_args(argv)
    stale = []
    for script in SCRIPTS:
        text = notebook(EXAMPLES / script)
        path = target(script)
        if path.exists() and path.read_text(encoding="utf-8") == text:
            continue
        stale.append(path.name)
        if not args.check:
            path.write_text(text, encoding="utf-8")
    if stale:
        verb = "stale (run python examples/notebooks/generate.py)" if args.check else "written"
        print(f"{', '.join(stale)}: {verb}")
    return 1 if stale and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
