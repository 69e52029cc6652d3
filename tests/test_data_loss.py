"""Nothing lost when work stops (issue 37, item 5): a track stopped by Ctrl-C, SIGTERM or a
failed step keeps its finished steps in an archive marked incomplete; SIGTERM ends every
scene command as Ctrl-C does ("rodsim: interrupted", exit 130); and every archive rodsim
writes, it reads (a resolved scene larger than the reader's old 4 MiB bound)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rodsim
from rodsim.app.interrupted import Interrupted
from rodsim.core.scene import Scene
from rodsim.io.archive import read_dataset, write_content
from rodsim.io.run_dataset import run_content

ROOT = Path(__file__).resolve().parents[1]
#: A light cantilever loaded step by step (12 nodes: fast).
SCENE = ["table1-50g", "--set", "nodes=12"]
RAMP = "tip_load.mass=0:0.05:40"


def _child(code: str, argv: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """Run the CLI in a child process after ``code`` (which patches it)."""
    script = (f"import sys\n{code}\nfrom rodsim.app.cli.main import main\n"
              f"sys.exit(main({argv!r}))\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-c", script], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def test_a_track_stopped_by_ctrl_c_keeps_its_finished_steps():
    """Ctrl-C in the middle of a track: the steps done come back on the exception, equal to
    an uninterrupted track's first steps (before, a plain KeyboardInterrupt lost them)."""
    scene = rodsim.load_scene("table1-50g", ["nodes=12"])
    ramps = {"tip_load.mass": np.linspace(0, 0.05, 12)}
    whole = rodsim.track(scene, ramps, estimates=False)

    def stop(fraction, status):
        if status.endswith("step 7/11"):
            raise KeyboardInterrupt

    with pytest.raises(Interrupted) as caught:
        rodsim.track(scene, ramps, progress=stop)
    assert isinstance(caught.value, KeyboardInterrupt)  # code that does not know it
    partial = caught.value.partial
    assert partial.steps == 8 and partial.interrupted and not partial.success
    assert not partial.complete and whole.complete
    assert np.array_equal(partial.positions, whole.positions[:8])
    stored = partial.to_xarray()
    assert stored.attrs["complete"] == 0 and stored.sizes["step"] == 8
    assert "interrupted" in stored.attrs["message"]


@pytest.mark.slow  # a rodsim track process of 39 steps, then the same track in process: ~6 s
def test_sigterm_during_a_track_writes_the_finished_steps_and_exits_130(tmp_path):
    """The issue: Ctrl-C (here SIGTERM, sent when the progress line reports step 25 of 39)
    after most steps wrote nothing. Now the finished steps are archived, marked incomplete;
    `rerun` and `plot` read the archive."""
    code = ("import os, signal\nfrom rodsim.app import progress\n"
            "def report(self, fraction, status):\n"
            "    if status.endswith('step 25/39'):\n"
            "        os.kill(os.getpid(), signal.SIGTERM)\n"
            "progress.ProgressPrinter.__call__ = report")
    done = _child(code, ["track", *SCENE, "--ramp", RAMP, "-o", "t.nc"], tmp_path)
    assert done.returncode == 130, done.stderr
    assert done.stderr.splitlines()[-1] == "rodsim: interrupted"
    assert "Traceback" not in done.stderr
    stored = read_dataset(tmp_path / "t.nc")
    assert stored.attrs["complete"] == 0 and stored.attrs["success"] == 0
    assert stored.sizes["step"] == 26
    whole = rodsim.track(rodsim.load_scene("table1-50g", ["nodes=12"]),
                         {"tip_load.mass": np.linspace(0, 0.05, 40)}, estimates=False)
    assert np.array_equal(stored["position"].values, whole.positions[:26])
    from rodsim.app.cli import main

    assert main(["rerun", str(tmp_path / "t.nc")]) == 0
    assert main(["plot", str(tmp_path / "t.nc"), "-o", str(tmp_path / "drawn")]) == 0


@pytest.mark.parametrize("command", [
    ["run", "table1-50g", "--set", "nodes=12"],
    ["track", *SCENE, "--ramp", RAMP],
    pytest.param(["fit", "table1-50g", "--set", "nodes=12", "--data", "DATA", "--param",
                  "youngs_modulus"], marks=pytest.mark.slow),
    pytest.param(["reach", "table1-50g", "--set", "nodes=12", "--tip", "0.1,-0.05,0",
                  "--actuate", "tip_load.force[0]", "--actuate", "tip_load.force[1]"],
                 marks=pytest.mark.slow),
])
def test_sigterm_ends_every_scene_command_as_ctrl_c_does(command, tmp_path):
    """SIGTERM during the solve of run, track, fit and reach: "rodsim: interrupted" and exit
    130, as docs/reliability.md promises (before: killed by the signal, nothing said). Each
    is a new process (~2 s of CPU to import): run and track every time, fit and reach with
    the slow tests."""
    data = tmp_path / "data.csv"
    data.write_text("x,y,z\n0.05,-0.005,0\n0.1,-0.02,0\n")
    argv = [str(data) if word == "DATA" else word for word in command] + ["-o", "out.nc"]
    code = ("import os, signal, time\nfrom rodsim.app.cli import pipeline\n"
            "def solve(self, scene, integrator, progress):\n"
            "    os.kill(os.getpid(), signal.SIGTERM)\n"
            "    time.sleep(60)\n"
            "pipeline.SceneCommand.solve = solve\n"
            "from rodsim.app.cli import run, track, fit, reach\n"
            "for cls in (run.Run, track.Track, fit.Fit, reach.Reach):\n"
            "    cls.solve = solve")
    done = _child(code, argv, tmp_path)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip().splitlines() == ["rodsim: interrupted"]
    assert not (tmp_path / "out.nc").exists()


def test_a_track_that_fails_at_step_k_writes_the_steps_before(tmp_path, capsys, cli):
    """A solver failure at step 2 wrote nothing; now steps 0 and 1 are archived, marked
    incomplete, and the exit is still 1 with the failure named."""
    output = tmp_path / "t.nc"
    code = cli(["track", "table3-catheter1", "--set", "catheter.nodes=12", "--set",
                "tendon.nodes=6", "--ramp", "tendon_actuation.force=0.5:5000:3", "-o",
                str(output)])
    assert code == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "solver failure" in err[0] and "step 1" in err[0]
    assert "incomplete" in err[0]
    stored = read_dataset(output)
    assert stored.sizes["step"] == 1
    assert stored.attrs["complete"] == 0 and stored.attrs["success"] == 0
    assert "step 1" in stored.attrs["message"]


def test_a_complete_track_says_so(tmp_path, cli, capsys):
    assert cli(["track", *SCENE, "--ramp", "tip_load.mass=0:0.05:3", "-o",
                str(tmp_path / "t.nc")]) == 0, capsys.readouterr().err
    assert read_dataset(tmp_path / "t.nc").attrs["complete"] == 1


def test_what_rodsim_writes_it_reads_a_large_resolved_scene(tmp_path, cli, capsys):
    """A vessel of 400 000 csv points made a 10 MB scene_json that `run` wrote and `rerun`
    and `plot` refused (the reader's 4 MiB bound). Here a scene as large (its description
    padded to 10 MB, which is cheap to solve) is solved, written, read, re-run and plotted;
    one beyond the reader's bound is not written, and `rodsim` refuses such a scene before
    any work."""
    from rodsim.app.cli.common import UserError
    from rodsim.app.cli.pipeline import check_archivable
    from rodsim.io import archive_schema

    data = json.loads(rodsim.load_scene("table1-50g", ["nodes=8"]).to_json())
    data["description"] = "a vessel's worth of text " * 400_000
    scene = Scene.from_dict(data)
    assert len(scene.to_json()) > 10 * 10 ** 6
    check_archivable(scene)
    result = rodsim.solve(scene, "static")
    write_content(run_content(result), tmp_path / "big.nc")  # as `rodsim run` writes
    assert len(read_dataset(tmp_path / "big.nc").attrs["scene_json"]) > 10 * 10 ** 6
    assert cli(["rerun", str(tmp_path / "big.nc")]) == 0, capsys.readouterr().err
    assert cli(["plot", str(tmp_path / "big.nc"), "-o", str(tmp_path / "drawn")]) == 0

    data["description"] = "x" * (archive_schema.MAX_JSON_CHARS + 1)
    with pytest.raises(UserError, match="too large for an archive"):
        check_archivable(Scene.from_dict(data))
