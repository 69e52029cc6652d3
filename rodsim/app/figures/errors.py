"""The one error of the figures (``PlotError``): its own module, so that every figure module
can raise it without importing the writer (and, through it, the 3-D view)."""

from __future__ import annotations

__all__ = ["PlotError"]


class PlotError(ValueError):
    """A figure cannot be drawn or written: unknown format, unwritable folder, bad archive."""
