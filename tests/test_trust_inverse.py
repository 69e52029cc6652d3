"""The trust estimate beyond ``run`` (issue 22): ``track`` (its last step), ``fit`` and
``reach`` print the penalty-error estimate and the tendon-compression check and store them in
their archives, as ``run`` does (rodsim/app/trust.py).

Each archived estimate is checked against the estimate of an independent cold static solve
of the scene at the values the command ended with.
"""

from __future__ import annotations

import json

import pytest

import rodsim
from rodsim.app.cli import main
from rodsim.app.trust import penalty_error
from rodsim.io.archive import read_dataset

SMALL = ["--set", "nodes=6"]


def _cold_estimate(scene: str, overrides: list[str]) -> float:
    result = rodsim.solve(scene, "static", overrides=overrides)
    assert result.success, result.message
    return penalty_error(result).error


def test_track_prints_and_archives_the_last_steps_penalty_error(tmp_path, capsys):
    out = tmp_path / "track.nc"
    assert main(["track", "table1-50g", *SMALL, "--ramp", "tip_load.mass=0.05:0.08:3",
                 "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "penalty     last step: error ≈" in printed
    archived = read_dataset(out).attrs["penalty_error"]
    expected = _cold_estimate("table1-50g", ["nodes=6", "tip_load.mass=0.08"])
    assert expected > 0.0
    assert archived == pytest.approx(expected, rel=1e-3)


def test_fit_and_reach_print_and_archive_the_penalty_error(tmp_path, capsys):
    run = tmp_path / "run.nc"
    assert main(["run", "table1-50g", "--integrator", "static", *SMALL, "-o", str(run)]) == 0
    nodes = read_dataset(run)["position"].values
    data = tmp_path / "data.csv"
    data.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.17g}" for v in p) for p in nodes))
    capsys.readouterr()
    for kind, extra in (
            ("fit", ["--data", str(data), "--param", "youngs_modulus"]),
            ("reach", ["--tip", f"{nodes[-1, 0]},{nodes[-1, 1] + 1e-4},0",
                       "--actuate", "tip_load.force[1]", "--tolerance", "1e-3"])):
        out = tmp_path / f"{kind}.nc"
        assert main([kind, "table1-50g", *SMALL, *extra, "-o", str(out)]) == 0
        assert "penalty     error ≈" in capsys.readouterr().out, kind
        archive = read_dataset(out)
        # the scene at the values found, solved cold: the same estimate
        scene = json.loads(archive.attrs["scene_json"])
        cold = rodsim.solve(scene, "static")
        assert cold.success, cold.message
        assert archive.attrs["penalty_error"] == pytest.approx(penalty_error(cold).error,
                                                               rel=1e-3), kind


def test_track_warns_when_its_last_step_has_a_compressed_tendon(tmp_path, capsys):
    """The issue's user scene with the paper coupling and the penalties of then: its tendons
    push (tests/test_user_robot.py), and its equilibria are unstable (kept with
    --allow-unstable); a track of the +y force says so and archives it."""
    from pathlib import Path

    scene = tmp_path / "paper.toml"
    text = (Path(__file__).parent / "data" / "user-two-tendon.toml").read_text()
    text = text.replace('offset = 0.0035\n', 'offset = 0.0035\ncoupling = "paper"\n')
    for name in ("tendon_y", "tendon_z"):
        text += (f"\n[tendons.{name}.lumen]\nK_L = 1000.0\n"
                 f"[tendons.{name}.endpoint_compliance]\nK_E = 1500.0\n"
                 f"[tendons.{name}.endpoint_coupling]\nK_C = 1e5\n")
    scene.write_text(text)
    out = tmp_path / "track.nc"
    assert main(["track", str(scene), "--set", "catheter.nodes=15", "--set",
                 "tendon_y.nodes=8", "--set", "tendon_z.nodes=8", "--ramp",
                 "tendons.tendon_y.tendon_actuation.force=1:1.5:2", "--allow-unstable", "-o",
                 str(out)]) == 0
    printed = capsys.readouterr().out
    assert "tendon tendon_y is in compression" in printed
    assert "tendon_y" in json.loads(read_dataset(out).attrs["tendon_compression"])
