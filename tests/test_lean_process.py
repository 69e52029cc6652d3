"""The lean command process (rodsim/app/lean.py): the early exit loses nothing, ``--help``
needs neither the solvers nor numpy, and only the whole-process entry takes the shortcuts.

The archives written by a process that ended with ``os._exit`` are read back after the
process is gone and compared with the same run made in this process; the write is also
slowed down (a sleep before and after the netCDF write, in the child) so that an exit racing
the write would show. No test measures time.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import rodsim
from rodsim.app import lean
from rodsim.app.cli import main
from rodsim.io.archive import read_dataset

#: A child process that runs the installed command's entry with the run archive's netCDF
#: write (rodsim/io/netcdf_writer.py) slowed down (``SLOW`` seconds before and after it).
SLOW_ENTRY = textwrap.dedent("""
    import sys, time
    from rodsim.io import netcdf_writer
    SLOW = float(sys.argv.pop(1))
    original = netcdf_writer.write_netcdf
    def slow(*args, **kwargs):
        time.sleep(SLOW)
        out = original(*args, **kwargs)
        time.sleep(SLOW)
        return out
    netcdf_writer.write_netcdf = slow
    from rodsim.app.cli import entry
    entry()
""")


def _child(args: list[str], slow: float | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env.pop("PYTHONUNBUFFERED", None)  # stdout into a pipe is block-buffered, as for a user
    command = ([sys.executable, "-c", SLOW_ENTRY, str(slow)] if slow is not None
               else [sys.executable, "-m", "rodsim"])
    return subprocess.run(command + args, capture_output=True, text=True, env=env,
                          timeout=600, check=False)


@pytest.mark.parametrize("slow", [None, 0.5])
def test_an_archive_written_by_rodsim_run_is_complete_after_the_process_ends(tmp_path, slow):
    """The archive is read back (its contract checked by read_dataset) and holds the
    equilibrium this process computes for the same scene; piped stdout is complete."""
    output = tmp_path / "run.nc"
    args = ["run", "--integrator", "static", "--set", "nodes=12", "-o", str(output)]
    done = _child(args, slow)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("scene       table1-50g")
    assert f"archive     {output}" in lines
    # The last line `rodsim run` prints (its penalty-error estimate) reached the pipe.
    assert lines[-1].startswith("penalty     error ≈ "), lines[-1]
    assert [p.name for p in tmp_path.iterdir()] == ["run.nc"]  # no temporary left behind
    stored = read_dataset(output)
    result = rodsim.solve(rodsim.load_scene("table1-50g", ["nodes=12"]), "static")
    np.testing.assert_allclose(stored["position"].values, result.positions(), rtol=0,
                               atol=1e-12)
    assert stored.attrs["success"] == 1
    assert stored.attrs["history"].endswith("rodsim run --integrator static --set nodes=12 "
                                            f"-o {output}")


def test_piped_stdout_of_a_listing_is_complete(capsys):
    """``rodsim terms`` through a pipe prints exactly what the same command prints in this
    process (block-buffered stdout flushed before the early exit)."""
    assert main(["terms"]) == 0
    expected = capsys.readouterr().out
    done = _child(["terms"])
    assert done.returncode == 0, done.stderr
    assert done.stdout == expected
    assert len(expected.splitlines()) > 20


def test_a_failing_run_keeps_its_exit_code_and_message(tmp_path):
    done = _child(["run", "--set", "nodes=1", "-o", str(tmp_path / "x.nc")])
    assert done.returncode == 2
    assert done.stderr.startswith("rodsim: error:") and len(done.stderr.splitlines()) == 1


def test_only_the_whole_process_entry_exits_early(tmp_path, monkeypatch, capsys):
    """``main(argv)`` (a Python caller, the tests) returns; ``main(argv, process=True)`` ends
    the process through ``os._exit`` with the command's code, after the archive is in place
    and stdout is flushed."""
    exits: list[int] = []

    class Exited(Exception):
        pass

    def fake_exit(code: int) -> None:
        exits.append(code)
        assert (tmp_path / "b.nc").exists()
        raise Exited

    monkeypatch.setattr(lean.os, "_exit", fake_exit)
    monkeypatch.setattr(lean, "hide_dask", lambda: None)  # keep this process's dask
    args = ["run", "--integrator", "static", "--set", "nodes=12"]
    assert main([*args, "-o", str(tmp_path / "a.nc")]) == 0
    assert exits == []
    with pytest.raises(Exited):
        main([*args, "-o", str(tmp_path / "b.nc")], process=True)
    assert exits == [0]
    assert "archive" in capsys.readouterr().out


def test_study_and_bench_keep_dask_and_bench_the_normal_exit():
    assert {"study", "bench"}.isdisjoint(lean.LEAN_COMMANDS)
    assert {"run", "track", "rerun", "scenes"} <= lean.LEAN_COMMANDS
    assert "bench" not in lean.EARLY_EXIT_COMMANDS and "study" in lean.EARLY_EXIT_COMMANDS
    assert lean.hides_dask("study") and not lean.hides_dask("study", "local")
    assert not lean.hides_dask("bench")


#: A whole ``rodsim`` process (``main(argv, process=True)``) that reports, as it ends, which
#: of dask and distributed it imported.
DASK_PROBE = textwrap.dedent("""
    import sys
    from rodsim.app import lean
    early = lean.fast_exit
    def report(code):
        print("imported:", sorted(m for m in ("dask", "distributed")
                                  if sys.modules.get(m) is not None), flush=True)
        early(code)
    lean.fast_exit = report
    from rodsim.app.cli.main import main
    sys.exit(main(sys.argv[1:], process=True))
""")


@pytest.mark.slow  # a rodsim study process with its workers: ~2-3 s of CPU each
@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_study_on_local_workers_never_imports_dask(tmp_path, workers):
    """xarray's netCDF write asks dask for its scheduler (0.4 s of imports, distributed
    included): a study on local workers hides dask and its archive is still complete."""
    output = tmp_path / "fig7b.nc"
    done = subprocess.run([sys.executable, "-c", DASK_PROBE, "study", "fig7b", "--size",
                           "small", "--workers", workers, "-o", str(output)],
                          capture_output=True, text=True, timeout=600, check=False,
                          env=dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1"))
    assert done.returncode == 0, done.stderr
    assert "imported: []" in done.stdout
    assert read_dataset(output)["status"].size > 0


@pytest.mark.slow  # as above
def test_a_study_on_two_workers_is_complete_after_its_process_ends(tmp_path):
    """The pool's workers are gone before the early exit, the archive holds every point."""
    output = tmp_path / "fig7b.nc"
    done = _child(["study", "fig7b", "--size", "small", "--workers", "2", "-o", str(output)])
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == f"archive     {output}"
    stored = read_dataset(output)
    assert stored.attrs["points"] == 4 and stored.attrs["failed_points"] == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig7b.nc"]  # parts removed


def test_a_live_child_process_keeps_the_normal_exit(monkeypatch):
    import multiprocessing

    monkeypatch.setattr(lean.os, "_exit", lambda code: pytest.fail("exited early"))
    monkeypatch.setattr(multiprocessing, "active_children", lambda: ["a worker"])
    with pytest.raises(SystemExit) as exit_info:
        lean.fast_exit(0)
    assert exit_info.value.code == 0


def test_help_imports_neither_numpy_nor_the_solvers():
    code = ("import sys\n"
            "from rodsim.app.cli import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.startswith(('numpy', 'scipy', "
            "'rodsim.solvers', 'rodsim.core', 'numba'))))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, timeout=120)
    assert done.stdout.splitlines()[-1] == "[]"
    assert "usage: rodsim" in done.stdout


def test_run_help_still_lists_the_scene_keys(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = capsys.readouterr().out
    assert "scene keys for --set" in out and "solver.static" in out
