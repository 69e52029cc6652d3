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
                         {"tip_load.force[1]": [-FORCE, -FORCE / 2]}, estimates=False)
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


def former_default_parameters() -> tuple:
    """The scene's solver parameters as they were before the change (at 61294df): the
    integrator of a scene that names none was cvode."""
    import dataclasses

    from rodsim.core.scene import SOLVER_PARAMETERS

    return tuple(dataclasses.replace(p, default="cvode") if p.name == "integrator" else p
                 for p in SOLVER_PARAMETERS)


def test_a_study_begun_under_the_cvode_default_resumes_with_cvode(tmp_path, monkeypatch):
    """A study of a scene that names no integrator, started when that meant cvode, was
    refused on resume ("a different study definition": its stored base scene says cvode,
    the same scene resolves to static now). It resumes with cvode, the integrator its
    points were started with: the point it runs again equals the one it ran then, bit for
    bit, and the archive's spec says cvode. The old parts folder is written by the study
    runner itself with the former default in place (``former_default_parameters``), then
    one point's record removed: a study stopped part-way."""
    import json

    import rodsim.core.scene
    from rodsim.app.study import Study, Sweep
    from rodsim.app.study_parts import parts_folder
    from rodsim.app.study_runner import run_study

    study = Study(name="implicit_default_resume", title="t", paper="tests only",
                  scene=str(SCENE), integrator=None, reference=None,
                  sweeps={"small": [Sweep("nodes", "rods.wire.nodes", (9, 11), "1", "N")],
                          "full": [Sweep("nodes", "rods.wire.nodes", (9, 11), "1", "N")]})
    output = tmp_path / "study.nc"
    with monkeypatch.context() as old:
        old.setattr(rodsim.core.scene, "SOLVER_PARAMETERS", former_default_parameters())
        assert json.loads(study.spec("small").base_scene_json)["solver"]["integrator"] \
            == "cvode"
        run_study(study, "small", output, workers=1, keep_parts=True)
    parts = parts_folder(output)
    last = sorted(parts.glob("point-*.json"))[-1]
    ran_then = json.loads(last.read_text())
    last.unlink()
    output.unlink()
    assert json.loads(study.spec("small").base_scene_json)["solver"]["integrator"] == "static"

    notes: list[str] = []
    resumed = run_study(study, "small", output, workers=1, keep_parts=True, log=notes.append)
    assert any("resumes with 'cvode'" in note for note in notes), notes
    assert json.loads(json.loads(resumed.attrs["spec_json"])["base_scene_json"])[
        "solver"]["integrator"] == "cvode"
    ran_now = json.loads(last.read_text())
    assert ran_now["status"] == ran_then["status"] == 0, ran_now["message"]
    assert ran_now["tip"] == ran_then["tip"] and ran_now["centerline"] == ran_then["centerline"]
    assert abs(-ran_now["tip"]["wire"][1] - beam_deflection()) < BEAM * beam_deflection()


def test_a_study_whose_scene_names_its_integrator_is_still_refused_when_it_changes(
        tmp_path, monkeypatch):
    """Only the implicit default is carried over: a base scene file that names cvode, then
    static, is a different study definition, as before."""
    import pytest

    from rodsim.app.study import Study, Sweep
    from rodsim.app.study_parts import parts_folder
    from rodsim.app.study_runner import run_study
    from rodsim.app.study_spec import StudyError

    scene = tmp_path / "named.toml"
    scene.write_text(SCENE.read_text() + '\n[solver]\nintegrator = "cvode"\n')
    study = Study(name="named_resume", title="t", paper="tests only", scene=str(scene),
                  integrator=None, reference=None,
                  sweeps={"small": [Sweep("nodes", "rods.wire.nodes", (9, 11), "1", "N")],
                          "full": [Sweep("nodes", "rods.wire.nodes", (9, 11), "1", "N")]})
    output = tmp_path / "study.nc"
    run_study(study, "small", output, workers=1, keep_parts=True)
    sorted(parts_folder(output).glob("point-*.json"))[-1].unlink()
    output.unlink()
    scene.write_text(SCENE.read_text() + '\n[solver]\nintegrator = "static"\n')
    with pytest.raises(StudyError, match="different study definition"):
        run_study(study, "small", output, workers=1, keep_parts=True)


def test_run_and_a_tracks_step_0_agree_on_a_scene_with_obstacles_that_names_none():
    """`run` gives a scene with obstacles that names no integrator ida, `track` keeps static
    (docs/contact.md, "Which integrator": measured to reach the same equilibria in less
    CPU, benchmarks/results/obstacle-track-integrator.md). A guard of that measurement: a
    polymer cantilever pressed onto a plane by its tip force (tests/test_contact_depth.py)
    — the two integrators' equilibria at step 0 agree, and the tip rests on the plane."""
    from tests.test_contact_depth import PLANE_Y, RADIUS, pressed

    scene = pressed(1.0)
    assert scene.solver.integrator == "ida"
    run = rodsim.solve(scene)
    assert run.success and run.integrator == "ida", run.message
    track = rodsim.track(scene, {"rods.c.tip_load.force[1]": [0.05, 0.04]}, estimates=False)
    assert track.complete and track.integrator == "static", track.message
    assert np.max(np.abs(track.tips()[0] - run.tip())) < 1e-9 * 0.1
    assert abs(run.tip()[1] + RADIUS - PLANE_Y) < 0.1 * RADIUS  # on the plane
