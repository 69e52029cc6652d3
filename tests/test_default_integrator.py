"""A scene that names no integrator runs the registry's one default (static), in `rodsim
run`, in the Python API and in `rodsim track`, which therefore agree; an archive written
when the default was cvode (at 61294df) still reruns with cvode, to the bit
(rodsim/core/integrator_default.py, docs/scenes.md "Which integrator runs").

The scene is a user's steel wire (L 0.4 m, r 1.2 mm, E 207 GPa) under a 0.1 N tip force:
linear beam theory, F L³ / (3 E I), is the independent check of the answer."""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

import rodsim
from rodsim.core.scene import SolverSettings
from rodsim.io.archive import read_dataset, scene_of
from rodsim.solvers import DEFAULT_INTEGRATOR

DATA = Path(__file__).parent / "data"
SCENE = DATA / "implicit-default.toml"  # no [solver] table
OLD_ARCHIVE = DATA / "implicit-cvode-61294df.nc"  # `rodsim run` of SCENE at 61294df

LENGTH, RADIUS, YOUNG, FORCE = 0.4, 0.0012, 207e9, 0.1
NUMBER = r"[-+]?\d+\.?\d*(?:[eE][-+]?\d+)?"


#: Relative distance allowed from beam theory: at N = 11 the discretisation error is
#: 4.7e-3 of the deflection (the run's own estimate: 3.2e-5 m of 6.3e-3 m), the geometric
#: non-linearity at 1.6 % of L about 1e-4.
BEAM = 1e-2


def beam_deflection() -> float:
    """F L³ / (3 E I) of the cantilever: the linear tip deflection [m]."""
    return FORCE * LENGTH**3 / (3 * YOUNG * math.pi * RADIUS**4 / 4)


def test_the_documented_default_is_static():
    assert DEFAULT_INTEGRATOR == "static"
    assert SolverSettings().integrator == DEFAULT_INTEGRATOR
    assert "[solver]" not in SCENE.read_text()
    scene = rodsim.load_scene(str(SCENE))
    assert scene.solver.integrator == DEFAULT_INTEGRATOR
    assert scene.data["solver"]["integrator"] == DEFAULT_INTEGRATOR  # archives store it


def test_python_solves_a_scene_without_an_integrator_with_the_default():
    result = rodsim.solve(str(SCENE))
    assert result.success, result.message
    assert result.integrator == DEFAULT_INTEGRATOR
    deflection = -result.tip()[1]
    assert abs(deflection - beam_deflection()) < BEAM * beam_deflection()


def test_run_and_track_agree_on_a_scene_without_an_integrator(tmp_path, capsys, cli):
    """`rodsim run` and step 0 of `rodsim track` (a cold solve at the ramp's first value)
    use the same integrator and reach the same tip (their kernels differ only by
    round-off: tiered for run, compiled for track)."""
    archive = tmp_path / "run.nc"
    assert cli(["run", str(SCENE), "-o", str(archive)]) == 0
    out = capsys.readouterr().out
    assert f"integrator  {DEFAULT_INTEGRATOR}  (" in out
    run = read_dataset(archive)
    assert run.attrs["integrator"] == DEFAULT_INTEGRATOR
    run_tip = run["position"].values[-1]
    printed = re.search(rf"tip of wire\s+x =\s*({NUMBER}) m\s+y =\s*({NUMBER}) m", out)
    assert printed and abs(float(printed.group(2)) - run_tip[1]) < 1e-6
    tracked = tmp_path / "track.nc"
    assert cli(["track", str(SCENE), "--ramp", f"tip_load.force[1]={-FORCE}:{-FORCE / 2}:2",
                "-o", str(tracked)]) == 0
    track = read_dataset(tracked)
    assert track.attrs["integrator"] == DEFAULT_INTEGRATOR
    step0 = rodsim.track(rodsim.load_scene(str(SCENE)),
                         {"tip_load.force[1]": [-FORCE, -FORCE / 2]})
    assert step0.complete, step0.message
    assert np.max(np.abs(step0.tips()[0] - run_tip)) < 1e-9 * LENGTH


def test_an_archive_of_the_former_implicit_cvode_default_reruns_with_cvode():
    """Written at 61294df, when a scene without an integrator ran cvode: the archive holds
    the integrator (attribute and resolved scene), so rerun solves with cvode again and
    finds the stored positions exactly. In its own process, as a user runs it: the move
    from numpy to the compiled kernels is counted per process (rodsim/core/kernel_tier.py),
    so a test process that solved other scenes first would move at another evaluation and
    differ by round-off (5e-14 m, measured)."""
    stored = read_dataset(OLD_ARCHIVE)
    assert stored.attrs["integrator"] == "cvode"
    assert scene_of(stored).solver.integrator == "cvode"
    done = subprocess.run([sys.executable, "-m", "rodsim", "rerun", str(OLD_ARCHIVE)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert "integrator  cvode  (" in out
    assert "largest difference from the stored positions: 0 m" in out
    tip = stored["position"].values[-1]
    assert abs(-tip[1] - beam_deflection()) < BEAM * beam_deflection()
    now = rodsim.solve(str(SCENE))  # the same scene today: static, the same equilibrium
    assert now.integrator == "static"
    assert np.max(np.abs(now.rods["wire"].positions - stored["position"].values)) < 1e-6 * LENGTH


def test_every_shipped_scene_names_its_integrator():
    """So the default's change moves none of them (their equilibria:
    tests/test_scene_reference.py); tendon-conserving, the one that named none, now names
    the cvode it always ran."""
    from rodsim.core.scene import scene_paths

    for name, path in scene_paths().items():
        assert re.search(r"^integrator\s*=", path.read_text(), re.M), name
    assert rodsim.load_scene("tendon-conserving").solver.integrator == "cvode"
