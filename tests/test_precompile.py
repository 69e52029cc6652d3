"""``rodsim compile`` and ``rodsim.compile_kernels`` (rodsim/app/precompile.py; issue 35 item
2): the kernels compiled ahead of time into numba's disk cache, so that a later process
compiles nothing.

The compilations are counted, not timed: numba's own dispatcher statistics (its cache
misses: a signature compiled in the process) and the cache folder's files (a compile writes
an index and a data file; loading writes nothing).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import rodsim
from rodsim.app.cli import main
from rodsim.app.precompile import compile_steps, kernel_counts
from rodsim.core.model import Model
from rodsim.core.obstacles import registered_obstacles
from rodsim.core.terms import registered_terms

KERNELS = Path(rodsim.__file__).parent / "core" / "kernels"


def step_models() -> list[Model]:
    """The models of every solve of ``rodsim compile`` (numpy path: no numba here)."""
    models = []
    for step in compile_steps():
        scene = rodsim.load_scene(step.scene, step.overrides)
        models.append(Model(scene, "numpy"))
    return models


def test_the_compile_step_solves_every_term_kernel_and_obstacle_type():
    """Every registered term, every kernel module and every obstacle type is in a scene
    that ``rodsim compile`` solves (so a new term needs a scene there, or this fails)."""
    models = step_models()
    terms = {type(term).name for model in models for term in model.terms}
    kernels = {term.kernel or term.name for model in models for term in model.terms}
    obstacles = {type(term.obstacle).__name__ for model in models for term in model.terms
                 if hasattr(term, "obstacle")}
    assert set(registered_terms()) <= terms, set(registered_terms()) - terms
    modules = {path.stem for path in KERNELS.glob("*.py")  # a term's kernel has evaluate
               if "\ndef evaluate(" in path.read_text(encoding="utf-8")}
    assert modules <= kernels, modules - kernels
    assert {cls.__name__ for cls in registered_obstacles().values()} <= obstacles
    rough = {type(term).name for model in models for term in model.terms
             if getattr(term, "friction", 0.0) > 0.0}
    assert {"tendon_string", "contact"} <= rough  # friction on tendons and on obstacles


def test_an_obstacle_type_registered_later_is_compiled_for_from_its_example():
    """A type added to the registry (docs/architecture.md, "How to add an obstacle type")
    gets its compile scenes, with and without friction, from its own ``example`` table:
    rodsim/app/kernel_coverage.py names no type. The throwaway type reuses the sphere's gap
    and kernel under a new name and is registered for this test only."""
    from rodsim.core.obstacles import OBSTACLES
    from rodsim.core.obstacles.sphere import Sphere

    class Ball(Sphere):
        type = "test_ball"
        example = {"center": [0.07, -0.02, 0.0], "radius": 0.015}

    try:
        steps = {step.label: step for step in compile_steps()}
        for name in ("compile-obstacle-test_ball", "compile-obstacle-test_ball-friction"):
            result = rodsim.solve(steps[name].scene, "static")
            assert result.success, result.message
            ball = [t for t in Model(result.scene, "numpy").terms if hasattr(t, "obstacle")]
            assert [type(t.obstacle) for t in ball] == [Ball], name
            assert (ball[0].friction > 0.0) == name.endswith("friction")
            gap = ball[0].obstacle.gap(result.positions())[0]
            radius = result.scene.rods["catheter"].radius  # contact where φ < r
            assert gap.min() < radius, f"{name}: the example does not stop the rod"
    finally:
        del OBSTACLES[Ball.type]
    assert not [n for n in (step.label for step in compile_steps()) if "test_ball" in n]


def test_an_unknown_scene_is_one_line_and_exit_2(capsys):
    compiled_before = kernel_counts().compiled  # this process's earlier tests may compile
    assert main(["compile", "no-such-scene"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no-such-scene" in err and "tdcr-two-segment" in err
    assert kernel_counts().compiled == compiled_before  # nothing was solved


def files(folder: Path) -> dict[str, tuple[int, int]]:
    """Every file of the cache folder: size and modification time."""
    return {str(path.relative_to(folder)): (path.stat().st_size, path.stat().st_mtime_ns)
            for path in folder.rglob("*") if path.is_file()}


SOLVE_AND_COUNT = """
import dataclasses, json, rodsim
from rodsim.app.precompile import kernel_counts
for integrator in (None, "static"):
    assert rodsim.solve("table1-50g", integrator).success
print(json.dumps(dataclasses.asdict(kernel_counts())))
"""


@pytest.mark.slow  # compiles table1-50g's kernels into an empty cache (a minute on 2 cores)
def test_after_rodsim_compile_a_later_process_compiles_nothing(tmp_path):
    cache = tmp_path / "numba-cache"
    cache.mkdir()
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    done = subprocess.run([sys.executable, "-m", "rodsim", "compile", "table1-50g"], env=env,
                          capture_output=True, text=True, timeout=1200)
    assert done.returncode == 0, done.stderr
    compiled = int(re.search(r"compiled +(\d+) kernel signatures", done.stdout).group(1))
    assert compiled > 0, done.stdout  # the count sees compilations into an empty cache
    assert "compiling kernels: table1-50g" in done.stderr  # the progress line
    before = files(cache)
    assert any(name.endswith(".nbi") for name in before)

    # The Python entry (compiled kernels), the scene's integrator (cvode) and static (the
    # error estimates' re-solves), in a fresh process. (Under ida two more signatures would
    # be compiled: the full `rodsim compile` solves table1-50g with every integrator.)
    later = subprocess.run([sys.executable, "-c", SOLVE_AND_COUNT], env=env,
                           capture_output=True, text=True, timeout=600, check=True)
    counts = json.loads(later.stdout.strip().splitlines()[-1])
    assert counts["compiled"] == 0, counts
    assert counts["loaded"] > 0 and counts["kernels"] > 0, counts
    # And the command with the compiled kernels from its first evaluation.
    run = subprocess.run([sys.executable, "-m", "rodsim", "run", "table1-50g", "--set",
                          "solver.kernels=compiled", "-o", str(tmp_path / "run.nc")], env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert files(cache) == before  # no index rewritten, no machine code added
