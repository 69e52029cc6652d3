"""Figures drawn from archives alone, one file per figure family:

- ``rodsim.app.figures.plot``: which figure an archive gets, and ``plot_dataset``;
- ``rodsim.app.figures.style``: the one style (``rodsim.mplstyle``), colours, labels;
- ``rodsim.app.figures.writer``: formats, output checks, the atomic write of each format
  (through ``rodsim.io.atomic.write_atomic``, the package's one atomic writer);
- ``rodsim.app.figures.references``: the analytic reference curves of a study;
- ``rodsim.app.figures.study_centerlines``, ``rodsim.app.figures.study_errors``:
  the study figures;
- ``rodsim.app.figures.inverse``: a run's figure and those of track, fit and reach;
- ``rodsim.app.figures.projections``: x–y alone, or x–y, x–z and y–z for a 3D shape;
- ``rodsim.app.figures.contact``: the contact figure;
- ``rodsim.app.figures.state_scene``: the scene of one state (a track's step, a
  trajectory's output time) with the values it was solved with;
- ``rodsim.app.figures.state_series``: several states on one panel, coloured on one scale;
- ``rodsim.app.figures.movie``, ``rodsim.app.figures.movie_encoder``: a track's or a
  trajectory's movie, an mp4 (ffmpeg) or a GIF (Pillow);
- ``rodsim.app.figures.view3d``: the interactive 3-D view (plotly).
"""

from __future__ import annotations

from rodsim.app.figures.inverse import short_key
from rodsim.app.figures.plot import PLOT_KINDS, draw_figure, plot_dataset, three_dimensional
from rodsim.app.figures.references import reference_centerlines
from rodsim.app.figures.style import STYLE, style
from rodsim.app.figures.writer import PlotError, check_output, supported_formats

__all__ = ["plot_dataset", "draw_figure", "three_dimensional", "style", "STYLE", "PLOT_KINDS",
           "reference_centerlines", "PlotError", "supported_formats", "check_output",
           "short_key"]
