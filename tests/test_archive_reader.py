"""The one validating archive reader (issue 23, items 4 and 5): every archive kind's own
fields checked, sizes bounded, byte-level damage and special files refused in one line with
exit 2 — never a traceback, a hang or a recomputation of steps that were never stored."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

from rodsim.app.cli import main
from rodsim.app.study import Study, Sweep
from rodsim.app.study_runner import run_study
from rodsim.io.archive import read_dataset, write_dataset
from rodsim.io.cf_layout import key_variable

TINY = Study(name="reader_test", title="two points", paper="tests only",
             scene="table1-50g", integrator="static", reference=None,
             sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (6, 7), "1", "N")]})


@pytest.fixture(scope="module")
def archives(tmp_path_factory) -> dict[str, Path]:
    """One archive of each kind rodsim writes (small and cheap), written once."""
    from rodsim.app.cli import main

    folder = tmp_path_factory.mktemp("kinds")
    small = ["--set", "nodes=6"]
    paths = {kind: folder / f"{kind}.nc" for kind in ("run", "track", "fit", "reach",
                                                        "study")}
    assert main(["run", "--integrator", "static", *small, "-o", str(paths["run"])]) == 0
    assert main(["track", "table1-50g", *small, "--ramp", "tip_load.mass=0.05:0.06:3",
                 "-o", str(paths["track"])]) == 0
    data = folder / "data.csv"
    nodes = read_dataset(paths["run"])["position"].values
    data.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.17g}" for v in p) for p in nodes))
    assert main(["fit", "table1-50g", *small, "--data", str(data), "--param",
                 "youngs_modulus", "-o", str(paths["fit"])]) == 0
    assert main(["reach", "table1-50g", *small, "--tip", f"{nodes[-1, 0]},"
                 f"{nodes[-1, 1] + 1e-4},0", "--actuate", "tip_load.force[1]", "--tolerance",
                 "1e-3", "-o", str(paths["reach"])]) == 0
    run_study(TINY, "small", paths["study"], workers=1)
    return paths


def one_line(capsys) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rodsim: error: "), captured.err
    return lines[0]


def changed(archives, kind: str, path: Path, change) -> str:
    ds = read_dataset(archives[kind])
    out = change(ds)
    write_dataset(out if isinstance(out, xr.Dataset) else ds, path)
    return str(path)


def setattr_(name, value):
    return lambda ds: ds.attrs.__setitem__(name, value)


def first_parameter(ds: xr.Dataset) -> str:
    key = "fit_parameters" if ds.attrs["kind"] == "fit" else "reach_parameters"
    return json.loads(ds.attrs[key])[0]


def nested(depth: int) -> str:
    return '{"a": ' * depth + "1" + "}" * depth


TAMPERS = {
    # a kind set on an archive without its fields (the example)
    ("run", "kind fit on a run"): setattr_("kind", "fit"),
    ("run", "kind reach on a run"): setattr_("kind", "reach"),
    ("run", "kind track on a run"): setattr_("kind", "track"),
    ("run", "kind is a number"): setattr_("kind", 3),
    ("fit", "no data_position"): lambda ds: ds.drop_vars("data_position"),
    ("fit", "no matched_position"): lambda ds: ds.drop_vars("matched_position"),
    ("fit", "fit_parameters not JSON"): setattr_("fit_parameters", "[youngs"),
    ("fit", "fit_parameters empty"): setattr_("fit_parameters", "[]"),
    ("fit", "fit_parameters names a missing variable"): setattr_("fit_parameters", '["E"]'),
    ("fit", "no standard error"): lambda ds: ds.drop_vars(
        key_variable(ds, first_parameter(ds), "standard_error").name),
    ("fit", "no residual_rms"): lambda ds: ds.attrs.pop("residual_rms"),
    ("fit", "residual_rms is text"): setattr_("residual_rms", "small"),
    ("fit", "data NaN"): lambda ds: ds["data_position"].values.__setitem__(0, np.nan),
    ("reach", "no target"): lambda ds: ds.drop_vars("target"),
    ("reach", "no tip_reached"): lambda ds: ds.drop_vars("tip_reached"),
    ("reach", "reach_parameters a dict"): setattr_("reach_parameters", '{"a": 1}'),
    ("reach", "no distance"): lambda ds: ds.attrs.pop("distance"),
    ("reach", "distance is text"): setattr_("distance", "near"),
    ("track", "ramp_json 200000 values"): lambda ds: ds.attrs.__setitem__(
        "ramp_json", json.dumps({k: list(np.linspace(0.05, 0.06, 200_000))
                                 for k in json.loads(ds.attrs["ramp_json"])})),
    ("track", "ramp coordinate edited"): lambda ds: key_variable(ds, next(iter(json.loads(
        ds.attrs["ramp_json"])))).values.__setitem__(0, 1.0),
    ("track", "ramp_json a list"): setattr_("ramp_json", "[1, 2]"),
    ("run", "a 2 MB title"): setattr_("title", "t" * 2_000_000),
    ("track", "a 2 MB title"): setattr_("title", "t" * 2_000_000),
    ("run", "a 2 MB long_name"): lambda ds: ds["position"].attrs.__setitem__(
        "long_name", "p" * 2_000_000),
    ("run", "integrator_options 40 levels deep"): setattr_("integrator_options", nested(40)),
    ("study", "spec_json 40 levels deep"): lambda ds: ds.attrs.__setitem__(
        "spec_json", ds.attrs["spec_json"][:-1] + ', "deep": ' + nested(40) + "}"),
}


@pytest.mark.parametrize("command", ["rerun", "plot"])
@pytest.mark.parametrize(("kind", "case"), list(TAMPERS))
def test_a_tampered_archive_of_any_kind_is_one_line_and_exit_2(command, kind, case, archives,
                                                               tmp_path, cli, capsys):
    path = changed(archives, kind, tmp_path / "tampered.nc", TAMPERS[kind, case])
    before = sorted(p.name for p in tmp_path.iterdir())
    assert cli([command, path]) == 2
    assert "tampered.nc" in one_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_every_kind_rodsim_writes_is_read_plotted_and_rerun(archives, tmp_path, cli, capsys):
    for kind, path in archives.items():
        assert cli(["plot", str(path), "-o", str(tmp_path / kind), "--format", "png"]) == 0
        if kind != "study":
            assert cli(["rerun", str(path), "--tolerance", "1e-6"]) == 0, (
                kind, capsys.readouterr().err)
    capsys.readouterr()


def test_rerun_of_a_track_recomputes_only_its_stored_steps(archives, tmp_path, cli, capsys):
    """A ramp_json longer than the stored steps made rerun recompute every planned step
    (200 000); a track stopped early (an unstable step) stores fewer steps than it plans.
    The rerun re-runs the stored ones."""
    def longer(ds):
        ds.attrs["ramp_json"] = json.dumps({k: v + list(np.linspace(0.06, 0.1, 50))
                                            for k, v in json.loads(ds.attrs["ramp_json"])
                                            .items()})
    path = changed(archives, "track", tmp_path / "longer.nc", longer)
    assert cli(["rerun", path]) == 0
    assert "re-ran 3 steps" in capsys.readouterr().out


def test_rerun_of_a_track_compares_integrator_options(archives, tmp_path, cli, capsys):
    def options(ds):
        stored = json.loads(ds.attrs["integrator_options"])
        stored[next(iter(stored))] = 12345
        ds.attrs["integrator_options"] = json.dumps(stored)
    path = changed(archives, "track", tmp_path / "options.nc", options)
    assert cli(["rerun", path]) == 2
    assert "integrator_options" in one_line(capsys)


def damage(source: Path, target: Path, offset: int, count: int = 64) -> None:
    data = bytearray(source.read_bytes())
    rng = np.random.default_rng(offset)
    offset %= len(data)
    data[offset:offset + count] = rng.integers(0, 256, min(count, len(data) - offset),
                                               dtype=np.uint8).tobytes()
    target.write_bytes(bytes(data))


@pytest.mark.parametrize("kind", ["run", "track", "fit", "reach", "study"])
def test_damaged_bytes_are_never_a_traceback(kind, archives, tmp_path, cli, capsys):
    """64 damaged bytes gave an AttributeError in rerun and plot. Damage at spread offsets
    (the header, the HDF5 structures, the data): one line and exit 2, or — where the damage
    lands in numbers the contract allows — a result (exit 0 or 1), never an exception."""
    source = archives[kind]
    size = source.stat().st_size
    for i, offset in enumerate([0, 8, 100, 600, 2000, size // 3, size // 2, size - 200]):
        path = tmp_path / f"damaged{i}.nc"
        damage(source, path, offset)
        for command in (["plot", str(path), "-o", str(tmp_path / f"fig{i}"), "--format",
                         "png"], ["rerun", str(path)]):
            if kind == "study" and command[0] == "rerun":
                continue  # a study rerun re-runs its points: covered by the fuzz suite
            code = cli(command)
            err = capsys.readouterr().err
            assert code in (0, 1, 2), (offset, command[0])
            if code == 2:
                assert len(err.strip().splitlines()) == 1, err


def test_a_text_scale_factor_is_one_line(archives, tmp_path, cli, capsys):
    """A text `scale_factor` on a variable raised UFuncNoLoopError in rerun and plot."""
    path = tmp_path / "scaled.nc"
    path.write_bytes(archives["run"].read_bytes())
    with netCDF4.Dataset(path, "a") as nc:
        nc["position"].setncattr("scale_factor", "two")
    for command in ("rerun", "plot"):
        assert cli([command, str(path)]) == 2
        assert "scaled.nc" in one_line(capsys)


def test_a_study_in_which_every_point_failed_is_one_line_for_plot(tmp_path, cli, capsys):
    """rodsim writes such archives itself; plot raised IndexError (error_vs_parameter)."""
    study = Study(name="failing_test", title="failing", paper="tests only",
                  scene="table1-50g", integrator="static", reference="paper",
                  plot="error_vs_parameter", overrides=("solver.max_wall_time=1e-9",),
                  sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (6, 7), "1", "N")]})
    run_study(study, "small", tmp_path / "failed.nc", workers=1)
    assert cli(["plot", str(tmp_path / "failed.nc")]) == 2
    assert "every one of the 2 points" in one_line(capsys)


def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """The real CLI in a subprocess (a FIFO blocked the old reader for good: a timeout)."""
    return subprocess.run([sys.executable, "-m", "rodsim.app.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "OMP_NUM_THREADS": "1"})


@pytest.mark.slow  # six fresh rodsim processes: ~8 s of CPU
def test_special_files_are_refused_before_they_are_opened(tmp_path):
    """`fit --data`, `rerun` and `plot` blocked forever on a FIFO; `fit --data /dev/zero`
    ran out of memory. Each is one line, exit 2, at once."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    cases = [("rerun", str(fifo)), ("plot", str(fifo)),
             ("fit", "table1-50g", "--data", str(fifo), "--param", "youngs_modulus"),
             ("fit", "table1-50g", "--data", "/dev/zero", "--param", "youngs_modulus"),
             ("rerun", "/dev/zero"), ("plot", str(tmp_path))]
    for case in cases:
        extra = ("-o", str(tmp_path / "out.nc")) if case[0] == "fit" else ()
        done = run_cli(*case, *extra, cwd=tmp_path)
        assert done.returncode == 2, (case, done.stderr)
        lines = done.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("rodsim: error: "), done.stderr
        assert "regular file" in lines[0] or "folder" in lines[0], lines[0]


def _read_in_a_fresh_process(script: str) -> subprocess.CompletedProcess:
    """``script`` run by a fresh single-threaded interpreter (the probe of
    rodsim.io.archive forks only there)."""
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120, env={**os.environ, "OMP_NUM_THREADS": "1"})


def test_bytes_that_hang_the_netcdf_library_are_one_line_and_exit_2(tmp_path):
    """tests/data/damaged-fit-archive.nc is a fit archive with 20 zero bytes at offset 3461
    (a case the fuzz suite found): netCDF/HDF5 reads it forever. ``rerun`` refuses it in one
    line after the probe's limit instead of hanging: the rodsim command's whole process
    (``entry``, as ``python -m rodsim.app.cli`` runs it), with the limit at 1 s instead of 10
    (the child reading the file spun for all of them)."""
    damaged = Path(__file__).parent / "data" / "damaged-fit-archive.nc"
    done = subprocess.run([sys.executable, "-c", f"""
import sys
import rodsim.io.archive as archive
archive.PROBE_SECONDS = 1.0
sys.argv = ["rodsim", "rerun", {str(damaged)!r}]
from rodsim.app.cli import entry
entry()
"""], capture_output=True, text=True, timeout=120, cwd=tmp_path,
                          env={**os.environ, "OMP_NUM_THREADS": "1"})
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and "still reading it after 1 s" in done.stderr, (
        done.stderr)


@pytest.mark.parametrize(("behaviour", "message"), [
    ("os.abort()", "crashed reading it (signal 6)"),
    ("time.sleep(3600)", "still reading it after 1 s"),
])
def test_a_library_that_aborts_or_hangs_on_a_file_is_an_archive_error(tmp_path, behaviour,
                                                                       message):
    """The probe turns a C-level abort or an endless read into an ArchiveError: the child's
    open is replaced by one that aborts or sleeps (the fork inherits the replacement)."""
    path = tmp_path / "run.nc"
    assert main(["run", "--integrator", "static", "--set", "nodes=6", "-o", str(path)]) == 0
    done = _read_in_a_fresh_process(f"""
import os, time
import xarray
import rodsim.io.archive as archive
archive.PROBE_SECONDS = 1.0
def broken(*args, **kwargs):
    {behaviour}
xarray.open_dataset = broken
try:
    archive.read_dataset({str(path)!r})
except archive.ArchiveError as exc:
    print(exc)
""")
    assert done.returncode == 0, done.stderr
    assert message in done.stdout, done.stdout


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")
def test_a_probe_child_outlives_no_killed_parent(tmp_path):
    """A parent killed while its probe child hangs in the library (the child's open replaced
    by one that records its pid and sleeps) leaves no reader behind: the child ends itself
    a second after the probe's limit. Before, it spun on for ever (found after a killed
    test run: the damaged-archive child at full CPU for minutes)."""
    path = tmp_path / "run.nc"
    assert main(["run", "--integrator", "static", "--set", "nodes=6", "-o", str(path)]) == 0
    marker = tmp_path / "child.pid"
    parent = subprocess.Popen([sys.executable, "-c", f"""
import os, time
import xarray
import rodsim.io.archive as archive
archive.PROBE_SECONDS = 2.0
def hang(*args, **kwargs):
    with open({str(marker)!r}, "w") as f:
        f.write(str(os.getpid()))
    time.sleep(3600)
xarray.open_dataset = hang
archive.read_dataset({str(path)!r})
"""], env={**os.environ, "OMP_NUM_THREADS": "1"})
    try:
        for _ in range(600):
            if marker.exists() and marker.read_text():
                break
            time.sleep(0.05)
        child = int(marker.read_text())
    finally:
        parent.kill()
        parent.wait()

    def alive(pid: int) -> bool:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (FileNotFoundError, ProcessLookupError):
            return False
        return state != "Z"

    assert alive(child)  # the parent died first: the child was still reading
    for _ in range(200):  # its own end: 3 s after it began, within 10 s
        if not alive(child):
            break
        time.sleep(0.05)
    assert not alive(child), f"the probe child {child} outlived its killed parent"


def test_a_probe_that_aborts_prints_no_fault_handler_dump(tmp_path):
    """With a fault handler on (pytest enables one on its own copy of stderr, as does
    `python -X faulthandler`), the probe child's abort printed "Fatal Python error: Aborted"
    and the stacks of the process on that copy, which redirecting stderr in the child does
    not reach: the suite's passing run showed the dump of the deliberate crash above. The
    child turns the handler off; the abort is still the one-line ArchiveError."""
    path = tmp_path / "run.nc"
    assert main(["run", "--integrator", "static", "--set", "nodes=6", "-o", str(path)]) == 0
    done = _read_in_a_fresh_process(f"""
import faulthandler, os
faulthandler.enable(file=os.fdopen(os.dup(2), "w"))
import xarray
import rodsim.io.archive as archive
def broken(*args, **kwargs):
    os.abort()
xarray.open_dataset = broken
try:
    archive.read_dataset({str(path)!r})
except archive.ArchiveError as exc:
    print(exc)
""")
    assert done.returncode == 0, done.stderr
    assert "crashed reading it (signal 6)" in done.stdout, done.stdout
    assert "Fatal Python error" not in done.stderr and done.stderr == "", done.stderr
