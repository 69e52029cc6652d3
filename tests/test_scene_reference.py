"""Every shipped scene's equilibrium is unchanged to round-off (issue 14: "no number may
change").

tests/data/scene_reference.npz holds, for every shipped scene, the control point positions
and segment quaternions of each rod at equilibrium with the ``static`` integrator and with
the scene's own integrator, computed at commit 7e59fe6 by tests/data/make_reference.py.
Each is solved again here and compared. Regenerate the file only for an intended change of
the numbers, and say so in the commit (tests/data/make_reference.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import rodsim
from rodsim.core.scene import scene_paths

REFERENCE = Path(__file__).parent / "data" / "scene_reference.npz"

#: Largest allowed difference relative to the scale of the values (the longest rod's largest
#: coordinate, or 1 for unit quaternions): round-off, not a tolerance of the solvers.
RELATIVE = 1e-12


def _stored() -> dict[str, np.ndarray]:
    with np.load(REFERENCE) as data:
        return {key: data[key] for key in data.files}


STORED = _stored()
CASES = sorted({tuple(key.split("/")[:2]) for key in STORED if key.count("/") == 3})


def test_every_shipped_scene_has_a_reference():
    """A new shipped scene needs its reference (and a static one at least): nothing is left
    out silently."""
    assert {name for name, _ in CASES} == set(scene_paths())
    assert all((name, "static") in CASES for name in scene_paths())
    for name in scene_paths():
        default = rodsim.load_scene(name).data["solver"]["integrator"]
        assert (name, default) in CASES, f"{name}: no reference for {default}"


@pytest.mark.parametrize(("name", "integrator"), CASES, ids=[f"{n}-{i}" for n, i in CASES])
def test_equilibrium_matches_the_reference(name, integrator):
    result = rodsim.solve(rodsim.load_scene(name), integrator)
    assert result.success, result.message
    prefix = f"{name}/{integrator}/"
    rods = {key.split("/")[2] for key in STORED if key.startswith(prefix)}
    assert rods == set(result.rods)
    scale = max(float(np.max(np.abs(STORED[f"{prefix}{rod}/position"]))) for rod in rods)
    for rod in sorted(rods):
        for what, now, tol in (
                ("position", result.rods[rod].positions, RELATIVE * scale),
                ("quaternion", result.rods[rod].quaternions, RELATIVE)):
            stored = STORED[f"{prefix}{rod}/{what}"]
            assert now.shape == stored.shape, f"{rod} {what}: shape changed"
            difference = float(np.max(np.abs(now - stored)))
            assert difference <= tol, (f"{name} ({integrator}) rod {rod!r} {what} moved by "
                                       f"{difference:.3e} > {tol:.1e}")
