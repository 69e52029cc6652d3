"""``rodsim plot``: an archive's figure, drawn from the archive alone."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from rodsim.app.cli.common import EXIT_OK, UserError

if TYPE_CHECKING:
    from rodsim.app.figures.movie_encoder import Encoder

__all__ = ["cmd_plot"]


def cmd_plot(args: argparse.Namespace) -> int:
    from rodsim.app.figures import PlotError, check_output, plot_dataset, three_dimensional, view3d
    from rodsim.io.archive import ArchiveError, read_dataset

    stem = args.output or str(Path(args.archive).with_suffix(""))
    requested = (args.format or "png,pdf").split(",")
    try:
        formats = check_output(stem, requested) if args.output else None
        dataset = read_dataset(args.archive)
        formats = formats or requested
        if args.format is None and three_dimensional(dataset) and view3d.available():
            formats = [*formats, "html"]  # a 3D shape: the interactive view too
        if args.cdn and "html" not in formats:
            formats = [*formats, "html"]
        movie: Path | None = None
        encoder: Encoder | None = None
        if args.movie or args.movie_format:
            from rodsim.app.figures.layers import hidden_layers
            from rodsim.app.figures.movie import check_movie, write_movie
            from rodsim.app.figures.movie_encoder import choose_encoder

            check_movie(dataset)  # before any file is written
            chosen = choose_encoder(args.movie_format)
            movie = Path(f"{stem}.{chosen.format}")
            encoder = check_movie(dataset, movie, chosen)
        paths = plot_dataset(dataset, stem, formats, colour=args.colour,
                             hide=args.hide.split(","), cdn=args.cdn)
        if movie is not None:
            paths.append(write_movie(dataset, movie, args.colour, hidden_layers(args.hide),
                                     encoder))
    except (ArchiveError, PlotError) as exc:
        raise UserError(str(exc)) from None
    if encoder is not None:
        print(f"note        {encoder.note}")
    for path in paths:
        print(f"figure      {path}")
    return EXIT_OK
