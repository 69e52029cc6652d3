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
