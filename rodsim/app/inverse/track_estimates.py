"""The error estimates of every step of a track (docs/inverse.md, "Error estimates per step"):
``discretisation_error`` and ``penalty_error`` of each step, in units of L, as
rodsim/app/trust.py and rodsim/app/discretisation.py make them for one result, but from
companion paths rather than two cold re-solves per step.

The estimate of one result compares it with the equilibrium of the same scene with every
penalty ×10 (``penalty_error``) and with those of the scene at about 1/2 and 2/3 of the
nodes (``discretisation_error``, Richardson at order 2, the mean of the two). Along a track
these comparison equilibria are themselves tracks: the stiffer scene and each coarser scene
are tracked along the same ramp with the static integrator, each step warm-started from the
companion's own previous step, exactly as the track's own steps are. Step k's estimates
then compare step k of the track with step k of each companion: the formulas of the
single-result estimates, applied per step. With tendon friction each companion follows its
own path (its anchors are its own history), which is what a path-dependent comparison
needs. A companion that fails at a step leaves NaN from that step on; a coarse scene that
is refused (a support off the coarse nodes) takes the next coarse count, as the
single-result estimate does (``rodsim.app.discretisation.coarser_scene``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np

from rodsim.app.discretisation import ATTEMPTS, ORDER, RATIOS, TRUST_WARNING, coarser_scene
from rodsim.app.interrupted import Interrupted
from rodsim.app.inverse.parameter_keys import scene_with
from rodsim.app.inverse.track import Track
from rodsim.app.inverse.track import track as track_path
from rodsim.app.trust import penalty_advice, stiffer_scene, tendon_compression
from rodsim.core.cubic_spline import cubic_spline
from rodsim.core.model import Model
from rodsim.core.scene import Scene, SceneError
from rodsim.solvers import DEFAULT_INTEGRATOR

__all__ = ["FACTOR", "estimate_steps", "last_step_estimates", "last_step_text", "step_shapes",
           "track"]

#: The factor on every penalty constant of the stiffer companion (``penalty_error``'s).
FACTOR = 10.0


def step_shapes(path: Track, step: int) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each rod's (rest arc lengths of its nodes, positions (N, 3)) at ``step`` of ``path``."""
    full = path.states[step]
    return {name: (rod.geometry.node_s, full[rod.layout.position_index])
            for name, rod in path.model.rods.items()}


def _ramps(path: Track, scene: Scene, factor: float = 1.0) -> dict[str, Any]:
    """The track's ramp over its completed steps (two values at least), for the companion
    ``scene``: a ramped key that is itself a scaled penalty constant (its value in ``scene``
    differs from the track's) ramps ×``factor``."""
    steps = max(path.steps, 2)
    rows = np.minimum(np.arange(steps), path.steps - 1)
    ramps: dict[str, Any] = {}
    for column, key in enumerate(path.keys):
        values = path.values[rows, column].astype(float)
        if factor != 1.0 and key.index is None and scene.get(key.path) != path.scene.get(
                key.path):
            values = values * factor
        ramps[key.name] = values
    return ramps


def _companion(path: Track, data: dict[str, Any], factor: float = 1.0) -> Track | None:
    """The track of the scene ``data`` along ``path``'s ramp (static integrator, without
    stability verdicts: the companion only measures); None when the scene is refused."""
    from rodsim.app.api import load_scene

    try:
        scene = load_scene(data)
        return track_path(scene, _ramps(path, scene, factor), DEFAULT_INTEGRATOR,
                          allow_unstable=True, verdicts=False)
    except SceneError:
        return None


def _penalty(path: Track) -> np.ndarray:
    """Each step's penalty-error estimate [L] from the stiffer companion."""
    out = np.full(path.steps, np.nan)
    data, count = stiffer_scene(path.scene, FACTOR)
    if count == 0:
        return np.zeros(path.steps)
    stiffer = _companion(path, data, FACTOR)
    if stiffer is None:
        return out
    length = _longest(path)
    for k in range(min(path.steps, stiffer.steps)):
        fine, other = step_shapes(path, k), step_shapes(stiffer, k)
        move = max(float(np.max(np.linalg.norm(other[name][1] - fine[name][1], axis=1)))
                   for name in fine)
        out[k] = move * FACTOR / (FACTOR - 1.0) / length
    return out


def _coarse(path: Track, target: float) -> tuple[Track, float] | None:
    """The companion at about 1/``target`` of the segments and its ratio r (the next coarse
    count when a scene is refused); None when none is accepted or r is not above 1."""
    for attempt in range(ATTEMPTS):
        data, _nodes, ratio = coarser_scene(path.scene, target, attempt)
        if ratio <= 1.0:
            return None
        companion = _companion(path, data)
        if companion is not None:
            return companion, ratio
    return None


def _discretisation(path: Track) -> np.ndarray:
    """Each step's discretisation-error estimate [L]: the mean over the coarse companions
    (``RATIOS``) of the Richardson estimate (rodsim/app/discretisation.py)."""
    length = _longest(path)
    levels: list[np.ndarray] = []
    ratios: list[float] = []
    for target in RATIOS:
        made = _coarse(path, target)
        if made is None or made[1] in ratios:
            continue
        coarse, ratio = made
        ratios.append(ratio)
        level = np.full(path.steps, np.nan)
        for k in range(min(path.steps, coarse.steps)):
            fine, other = step_shapes(path, k), step_shapes(coarse, k)
            change = max(float(np.max(np.linalg.norm(
                cubic_spline(fine[name][0], fine[name][1])(other[name][0]) - other[name][1],
                axis=1))) for name in fine)
            level[k] = change / (ratio**ORDER - 1.0) / length
        levels.append(level)
    if not levels:
        return np.full(path.steps, np.nan)
    return np.mean(levels, axis=0)


def _longest(path: Track) -> float:
    """The longest rod's length [m]."""
    return max(float(rod.geometry.node_s[-1]) for rod in path.model.rods.values())


def estimate_steps(path: Track) -> Track:
    """Store on ``path`` (a track with at least one step) the discretisation and penalty
    error estimates of every completed step (``step_discretisation_error``,
    ``step_penalty_error``; the archive's variables ``discretisation_error`` and
    ``penalty_error`` along ``step``), from the companion paths (module docstring).
    Returns ``path``."""
    if path.steps == 0 or not isinstance(path.model, Model):
        return path
    path.step_penalty_error = [float(v) for v in _penalty(path)]
    path.step_discretisation_error = [float(v) for v in _discretisation(path)]
    return path


def last_step_estimates(path: Track) -> bool:
    """Take the last step's figures (``Track.discretisation_error``, ``penalty_error``: the
    archive's attributes and the summaries' "last step") from the per-step estimates, and
    check that step's tendons for compression from its stored state: no re-solve. False
    (nothing set) when ``path`` carries no per-step estimates."""
    if not path.steps or len(path.step_discretisation_error) != path.steps \
            or len(path.step_penalty_error) != path.steps:
        return False
    path.discretisation_error = float(path.step_discretisation_error[-1])
    path.penalty_error = float(path.step_penalty_error[-1])
    last = path.steps - 1
    scene = scene_with(path.scene, path.keys, path.values[last])
    rods = {name: SimpleNamespace(positions=shape[1])
            for name, shape in step_shapes(path, last).items()}
    last_result: Any = SimpleNamespace(scene=scene, rods=rods)  # what tendon_compression reads
    path.tendon_compression = tendon_compression(last_result)
    return True


def last_step_text(path: Track) -> str:
    """The CLI's "last step" lines (and warnings) from ``last_step_estimates``'s figures."""
    length = _longest(path)
    lines = []
    error = float(path.discretisation_error or np.nan)
    if np.isfinite(error):
        lines.append(f"discretis.  last step: error ≈ {error:.2g} L ({error * length:.2g} m; "
                     f"Richardson at order {ORDER:g} from the tracks at about 1/2 and 2/3 of "
                     "the nodes)")
    else:
        lines.append("discretis.  last step: error estimate unavailable: the coarse tracks "
                     "did not reach that step (warning: compare with a run at twice the nodes)")
    if not error <= TRUST_WARNING and np.isfinite(error):
        lines.append(f"warning     the discretisation error exceeds {TRUST_WARNING:g} L: raise "
                     "the rods' nodes (rods.<name>.nodes; the error falls as N^-2)")
    error = float(path.penalty_error if path.penalty_error is not None else np.nan)
    if stiffer_scene(path.scene, FACTOR)[1] == 0:
        lines.append("penalty     last step: none in this scene (no penalty error)")
    elif not np.isfinite(error):
        lines.append(f"penalty     last step: error estimate unavailable: the track with "
                     f"penalties ×{FACTOR:g} did not reach that step (warning: the result "
                     "may depend on a penalty)")
    else:
        lines.append(f"penalty     last step: error ≈ {error:.2g} L ({error * length:.2g} m; "
                     f"from the track with every penalty ×{FACTOR:g})")
        if error > TRUST_WARNING:
            lines.append(f"warning     the penalty error exceeds {TRUST_WARNING:g} L: raise "
                         f"{penalty_advice()['']} and compare")
    return "\n".join(lines)


def track(scene: Any, ramps: Mapping[str, Sequence[float] | np.ndarray],
          integrator: str = DEFAULT_INTEGRATOR, *, progress: Any = None,
          allow_unstable: bool = False, verdicts: bool = True,
          estimates: bool = True) -> Track:
    """``rodsim.track``: the track of rodsim/app/inverse/track.py (its docstring: arguments,
    failures, interruption), then with ``estimates`` (the default) every completed step's
    discretisation and penalty error estimates (``estimate_steps``) and the last step's
    figures from them (``last_step_estimates``), as ``rodsim track`` makes them. They cost
    three companion tracks (docs/inverse.md, "Error estimates per step"); ``estimates=False``
    skips them. Ctrl-C while they are made raises ``rodsim.app.interrupted.Interrupted``
    whose ``partial`` is the track without them."""
    path = track_path(scene, ramps, integrator, progress=progress,
                      allow_unstable=allow_unstable, verdicts=verdicts)
    if not estimates:
        return path
    try:
        estimate_steps(path)
    except KeyboardInterrupt:
        path.step_discretisation_error, path.step_penalty_error = [], []
        raise Interrupted(path, "interrupted (Ctrl-C or SIGTERM) while estimating the "
                          "steps' errors; the track is complete without them") from None
    last_step_estimates(path)
    return path
