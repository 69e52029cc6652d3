"""The summary's contact warnings: a rest shape through an obstacle's wall
(rodsim/core/contact_depth.py, :func:`~rodsim.core.contact_depth.rest_crossings`).

A rest state deeper inside an obstacle than the contact law's validity starts the solve
through the wall, where it may settle on the far side (a user's guidewire whose straight
rest shape crossed its vessel got no word of it, and came back folded and "stable").
"""

from __future__ import annotations

from typing import Any

__all__ = ["contact_warnings"]


def contact_warnings(result: Any) -> list[str]:
    """The summary lines ("warning     …") for ``result`` (a Result): one per rod and
    obstacle whose rest shape crosses the obstacle's wall; none for a scene without
    obstacles."""
    if not result.scene.data.get("obstacles"):
        return []
    from rodsim.core.contact_depth import rest_crossings
    from rodsim.core.model import Model

    return [f"warning     {line}" for line in rest_crossings(Model(result.scene))]
