"""Output paths (issue 15, items 9–11): writability checked before any work, nothing but a
regular file replaced, symbolic links followed, stale temporaries of a killed write removed.

Tests run as root, where a read-only folder does not stop writes: an unwritable target is
made with a path through a regular file, or a name longer than the file system allows.
"""

from __future__ import annotations

import os
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
import xarray as xr

import rodsim
import rodsim.app.api
from rodsim.io.archive import ArchiveError, read_dataset, write_dataset
from rodsim.io.output import OutputError, check_target, owned_prefix

RUN = ["run", "--integrator", "static", "--set", "nodes=6"]


def one_line(capsys) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rodsim: error: "), captured.err
    return lines[0]


def killed_writers_prefix(target: Path) -> str:
    """The temporary prefix a killed writer of ``target`` on this host used: this process's
    stamp with the id of a process that has ended."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return owned_prefix(target).replace(f"-{os.getpid()}.", f"-{child.pid}.")


@pytest.fixture
def no_solve(monkeypatch):
    """Fail the test if a solve starts: the output must be refused before."""
    monkeypatch.setattr(rodsim.app.api, "Model", lambda scene: pytest.fail("the solve started"))


def unwritable_targets(tmp_path: Path) -> dict[str, Path]:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder", encoding="utf-8")
    return {"under a regular file": blocker / "out.nc",
            "name too long": tmp_path / ("x" * 300 + ".nc")}


def test_run_refuses_an_unwritable_output_before_solving(tmp_path, cli, capsys, no_solve):
    """Item 9: `run` checked only that the folder exists, and failed after the solve."""
    for why, target in unwritable_targets(tmp_path).items():
        assert cli([*RUN, "-o", str(target)]) == 2, why
        assert "cannot write" in one_line(capsys), why
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]


def test_bench_refuses_an_unwritable_folder_before_running(tmp_path, cli, capsys,
                                                          monkeypatch):
    """Item 9: `bench` ran the whole benchmark, then failed to write."""
    from rodsim_bench import work_precision

    monkeypatch.setattr(work_precision, "run",
                        lambda *args: pytest.fail("the benchmark ran"))
    blocker = tmp_path / "a-file"
    blocker.write_text("", encoding="utf-8")
    for folder in (blocker / "results", tmp_path / ("y" * 300), tmp_path / "missing"):
        assert cli(["bench", "work-precision", "--size", "small", "-o", str(folder)]) == 2
        assert "cannot write" in one_line(capsys)


@pytest.mark.parametrize("kind", ["folder", "fifo", "socket", "device"])
def test_a_non_regular_target_is_refused_and_left_alone(kind, tmp_path, cli, capsys,
                                                        no_solve):
    """Item 10: `-o /dev/full` (as root) turned the device into a regular file."""
    target = tmp_path / kind
    if kind == "folder":
        target.mkdir()
    elif kind == "fifo":
        os.mkfifo(target)
    elif kind == "socket":
        import socket

        server = socket.socket(socket.AF_UNIX)
        server.bind(str(target))
        server.close()
    elif os.geteuid() == 0:
        os.mknod(target, stat.S_IFCHR | 0o666, os.makedev(1, 7))  # a copy of /dev/full
    else:  # without root no device node can be made, and /dev/null cannot be replaced
        target = Path("/dev/null")
    mode = os.lstat(target).st_mode
    assert cli([*RUN, "-o", str(target)]) == 2
    line = one_line(capsys)
    assert str(target) in line and ("folder" in line or "not a regular file" in line), line
    assert os.lstat(target).st_mode == mode
    with pytest.raises(ArchiveError):  # the Python door too
        write_dataset(xr.Dataset({"a": ("x", [1.0])}), target)
    assert os.lstat(target).st_mode == mode


def test_a_symbolic_link_is_followed_and_kept(tmp_path, cli, capsys):
    """Item 10, the documented choice: writing to a link replaces the file it points to
    (atomically, in the target's folder); the link stays a link."""
    results = tmp_path / "results"
    results.mkdir()
    real = results / "real.nc"
    real.write_text("old", encoding="utf-8")
    link = tmp_path / "link.nc"
    link.symlink_to(real)
    assert cli([*RUN, "-o", str(link)]) == 0, capsys.readouterr().err
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert read_dataset(real).sizes["node"] == 6
    assert sorted(p.name for p in results.iterdir()) == ["real.nc"]
    dangling = tmp_path / "dangling.nc"
    dangling.symlink_to(results / "new.nc")
    assert cli([*RUN, "-o", str(dangling)]) == 0, capsys.readouterr().err
    assert dangling.is_symlink() and read_dataset(results / "new.nc").sizes["node"] == 6


def test_a_link_loop_is_refused(tmp_path, cli, capsys, no_solve):
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    assert cli([*RUN, "-o", str(tmp_path / "a")]) == 2
    assert "cannot write" in one_line(capsys)


def test_check_target_returns_the_file_to_replace(tmp_path):
    plain = tmp_path / "plain.nc"
    assert check_target(plain) == plain
    link = tmp_path / "link.nc"
    link.symlink_to(plain)
    assert check_target(link) == plain.resolve()
    with pytest.raises(OutputError, match="NUL|null"):
        check_target(tmp_path / "nul\0.nc")


def test_the_next_write_removes_a_killed_writes_temporary(tmp_path, cli, capsys):
    """Item 11: kill -9 during the final archive write left `.X.nc.<owner>.<random>.tmp`
    behind for good; its owner is gone, so the next write removes it (issue 23: only then).
    Another target's temporaries and other files are left alone."""
    target = tmp_path / "run.nc"
    stale = []
    for prefix in (killed_writers_prefix(target), killed_writers_prefix(target)):
        handle, name = tempfile.mkstemp(prefix=prefix, suffix=".tmp", dir=tmp_path)
        os.write(handle, b"half an archive")
        os.close(handle)
        stale.append(Path(name))
    handle, other = tempfile.mkstemp(prefix=".other.nc.", suffix=".tmp", dir=tmp_path)
    os.close(handle)
    keep = [Path(other), tmp_path / f".{target.name}.notes.tmp", tmp_path / "run.nc.tmp"]
    for path in keep[1:]:
        path.write_text("mine", encoding="utf-8")
    assert cli([*RUN, "-o", str(target)]) == 0, capsys.readouterr().err
    assert not any(path.exists() for path in stale)
    assert all(path.exists() for path in keep)
    assert read_dataset(target).sizes["node"] == 6


def test_a_resumed_study_removes_the_temporary_of_its_killed_archive_write(tmp_path):
    """Item 11 through the study runner: a study killed while writing its archive resumes,
    and the resume's write removes the temporary the kill left."""
    from rodsim.app.study import Study, Sweep
    from rodsim.app.study_runner import run_study

    study = Study(name="stale_test", title="t", paper="tests only", scene="table1-50g",
                  integrator="static", reference=None,
                  sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (6, 7), "1", "N")]})
    output = tmp_path / "study.nc"
    run_study(study, "small", output, workers=1, keep_parts=True)
    output.unlink()  # as if killed during the write: the points are kept, no archive
    handle, stale = tempfile.mkstemp(prefix=killed_writers_prefix(output), suffix=".tmp",
                                     dir=tmp_path)
    os.close(handle)
    run_study(study, "small", output, workers=1)
    assert not Path(stale).exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.nc"]


def test_plot_follows_the_same_target_rules(tmp_path, cli, capsys):
    """A figure target that is a FIFO is refused (not replaced), a name too long is one
    line, and a link to a figure is followed and kept."""
    archive = tmp_path / "run.nc"
    assert cli([*RUN, "-o", str(archive)]) == 0
    capsys.readouterr()
    fifo = tmp_path / "fig.svg"
    os.mkfifo(fifo)
    assert cli(["plot", str(archive), "-o", str(tmp_path / "fig"), "--format", "svg"]) == 2
    assert "not a regular file" in one_line(capsys)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert cli(["plot", str(archive), "-o", str(tmp_path / ("z" * 300)), "--format",
                "svg"]) == 2
    assert "cannot write" in one_line(capsys)
    real = tmp_path / "figures" / "real.svg"
    real.parent.mkdir()
    link = tmp_path / "link.svg"
    link.symlink_to(real)
    assert cli(["plot", str(archive), "-o", str(tmp_path / "link"), "--format", "svg"]) == 0
    assert link.is_symlink() and real.read_text(encoding="utf-8").lstrip().startswith("<?xml")
