"""Scene input that used to escape the one-line error (issue 15, items 1, 5 and 13): names
that are paths, files that are no scene files, nesting that overflows the parser's stack, rod
names with a dot, empty term lists, scenes too large for memory, long echoed values, and
SciPy's singular-matrix warning."""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path

import pytest
import scipy.sparse.linalg as spla

import rodsim.app.api
import rodsim.core.memory
from rodsim.core.memory import BYTES_PER_NODE
from rodsim.core.schema import SHOWN_WIDTH, SceneError
from rodsim.io.archive import read_dataset

SCENE = """\
name = "{name}"
[rods.{rod}]
length = 0.12
radius = 0.006
youngs_modulus = 5.9e6
stretch_modulus = 5.9e6
density = 11040.0
nodes = 6
terms = {terms}
"""


def scene_text(name: str = "small", rod: str = "catheter",
               terms: str = '["stretch", "bend_twist", "centerline"]') -> str:
    return SCENE.format(name=name, rod=rod, terms=terms)


def one_line(capsys) -> str:
    """The single line on stderr of a refused input (no traceback, nothing on stdout)."""
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rodsim: error: "), captured.err
    assert captured.out == ""
    return lines[0]


def files_under(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.fixture
def sandbox(tmp_path, monkeypatch) -> Path:
    """A working folder two levels below ``tmp_path``, the current folder of the test, so
    that a name like ``../../x`` would land in ``tmp_path`` where the test can see it."""
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    return tmp_path


@pytest.mark.parametrize("name", ["../../via-set", "/abs/dir/ABS", "a/b", "..", ".hidden",
                                  "two\nlines", "nul\0byte", "", "x" * 101])
def test_a_scene_name_must_be_a_plain_file_stem(name, sandbox, cli, capsys):
    """Item 1: the default archive is named after the scene; a name with a path in it, a
    NUL or a newline is refused (exit 2) before anything runs, in a file and with --set."""
    before = files_under(sandbox)
    code = cli(["run", "--integrator", "static", "--set", "nodes=6", "--set",
                f"name={json.dumps(name)}"])
    assert code == 2
    assert "name = " in one_line(capsys)
    scene = sandbox / "scene.toml"
    scene.write_text(scene_text(name=json.dumps(name)[1:-1]), encoding="utf-8")
    assert cli(["run", str(scene), "--integrator", "static"]) == 2
    one_line(capsys)
    scene.unlink()
    assert files_under(sandbox) == before


def test_a_plain_scene_name_names_the_default_archive(sandbox, cli, capsys):
    """The rule's other side: a stem with '.', '+', '-' and '_' is accepted and written in
    the current folder's runs/."""
    assert cli(["run", "--integrator", "static", "--set", "nodes=6", "--set",
                'name="v1.2+rc_3-x"']) == 0
    capsys.readouterr()
    assert files_under(sandbox / "a" / "b") == ["runs", "runs/v1.2+rc_3-x-static.nc"]


def test_a_scene_file_that_is_not_utf8_text(tmp_path, cli, capsys):
    scene = tmp_path / "latin1.toml"
    scene.write_bytes(scene_text().replace("small", "caf\u00e9").encode("latin-1"))
    assert cli(["run", str(scene), "--integrator", "static", "-o",
                str(tmp_path / "x.nc")]) == 2
    assert "not UTF-8" in one_line(capsys)
    assert files_under(tmp_path) == ["latin1.toml"]


@pytest.mark.parametrize("where", ["file", "set"])
def test_deeply_nested_values_are_refused(where, tmp_path, cli, capsys):
    """Item 5: 100 000 nested brackets overflow tomllib's recursion (RecursionError)."""
    deep = "[" * 100_000 + "]" * 100_000
    if where == "file":
        scene = tmp_path / "deep.toml"
        scene.write_text(scene_text() + f"nested = {deep}\n", encoding="utf-8")
        argv = ["run", str(scene)]
    else:
        argv = ["run", "--set", f"nodes={deep}"]
    assert cli([*argv, "--integrator", "static", "-o", str(tmp_path / "x.nc")]) == 2
    line = one_line(capsys)
    assert "nested too deeply" in line and len(line) < 200, line
    assert not (tmp_path / "x.nc").exists()


def test_a_rod_name_with_a_dot(tmp_path, cli, capsys):
    """Item 5: rods."a.b" made `--set nodes=9` split the rod's name (KeyError)."""
    scene = tmp_path / "dotted.toml"
    scene.write_text(scene_text(rod='"a.b"'), encoding="utf-8")
    assert cli(["run", str(scene), "--integrator", "static", "--set", "nodes=9", "-o",
                str(tmp_path / "x.nc")]) == 2
    assert "rods.'a.b'" in one_line(capsys)


def test_an_empty_term_list(tmp_path, cli, capsys):
    scene = tmp_path / "empty.toml"
    scene.write_text(scene_text(terms="[]"), encoding="utf-8")
    assert cli(["run", str(scene), "--integrator", "static", "-o",
                str(tmp_path / "x.nc")]) == 2
    assert "rods.catheter.terms = []" in one_line(capsys)


@pytest.mark.parametrize("path", ["/dev/zero", "fifo", "big.toml"])
def test_scene_files_must_be_small_regular_files(path, tmp_path, cli, capsys):
    """Item 5: `rodsim run /dev/zero` read forever; a FIFO would wait for a writer; a file
    over 1 MiB is no scene file."""
    if path == "fifo":
        path = str(tmp_path / "fifo")
        os.mkfifo(path)
    elif path == "big.toml":
        path = str(tmp_path / "big.toml")
        Path(path).write_text(scene_text() + "#" * (1 << 20) + "\n", encoding="utf-8")
    assert cli(["run", path, "--integrator", "static", "-o", str(tmp_path / "x.nc")]) == 2
    line = one_line(capsys)
    assert "not a regular file" in line or "larger than 1024 KiB" in line, line


def test_a_nul_in_the_scene_path(tmp_path, cli, capsys):
    assert cli(["run", "scene\0.toml", "--integrator", "static"]) == 2
    assert "NUL" in one_line(capsys)


def test_a_scene_too_large_for_memory_is_refused_with_its_estimate(tmp_path, cli, capsys,
                                                                   monkeypatch):
    """Item 5: 20 rods × 200 000 nodes is refused before any allocation, saying the estimate
    (the machine's memory is set to 8 GB so that the test does not depend on it)."""
    monkeypatch.setattr(rodsim.core.memory, "physical_memory", lambda: 8 * 10**9)
    monkeypatch.setattr(rodsim.app.api, "Model", lambda scene: pytest.fail("model was built"))
    rods = "".join(scene_text(rod=f"rod{i}").split("\n", 1)[1].replace("nodes = 6",
                                                                        "nodes = 200000")
                   for i in range(20))
    scene = tmp_path / "huge.toml"
    scene.write_text('name = "huge"\n' + rods, encoding="utf-8")
    assert cli(["run", str(scene), "--integrator", "static", "-o",
                str(tmp_path / "x.nc")]) == 2
    line = one_line(capsys)
    estimate = 20 * 200_000 * BYTES_PER_NODE / 1e9
    assert f"{estimate:.3g} GB" in line and "8 GB" in line, line
    assert files_under(tmp_path) == ["huge.toml"]


def test_removing_a_term_with_set(tmp_path, cli, capsys):
    """Item 13: `--set terms=[…]` without tip_load was refused, blaming the default
    tip_load table; the removed term's table goes with it."""
    output = tmp_path / "unloaded.nc"
    code = cli(["run", "--integrator", "static", "--set", "nodes=6", "--set",
                'terms=["stretch", "bend_twist", "centerline"]', "-o", str(output)])
    assert code == 0, capsys.readouterr().err
    scene = json.loads(read_dataset(output).attrs["scene_json"])["rods"]["catheter"]
    assert scene["terms"] == ["stretch", "bend_twist", "centerline"]
    assert "tip_load" not in scene


def test_a_term_table_in_the_scene_file_still_needs_its_term(tmp_path, cli, capsys):
    """Only --set's removal drops tables: a file that gives parameters of an unlisted term
    is still refused (the rule of the scene format)."""
    scene = tmp_path / "table.toml"
    scene.write_text(scene_text() + "[rods.catheter.tip_load]\nmass = 0.05\n",
                     encoding="utf-8")
    assert cli(["run", str(scene), "--integrator", "static", "-o",
                str(tmp_path / "x.nc")]) == 2
    assert "rods.catheter.tip_load" in one_line(capsys)


@pytest.mark.parametrize("value", ["1e300", "'" + "x" * 500 + "'", "[" + "1," * 300 + "1]"])
def test_echoed_values_are_capped(value, cli, capsys):
    """Item 13: `--set nodes=1e300` printed a 392-character line."""
    assert cli(["run", "--integrator", "static", "--set", f"nodes={value}"]) == 2
    line = one_line(capsys)
    assert "rods.catheter.nodes" in line
    echoed = line.split(" = ", 1)[1].split(": ", 1)[0]
    assert len(echoed) <= SHOWN_WIDTH, echoed


def test_a_singular_jacobian_is_a_diagnosed_failure_without_scipy_warning(tmp_path, cli,
                                                                          capsys):
    """Item 13: a rod with only its tip load has a singular Jacobian; SciPy's
    MatrixRankWarning must not leak: the run is a solver failure (exit 1), one line."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code = cli(["run", "--integrator", "static", "--set", "nodes=6", "--set",
                    'terms=["tip_load"]', "-o", str(tmp_path / "x.nc")])
    assert code == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rodsim: solver failure:"), err
    assert not [w for w in caught if issubclass(w.category, spla.MatrixRankWarning)]
    assert not (tmp_path / "x.nc").exists()


def test_control_characters_in_keys_stay_on_one_line(tmp_path, cli, capsys):
    """Found by the fuzz suite: a top-level key "\\r" printed a carriage return, which
    splits the message; keys and paths are shown escaped."""
    scene = tmp_path / "cr.toml"
    scene.write_text('"\\r" = 1\n' + scene_text(), encoding="utf-8")
    assert cli(["run", str(scene), "--integrator", "static", "-o",
                str(tmp_path / "x.nc")]) == 2
    assert "\\r: unknown top-level key" in one_line(capsys)
    odd = tmp_path / "two\nlines.toml"
    odd.write_text("not = = toml", encoding="utf-8")
    assert cli(["run", str(odd), "--integrator", "static", "-o",
                str(tmp_path / "x.nc")]) == 2
    assert "not valid TOML" in one_line(capsys)


def test_an_integrator_option_the_scene_does_not_hold_can_be_set_by_its_full_key():
    """The scene keeps [solver.<integrator>] tables as written, so an option the file does
    not set is absent; Scene.with_overrides still accepts its full key, and load_scene's check
    validates the value (found while reviewing: the full key was refused as unknown)."""
    scene = rodsim.load_scene("table1-50g")
    assert "rtol" not in scene.data["solver"].get("cvode", {})
    assert scene.with_overrides(["solver.cvode.rtol=1e-6"]).data["solver"]["cvode"] == {
        "rtol": 1e-6}
    with pytest.raises(SceneError, match="solver.cvode.rtol"):
        rodsim.load_scene(scene.with_overrides(["solver.cvode.rtol=-1"]))
