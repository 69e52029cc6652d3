"""The notebooks in examples/notebooks/ (issue 36): each is made from an example script by
examples/notebooks/generate.py and must be up to date with it, is saved without outputs,
and runs top to bottom in a fresh Jupyter kernel (nbclient) with no cell error, from an
empty current folder; the cells that end in a result show its summary table and sketch (the
``_repr_html_`` Jupyter renders)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

FOLDER = Path(__file__).resolve().parent.parent / "examples" / "notebooks"
GENERATE = FOLDER / "generate.py"
NOTEBOOKS = sorted(FOLDER.glob("*.ipynb"))
#: The summary tables the notebooks show: notebook → the titles of their result cells.
TABLES = {"01_cantilever": ["rodsim Result: scene 'table1-50g', integrator static"],
          "02_tendon_catheter": ["rodsim Result: scene 'table3-catheter1', integrator static"],
          "07_track": ["rodsim Track: scene 'table3-catheter1'"],
          "08_swing": ["rodsim Modes: scene 'table1-50g'",
                       "rodsim Simulation: scene 'table1-50g', integrator midpoint"]}


def test_the_notebooks_are_made_from_the_scripts_and_up_to_date():
    run = subprocess.run([sys.executable, str(GENERATE), "--check"], capture_output=True,
                         text=True, check=False)
    assert run.returncode == 0, run.stdout + run.stderr
    assert [path.stem for path in NOTEBOOKS] == sorted(TABLES)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_a_notebook_is_saved_without_outputs(path):
    book = nbformat.read(path, as_version=4)
    nbformat.validate(book)
    code = [cell for cell in book.cells if cell.cell_type == "code"]
    assert code
    for cell in code:
        assert cell.outputs == [] and cell.execution_count is None, cell.id


@pytest.mark.slow  # a fresh Jupyter kernel each, ~2 s of CPU: 8 s in all
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_a_notebook_runs_without_a_cell_error(path, tmp_path, monkeypatch):
    monkeypatch.setenv("OMP_NUM_THREADS", "1")  # the kernel inherits the environment
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    book = nbformat.read(path, as_version=4)
    client = NotebookClient(book, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}})
    try:
        client.execute()
    except CellExecutionError as exc:
        pytest.fail(f"{path.name}: {str(exc)[-2000:]}")
    outputs = [output for cell in book.cells if cell.cell_type == "code"
               for output in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert any(o.output_type == "stream" and o.name == "stdout" for o in outputs)
    pages = [o.data["text/html"] for o in outputs if "text/html" in o.get("data", {})]
    titles = [title for title in TABLES[path.stem] if any(
        "<table>" in page and title.replace("'", "&#x27;") in page for page in pages)]
    # each table comes with its sketch of the shape (an inline SVG)
    assert all("<svg " in page for page in pages if "<table>" in page), pages
    assert titles == TABLES[path.stem], pages
