"""``rodsim plot --movie`` as an mp4 or a GIF (issue 36): the encoder's choice and its note,
the mp4's frames against the GIF's (the same drawing, encoded twice), one frame per step of
a track and per output time of a trajectory, the refusal of an mp4 with no ffmpeg, and the
atomic write (a failed encode leaves no file and keeps an older one).

The mp4 is read back with imageio-ffmpeg (frame count, duration, size and the decoded
frames), not with the code that wrote it; the GIF with Pillow."""

from __future__ import annotations

import logging
import os
import stat
import sys

import numpy as np
import pytest

from rodsim.app.figures import PlotError, movie
from rodsim.app.figures.movie_encoder import choose_encoder, encoder_for, find_ffmpeg


def no_ffmpeg(monkeypatch, tmp_path) -> None:
    """No imageio-ffmpeg and an empty PATH: no ffmpeg anywhere."""
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    empty = tmp_path / "empty-path"
    empty.mkdir(exist_ok=True)
    monkeypatch.setenv("PATH", str(empty))


def test_without_ffmpeg_a_movie_is_a_gif_and_an_mp4_is_refused(monkeypatch, tmp_path):
    no_ffmpeg(monkeypatch, tmp_path)
    assert find_ffmpeg() is None
    auto = choose_encoder()
    assert auto.format == "gif" and auto.program is None
    assert "no ffmpeg" in auto.note and "rodsim[movie]" in auto.note
    assert "\n" not in auto.note
    with pytest.raises(PlotError, match="mp4 movie needs ffmpeg") as refused:
        choose_encoder("mp4")
    assert "\n" not in str(refused.value)
    with pytest.raises(PlotError, match="mp4 movie needs ffmpeg"):
        encoder_for(tmp_path / "x.mp4")
    assert encoder_for(tmp_path / "x.GIF").format == "gif"
    with pytest.raises(PlotError, match=".mp4 or .gif"):
        encoder_for(tmp_path / "x.avi")
    with pytest.raises(PlotError, match="unknown movie format"):
        choose_encoder("webm")


def test_an_ffmpeg_on_the_path_is_found_when_imageio_ffmpeg_is_missing(monkeypatch, tmp_path):
    no_ffmpeg(monkeypatch, tmp_path)
    program = tmp_path / "empty-path" / "ffmpeg"
    program.write_text("#!/bin/sh\nexit 0\n")
    program.chmod(program.stat().st_mode | stat.S_IXUSR)
    assert find_ffmpeg() == (str(program), "the PATH")
    chosen = choose_encoder()
    assert chosen.format == "mp4" and chosen.program == str(program)
    assert "the PATH" in chosen.note and "\n" not in chosen.note
    assert str(program) not in chosen.note and "/" not in chosen.note  # where, not the path
    assert choose_encoder("gif").format == "gif"  # asked for: no ffmpeg looked for


def test_the_note_names_the_encoder_in_short_words_not_its_path():
    """imageio-ffmpeg's binary sits deep in site-packages: the note says where it came from;
    the path stays on the Encoder for a caller who wants it."""
    pytest.importorskip("imageio_ffmpeg")
    chosen = choose_encoder()
    assert chosen.format == "mp4" and chosen.program and "/" in chosen.program
    assert chosen.note == "movie as mp4 (ffmpeg found): ffmpeg from imageio-ffmpeg"
    assert choose_encoder("mp4").note == "movie as mp4 (as asked): ffmpeg from imageio-ffmpeg"


def namespace(*argv: str):
    """``rodsim plot``'s parsed arguments."""
    from rodsim.app.cli.parser import build_parser

    return build_parser().parse_args(["plot", *argv])


def test_an_output_ending_in_mp4_or_gif_is_the_movies_format():
    """-o STEM.mp4 (or .gif, any case) is that movie alone, with figures only when --format
    asks; other endings stay a stem; --movie alone leaves the format to the encoder's
    choice ("")."""
    from rodsim.app.cli.plot import movie_output

    assert movie_output(namespace("a.nc")) == ("a", None, None)
    assert movie_output(namespace("a.nc", "--movie")) == ("a", "", None)
    assert movie_output(namespace("a.nc", "-o", "out/fig", "--movie-format", "gif")) == (
        "out/fig", "gif", None)
    assert movie_output(namespace("a.nc", "-o", "out/pull.mp4")) == ("out/pull", "mp4", [])
    assert movie_output(namespace("a.nc", "-o", "pull.GIF", "--movie")) == ("pull", "gif", [])
    assert movie_output(namespace("a.nc", "-o", "pull.mp4", "--movie-format", "mp4",
                                  "--format", "png")) == ("pull", "mp4", ["png"])
    assert movie_output(namespace("a.nc", "-o", "fig6.v2")) == ("fig6.v2", None, None)


def test_a_movie_format_against_the_outputs_ending_is_refused_in_one_line(tmp_path, cli,
                                                                           capsys):
    """Refused before the archive is read (it need not exist) and before anything is
    written."""
    out = tmp_path / "pull.mp4"
    assert cli(["plot", str(tmp_path / "none.nc"), "-o", str(out), "--movie-format",
                "gif"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert "names an mp4 movie but --movie-format asks for gif" in err
    assert not list(tmp_path.iterdir())


def test_without_pillow_a_gif_is_refused_in_one_line(monkeypatch, tmp_path):
    no_ffmpeg(monkeypatch, tmp_path)
    monkeypatch.setitem(sys.modules, "PIL", None)
    for requested in (None, "gif"):
        with pytest.raises(PlotError, match="pip install pillow") as refused:
            choose_encoder(requested)
        assert "\n" not in str(refused.value)


def test_the_frame_sizes_are_even_and_kept_by_the_movie_writer():
    """matplotlib's writer rounds a frame to even pixels from its size in inches: the sizes
    chosen survive that rounding (460 px would become 458)."""
    from matplotlib.animation import adjusted_figsize

    for panels in (1, 2, 3):
        pixels = movie.frame_pixels(panels)
        assert all(p % 2 == 0 for p in pixels)
        inches = [p / movie.MOVIE_DPI for p in pixels]
        again = adjusted_figsize(*inches, movie.MOVIE_DPI, 2)
        assert [int(v * movie.MOVIE_DPI + 1e-8) for v in again] == list(pixels)


# --- Writing movies: each needs a track or a trajectory archive and draws its frames. ---

@pytest.fixture(scope="module")
def track_archive(tmp_path_factory):
    from rodsim.app.cli import main

    archive = tmp_path_factory.mktemp("movie") / "track.nc"
    assert main(["track", "table1-50g", "--set", "nodes=8", "--ramp",
                 "tip_load.mass=0:0.05:5", "-o", str(archive)]) == 0
    return archive


def gif_frames(path) -> list[np.ndarray]:
    from PIL import Image

    with Image.open(path) as gif:
        frames = []
        for k in range(gif.n_frames):
            gif.seek(k)
            frames.append(np.asarray(gif.convert("RGB"), dtype=float))
    return frames


def mp4_frames(path) -> tuple[tuple[int, int], list[np.ndarray]]:
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    width, height = meta["size"]
    return (width, height), [np.frombuffer(f, np.uint8).reshape(height, width, 3).astype(float)
                             for f in reader]


@pytest.mark.slow  # a track and three movies drawn: ~10 s of CPU
def test_a_tracks_mp4_has_the_gifs_frames_one_per_step(track_archive, tmp_path, cli, capsys):
    """The mp4 of a 5-step track: 5 frames of 0.15 s, 480 × 462 pixels; its frame k is the
    GIF's frame k (mean colour difference under 1.5 of 255, from H.264's loss and the GIF's
    palette) and no other (every other frame differs by more than twice as much); a second
    write gives the same bytes."""
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    stem = tmp_path / "track"
    assert cli(["plot", str(track_archive), "-o", str(stem), "--movie", "--format",
                "png"]) == 0
    out = capsys.readouterr().out
    notes = [line for line in out.splitlines() if line.startswith("note")]
    assert len(notes) == 1 and "movie as mp4" in notes[0] and "imageio-ffmpeg" in notes[0]
    assert f"{stem}.mp4" in out and not (tmp_path / "track.gif").exists()
    count, seconds = imageio_ffmpeg.count_frames_and_secs(f"{stem}.mp4")
    assert count == 5
    assert seconds == pytest.approx(5 * movie.FRAME_SECONDS, abs=0.01)
    size, decoded = mp4_frames(f"{stem}.mp4")
    assert size == movie.frame_pixels(1) and len(decoded) == 5

    assert cli(["plot", str(track_archive), "-o", str(stem), "--movie-format", "gif",
                "--format", "png"]) == 0
    assert "movie as GIF (as asked)" in capsys.readouterr().out
    drawn = gif_frames(f"{stem}.gif")
    assert len(drawn) == 5 and drawn[0].shape == decoded[0].shape
    differences = np.array([[np.abs(a - b).mean() for b in drawn] for a in decoded])
    same = np.diag(differences)
    others = differences[~np.eye(5, dtype=bool)]
    assert same.max() < 1.5 and others.min() > 2 * same.max(), differences

    from rodsim.io.archive import read_dataset

    again = movie.write_movie(read_dataset(track_archive), tmp_path / "again.mp4")
    assert again.read_bytes() == (tmp_path / "track.mp4").read_bytes()


@pytest.mark.slow  # two movies of a track drawn: ~4 s of CPU
def test_an_output_named_as_a_movie_writes_that_movie(track_archive, tmp_path, cli, capsys):
    """-o STEM.gif writes the GIF alone, one frame per step; -o STEM.mp4 --format png the
    mp4 and the PNG, and the note names no path."""
    from PIL import Image

    assert cli(["plot", str(track_archive), "-o", str(tmp_path / "pull.gif")]) == 0
    out = capsys.readouterr().out
    assert "movie as GIF (as asked)" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pull.gif"]
    with Image.open(tmp_path / "pull.gif") as gif:
        assert gif.n_frames == 5
    pytest.importorskip("imageio_ffmpeg")
    assert cli(["plot", str(track_archive), "-o", str(tmp_path / "pull.mp4"), "--format",
                "png"]) == 0
    out = capsys.readouterr().out
    (note,) = [line for line in out.splitlines() if line.startswith("note")]
    assert note.endswith("movie as mp4 (as asked): ffmpeg from imageio-ffmpeg")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pull.gif", "pull.mp4", "pull.png"]


@pytest.mark.slow  # a simulation and its movies drawn: ~8 s of CPU
def test_a_trajectorys_mp4_has_one_frame_per_output_time(tmp_path, cli, capsys, monkeypatch):
    """``rodsim simulate``'s archive with 6 output times: 6 frames, or MAX_FRAMES of them
    when there are more; without an ffmpeg, ``--movie`` writes the GIF and says why, and
    ``--movie-format mp4`` is refused in one line with nothing written."""
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    archive = tmp_path / "swing.nc"
    assert cli(["simulate", "table1-50g", "--set", "nodes=9", "--t-end", "0.05",
                "--output-dt", "0.01", "-o", str(archive)]) == 0
    capsys.readouterr()
    assert cli(["plot", str(archive), "--movie-format", "mp4", "--format", "png"]) == 0
    assert "swing.mp4" in capsys.readouterr().out
    assert imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "swing.mp4"))[0] == 6
    monkeypatch.setattr(movie, "MAX_FRAMES", 4)
    assert cli(["plot", str(archive), "-o", str(tmp_path / "four"), "--movie",
                "--format", "png"]) == 0
    capsys.readouterr()
    assert imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "four.mp4"))[0] == 4

    no_ffmpeg(monkeypatch, tmp_path)
    assert cli(["plot", str(archive), "-o", str(tmp_path / "fallback"), "--movie",
                "--format", "png"]) == 0
    out = capsys.readouterr().out
    assert "movie as GIF: no ffmpeg" in out and "fallback.gif" in out
    assert len(gif_frames(tmp_path / "fallback.gif")) == 4
    assert not (tmp_path / "fallback.mp4").exists()
    assert cli(["plot", str(archive), "-o", str(tmp_path / "refused"), "--movie-format",
                "mp4"]) == 2
    err = capsys.readouterr().err
    assert "mp4 movie needs ffmpeg" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not list(tmp_path.glob("refused*")) and not list(tmp_path.glob(".refused*"))


@pytest.mark.slow  # movies drawn and encoded: ~6 s of CPU
def test_a_failed_mp4_leaves_no_file_and_keeps_the_older_one(track_archive, tmp_path,
                                                             monkeypatch, caplog):
    """ffmpeg refusing its options, or the drawing failing at the third frame: a one-line
    PlotError (ffmpeg's own last line in it), the older movie intact, no temporary left."""
    pytest.importorskip("imageio_ffmpeg")
    from rodsim.io.archive import read_dataset

    ds = read_dataset(track_archive)
    target = tmp_path / "kept.mp4"
    target.write_bytes(b"an older movie")
    monkeypatch.setattr(movie, "FFMPEG_ARGS", ("-pix_fmt", "no-such-format"))
    with caplog.at_level(logging.WARNING), pytest.raises(PlotError, match="ffmpeg failed") \
            as failed:
        movie.write_movie(ds, target)
    assert "\n" not in str(failed.value) and str(target) in str(failed.value)
    assert target.read_bytes() == b"an older movie"
    assert sorted(os.listdir(tmp_path)) == ["kept.mp4"]
    assert not [r for r in caplog.records if r.name == "matplotlib.animation"]

    monkeypatch.undo()
    drawn = movie.draw_parts
    calls = []

    def fail_at_the_third_frame(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise RuntimeError("drawing failed")
        return drawn(*args, **kwargs)

    monkeypatch.setattr(movie, "draw_parts", fail_at_the_third_frame)
    for name in ("kept.mp4", "kept.gif"):
        (tmp_path / name).write_bytes(b"an older movie")
        calls.clear()
        with pytest.raises(RuntimeError, match="drawing failed"):
            movie.write_movie(ds, tmp_path / name)
        assert (tmp_path / name).read_bytes() == b"an older movie"
    assert sorted(os.listdir(tmp_path)) == ["kept.gif", "kept.mp4"]

