"""``rodsim plot``: an archive's figure, drawn from the archive alone."""

from __future__ import annotations

import argparse
from pathlib import Path

from rodsim.app.cli.common import EXIT_OK, UserError

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
        if args.movie:
            from rodsim.app.figures.layers import hidden_layers
            from rodsim.app.figures.movie import check_movie, write_movie

            check_movie(dataset)  # before any file is written
        paths = plot_dataset(dataset, stem, formats, colour=args.colour,
                             hide=args.hide.split(","), cdn=args.cdn)
        if args.movie:
            paths.append(write_movie(dataset, Path(f"{stem}.gif"), args.colour,
                                     hidden_layers(args.hide)))
    except (ArchiveError, PlotError) as exc:
        raise UserError(str(exc)) from None
    for path in paths:
        print(f"figure      {path}")
    return EXIT_OK
