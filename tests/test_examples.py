"""Every script in examples/ runs as a user would run it: ``python examples/NAME.py`` in a
fresh process, from an empty current folder (each writes, if anything, under ``runs/``
there), and exits 0. The scripts assert their own results (an equilibrium that agrees with
a second integrator, a fitted or reached value equal to the one the data were made with)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).resolve().parent.parent / "examples").glob("*.py"))


def test_there_are_five_to_eight_examples():
    assert 5 <= len(EXAMPLES) <= 8, [p.name for p in EXAMPLES]


@pytest.mark.slow  # a fresh interpreter each, 1-3.5 s of CPU: 16 s in all
@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs(script, tmp_path):
    environment = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
                       MPLBACKEND="Agg")
    run = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                         text=True, timeout=300, env=environment, check=False)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    assert run.stdout.strip(), "an example says what it computed"
    assert "Traceback" not in run.stderr
