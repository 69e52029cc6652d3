"""Bad scene input through the CLI: exit code 2, one line on stderr naming the key, no
traceback, and nothing written."""

from __future__ import annotations

import pytest

BASE = """\
name = "base"
[rods.catheter]
length = 0.12
radius = 0.006
youngs_modulus = 5.9e6
stretch_modulus = 5.9e6
density = 11040.0
nodes = 8
clamp = "frame"
terms = ["stretch", "bend_twist", "centerline", "tip_load"]

[rods.catheter.centerline]
K_P = 1e4

[rods.catheter.tip_load]
mass = 0.05
"""

TWO_RODS = BASE + BASE.split("\n", 1)[1].replace("rods.catheter", "rods.second")


def edit(old: str, new: str, text: str = BASE) -> str:
    assert old in text
    return text.replace(old, new, 1)


# (id, scene text — None for a path that is no readable file, extra CLI args, key in message)
CASES = [
    ("unknown-top-level-key", 'colour = "red"\n' + BASE, [], "colour"),
    ("unknown-key-in-rod", edit("nodes = 8", "nodes = 8\nlenght = 0.1"), [],
     "rods.catheter.lenght"),
    ("wrong-type-length", edit("length = 0.12", 'length = "long"'), [],
     "rods.catheter.length"),
    ("negative-radius", edit("radius = 0.006", "radius = -0.006"), [], "rods.catheter.radius"),
    ("zero-length", edit("length = 0.12", "length = 0.0"), [], "rods.catheter.length"),
    ("too-few-nodes", edit("nodes = 8", "nodes = 2"), [], "rods.catheter.nodes"),
    ("zero-relative-penalty", edit("K_P = 1e4", "K_P_relative = 0.0"), [],
     "rods.catheter.centerline.K_P_relative"),
    ("two-units-one-penalty", edit("K_P = 1e4", "K_P = 1e4\nK_P_relative = 1e6"), [],
     "rods.catheter.centerline"),
    ("negative-penalty", edit("K_P = 1e4", "K_P = -1e4"), [], "rods.catheter.centerline.K_P"),
    ("nan-modulus", edit("youngs_modulus = 5.9e6", "youngs_modulus = nan"), [],
     "rods.catheter.youngs_modulus"),
    ("inf-density", edit("density = 11040.0", "density = inf"), [], "rods.catheter.density"),
    ("unknown-term", edit('"tip_load"]', '"tip_load", "magnetism"]'), [],
     "rods.catheter.terms"),
    ("parameters-for-unlisted-term", BASE + "\n[rods.catheter.gravity]\ngravity = 9.81\n", [],
     "rods.catheter.gravity"),
    ("unknown-clamp", edit('clamp = "frame"', 'clamp = "glue"'), [], "rods.catheter.clamp"),
    ("set-without-equals", BASE, ["--set", "nodes80"], "nodes80"),
    ("set-unknown-key", BASE, ["--set", "colour=3"], "colour"),
    ("set-ambiguous-key", TWO_RODS, ["--set", "nodes=12"], "nodes"),
    ("set-wrong-type", BASE, ["--set", "nodes=many"], "rods.catheter.nodes"),
    ("unknown-integrator-option", BASE + "\n[solver.cvode]\nbogus = 1\n", [],
     "solver.cvode.bogus"),
    ("set-unknown-integrator-option", BASE, ["--set", "solver.cvode.bogus=1"],
     "solver.cvode.bogus"),
    ("set-bad-integrator-choice", BASE, ["--set", "solver.cvode.formulation='sideways'"],
     "solver.cvode.formulation"),
    ("unknown-integrator-in-scene", BASE + '\n[solver]\nintegrator = "rk4"\n', [],
     "solver.integrator"),
    ("zero-tolerance", BASE + "\n[solver]\ntolerance = 0.0\n", [], "solver.tolerance"),
    ("negative-mass", edit("mass = 0.05", "mass = -0.05"), [], "rods.catheter.tip_load.mass"),
    ("missing-required-key", edit("youngs_modulus = 5.9e6\n", ""), [],
     "rods.catheter.youngs_modulus"),
    ("origin-wrong-length", edit("nodes = 8", "nodes = 8\norigin = [0.0, 0.0]"), [],
     "rods.catheter.origin"),
    ("no-rods", 'name = "empty"\n', [], "rods"),
    ("vanishing-length", edit("length = 0.12", "length = 1e-300"), [], "rods.catheter.length"),
    ("radius-not-below-length", edit("radius = 0.006", "radius = 0.5"), [],
     "rods.catheter.radius"),
    ("vanishing-density", BASE, ["--set", "density=1e-300"], "rods.catheter.density"),
    ("huge-tip-force", BASE, ["--set", "tip_load.force=[1e308, 1e308, 0]"],
     "rods.catheter.tip_load.force"),
    ("catheter-base-free", BASE, ["--set", "clamp='orientation'"], "rods.catheter.clamp"),
    ("base-unknown-key", BASE + "\n[rods.catheter.base]\ndepth = 0.01\n", [],
     "rods.catheter.base.depth"),
    ("base-insertion-nan", BASE, ["--set", "insertion=nan"], "rods.catheter.base.insertion"),
    ("base-rotation-text", BASE, ["--set", "rotation='left'"], "rods.catheter.base.rotation"),
    ("free-base-without-joint", BASE, ["--set", "clamp='free'"], "rods.catheter.clamp"),
    ("joint-to-missing-rod",
     edit('"tip_load"]', '"tip_load", "joint"]', edit('clamp = "frame"', 'clamp = "free"'))
     + '\n[rods.catheter.joint]\nrod = "shaft"\ns = 0.1\n', [], "rods.catheter.joint.rod"),
    ("support-beyond-the-rod", BASE + "\n[rods.catheter.supports.tip]\ns = 0.2\n", [],
     "rods.catheter.supports.tip.s"),
    ("invalid-toml", edit("nodes = 8", "nodes = = 8"), [], "scene.toml"),
    ("nonexistent-file", None, [], "missing.toml"),
    ("unreadable-file", None, [], "folder.toml"),
]


@pytest.mark.parametrize(("scene_text", "extra", "key"), [c[1:] for c in CASES],
                         ids=[c[0] for c in CASES])
def test_bad_scene_exits_2_with_one_line_naming_the_key(scene_text, extra, key, tmp_path,
                                                        capsys, request, cli):
    out = tmp_path / "out"
    out.mkdir()
    case = request.node.callspec.id
    if scene_text is not None:
        scene = tmp_path / "scene.toml"
        scene.write_text(scene_text, encoding="utf-8")
    elif case == "unreadable-file":
        scene = tmp_path / "folder.toml"
        scene.mkdir()  # exists but cannot be read as a file
    else:
        scene = tmp_path / "missing.toml"
    before = sorted(p.name for p in tmp_path.rglob("*"))

    code = cli(["run", str(scene), "--integrator", "static", "-o", str(out / "run.nc"),
                 *extra])
    captured = capsys.readouterr()
    stderr = captured.err.strip()
    assert code == 2, f"exit code {code}; stderr: {stderr!r}"
    assert stderr, "nothing on stderr"
    assert "\n" not in stderr, f"message is not one line: {stderr!r}"
    assert "Traceback" not in captured.err
    assert key in stderr, f"{key!r} not named in {stderr!r}"
    assert stderr.startswith("rodsim: error:")
    assert captured.out == ""
    assert list(out.iterdir()) == []
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


def test_every_case_is_distinct():
    assert len(CASES) >= 15
    assert len({c[0] for c in CASES}) == len(CASES)
    assert len({(c[1], tuple(c[2])) for c in CASES if c[1] is not None}) == sum(
        c[1] is not None for c in CASES)
