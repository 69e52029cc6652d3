"""A stop (Ctrl-C, or SIGTERM, which the ``rodsim`` command turns into Ctrl-C) in the middle
of a long piece of work that has finished parts worth keeping: ``Interrupted`` is a
``KeyboardInterrupt`` that carries them (``partial``, e.g. a track's finished steps, marked
incomplete), so that whoever catches it may write them before the stop goes on."""

from __future__ import annotations

from typing import Any

__all__ = ["Interrupted"]


class Interrupted(KeyboardInterrupt):
    """A ``KeyboardInterrupt`` with the finished part of the work: ``partial`` (e.g. a
    ``rodsim.app.inverse.track.Track`` of the steps done, ``success`` False and
    ``complete`` False). Code that does not know it sees a plain ``KeyboardInterrupt``."""

    def __init__(self, partial: Any, message: str) -> None:
        super().__init__(message)
        self.partial = partial
