"""The summary's contact warnings: a rest shape through an obstacle's wall
(rodsim/core/contact_depth.py, ``rodsim.core.contact_depth.rest_crossings``), and a rod
that passes through itself (rodsim/core/self_crossing.py; rodsim has no self-contact).

A rest state deeper inside an obstacle than the contact law's validity starts the solve
through the wall, where it may settle on the far side (a user's guidewire whose straight
rest shape crossed its vessel got no word of it, and came back folded and "stable").
"""

from __future__ import annotations

from typing import Any

__all__ = ["contact_warnings", "failure_note"]


def contact_warnings(result: Any) -> list[str]:
    """The summary lines ("warning     …") for ``result`` (a Result): one per rod and
    obstacle whose rest shape crosses the obstacle's wall (scenes with obstacles), and one
    per rod that passes through itself."""
    from rodsim.io.run_dataset import self_crossings

    lines = self_crossings(result)
    if result.scene.data.get("obstacles"):
        from rodsim.core.contact_depth import rest_crossings
        from rodsim.core.model import Model

        lines = rest_crossings(Model(result.scene)) + lines
    return [f"warning     {line}" for line in lines]


def failure_note(scene: Any, message: str = "") -> str:
    """What a solver failure's one line adds when a rod's rest shape crosses an obstacle's
    wall: "; " and each crossing (``rest_crossings``) that ``message`` (the failure's own
    text) does not already hold, else "". The likely cause of the failure, which the
    summary of a success warns about but a failure did not say (a user's guidewire through
    its vessel: `track` failed at step 0 advising a smaller load step)."""
    if not scene.data.get("obstacles"):
        return ""
    from rodsim.core.contact_depth import rest_crossings
    from rodsim.core.model import Model

    try:
        crossings = rest_crossings(Model(scene))
    except Exception:  # noqa: BLE001 - a note, never a second failure
        return ""
    return "".join(f"; {line}" for line in crossings if line not in message)
