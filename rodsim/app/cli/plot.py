"""``rodsim plot``: an archive's figure, drawn from the archive alone."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from rodsim.app.cli.common import EXIT_OK, UserError

if TYPE_CHECKING:
    from rodsim.app.figures.movie_encoder import Encoder

__all__ = ["cmd_plot", "movie_output"]

#: The file endings ``-o`` reads as a movie's format.
MOVIE_SUFFIXES = (".mp4", ".gif")


def movie_output(args: argparse.Namespace) -> tuple[str, str | None, list[str] | None]:
    """What ``rodsim plot`` writes: the output stem, the movie's format (None: none, or the
    encoder's choice when ``--movie`` alone asks for one; "" for that choice) and the
    figure formats asked for (None: the defaults). ``-o STEM.mp4`` or ``-o STEM.gif`` is a
    movie of that format, alone unless ``--format`` asks for figures too; a
    ``--movie-format`` that says otherwise is a UserError."""
    output = args.output
    formats = args.format.split(",") if args.format else None
    movie = args.movie_format or ("" if args.movie else None)
    if output is None:
        return str(Path(args.archive).with_suffix("")), movie, formats
    suffix = Path(output).suffix.lower()
    if suffix not in MOVIE_SUFFIXES:
        return output, movie, formats
    named = suffix.lstrip(".")
    if args.movie_format and args.movie_format != named:
        raise UserError(f"-o {output} names an {named} movie but --movie-format asks for "
                        f"{args.movie_format}: give one of them")
    return output[:-len(suffix)], named, formats or []


def cmd_plot(args: argparse.Namespace) -> int:
    from rodsim.app.figures import PlotError, check_output, plot_dataset, three_dimensional, view3d
    from rodsim.app.figures.layers import layers_left_out
    from rodsim.io.archive import ArchiveError, read_dataset

    stem, movie_format, requested = movie_output(args)
    figures = ["png", "pdf"] if requested is None else requested
    try:
        hidden = layers_left_out(args.show, args.hide)  # --show or --hide, checked first
        formats = check_output(stem, figures) if args.output and figures else figures
        dataset = read_dataset(args.archive)
        if requested is None and three_dimensional(dataset) and view3d.available():
            formats = [*formats, "html"]  # a 3D shape: the interactive view too
        if args.cdn and "html" not in formats:
            formats = [*formats, "html"]
        movie: Path | None = None
        encoder: Encoder | None = None
        if movie_format is not None:
            from rodsim.app.figures.movie import check_movie, write_movie
            from rodsim.app.figures.movie_encoder import choose_encoder

            check_movie(dataset)  # before any file is written
            chosen = choose_encoder(movie_format or None)
            movie = Path(f"{stem}.{chosen.format}")
            encoder = check_movie(dataset, movie, chosen)
        paths = plot_dataset(dataset, stem, formats, colour=args.colour,
                             hide=args.hide, show=args.show, cdn=args.cdn) if formats else []
        if movie is not None:
            paths.append(write_movie(dataset, movie, args.colour, hidden, encoder))
    except (ArchiveError, PlotError) as exc:
        raise UserError(str(exc)) from None
    if encoder is not None:
        print(f"note        {encoder.note}")
    for path in paths:
        print(f"figure      {path}")
    return EXIT_OK
