"""Concurrent writers of one archive (issue 23, item 1): a temporary is removed only by the
process that made it or when its owner is provably gone, so every writer of one target
finishes, tells the truth, and the target is one complete archive."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from rodsim.io.archive import read_dataset, write_dataset

#: A writer in another process whose netCDF write pauses (after the temporary is complete,
#: before the rename) until the file ``release`` appears.
SLOW_WRITER = r"""
import sys, time
from pathlib import Path
import xarray as xr
from rodsim.io.archive import write_dataset
target, ready, release = map(Path, sys.argv[1:4])
original = xr.Dataset.to_netcdf
def slow(self, *args, **kwargs):
    out = original(self, *args, **kwargs)
    ready.write_text("writing")
    for _ in range(600):
        if release.exists():
            break
        time.sleep(0.05)
    return out
xr.Dataset.to_netcdf = slow
write_dataset(xr.open_dataset(sys.argv[4]).load(), target)
print("written")
"""


NOTE = True


def small_archive(tmp_path: Path, cli, value: float = 0.0) -> Path:
    source = tmp_path / f"source{value}.nc"
    assert cli(["run", "--integrator", "static", "--set", "nodes=6", "--set",
                f"tip_load.mass={0.05 + value}", "-o", str(source)]) == 0
    return source


def test_a_live_writers_temporary_is_left_alone(tmp_path, cli, capsys):
    """Today's code deleted every `.same.nc.*.tmp` before its own write, a live one of
    another process included: that process then failed (exit 2) although its solve
    converged. Here a writer in another process is paused between its temporary and the
    rename while this process writes the same target; both must succeed."""
    source = small_archive(tmp_path, cli)
    capsys.readouterr()
    target, ready, release = tmp_path / "same.nc", tmp_path / "ready", tmp_path / "release"
    writer = subprocess.Popen([sys.executable, "-c", SLOW_WRITER, str(target), str(ready),
                               str(release), str(source)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for _ in range(1200):
            if ready.exists() or writer.poll() is not None:
                break
            time.sleep(0.05)
        assert ready.exists(), writer.communicate()
        notes: list[str] = []
        write_dataset(read_dataset(source), target, **({"note": notes.append} if NOTE else {}))
    finally:
        release.write_text("go")
        out, err = writer.communicate(timeout=120)
    assert writer.returncode == 0 and "written" in out, err
    assert notes and "at the same time" in notes[0]  # this writer was told of the other
    assert read_dataset(target).sizes["node"] == 6
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []


def dead_pid() -> int:
    """The id of a process that has ended (and been reaped)."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_only_provably_stale_temporaries_are_removed(tmp_path):
    """A temporary stamped by a process of this host that no longer exists is removed; one
    stamped by a live process, another host's, an unstamped one and other files stay."""
    from rodsim.io.output import owned_prefix, remove_stale_temporaries, temporary_prefix

    target = tmp_path / "run.nc"
    prefix = owned_prefix(target)
    host = prefix[len(temporary_prefix(target)):].split("-")[0]
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        def made(stamp: str) -> Path:
            handle, name = tempfile.mkstemp(prefix=temporary_prefix(target) + stamp,
                                            suffix=".tmp", dir=tmp_path)
            os.close(handle)
            return Path(name)

        stale = made(f"{host}-{dead_pid()}.")
        live = made(f"{host}-{sleeper.pid}.")
        mine = made(f"{host}-{os.getpid()}.")
        elsewhere = made(f"{'0' * 8 if host != '0' * 8 else '1' * 8}-{dead_pid()}.")
        unstamped = made("")
        assert remove_stale_temporaries(target) == [stale]
        assert all(p.exists() for p in (live, mine, elsewhere, unstamped))
    finally:
        sleeper.kill()
        sleeper.wait()


@pytest.mark.slow
def test_concurrent_cli_runs_of_one_target(tmp_path):
    """Two rounds of six concurrent `rodsim run -o same.nc` (the issue's reproduction in
    small): every process exits 0, and the file is a complete archive of one of them."""
    target = tmp_path / "same.nc"
    masses = []
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    for round_ in range(2):
        runs = []
        for i in range(6):
            mass = 0.01 * (i + 1) + 0.001 * round_
            masses.append(mass)
            runs.append(subprocess.Popen(
                [sys.executable, "-m", "rodsim.app.cli", "run", "table1-50g", "--integrator",
                 "static", "--set", "nodes=10", "--set", f"tip_load.mass={mass}", "-o",
                 str(target)], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                stderr=subprocess.PIPE, text=True))
        for run in runs:
            out, err = run.communicate(timeout=600)
            assert run.returncode == 0, err
            assert "Traceback" not in err
            assert all(line.strip() == "" or line.lstrip().startswith(("[", "rodsim: warning: "))
                       for line in err.splitlines()), err  # progress lines and warnings
        stored = read_dataset(target)  # complete: it passes the archive contract
        mass = json.loads(stored.attrs["scene_json"])["rods"]["catheter"]["tip_load"]["mass"]
        assert mass in masses[-6:]  # one of this round's writers
        assert stored.sizes["node"] == 10 and np.all(np.isfinite(stored["position"].values))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["same.nc"]
