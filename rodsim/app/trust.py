"""How far to trust a result: an a-posteriori estimate of its penalty error (docs/model.md,
"The penalty-error estimate").

Every penalty term (centerline K_P, lumen K_L, endpoint compliance K_E, endpoint coupling K_C,
joint K_J) holds a constraint only to within force/K, so an equilibrium x(K) differs from the
constrained one x(∞) by an error that, for stiff enough penalties, falls as 1/K:
x(K) ≈ x(∞) + c/K. One warm Newton solve with every penalty constant ×f from the converged
state gives x(fK), and

    x(K) − x(∞) ≈ (x(K) − x(fK)) · f / (f − 1),

reported as the largest distance over every control point of every rod, in units of the
longest rod's length L. Checked against the change a 100× stiffer solve makes on the user
scene and the random family (tests/test_user_robot.py).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.solvers import DEFAULT_INTEGRATOR
from rodsim.solvers.result import Result

__all__ = ["PENALTIES", "TRUST_WARNING", "PenaltyError", "assess", "last_step_result",
           "penalty_error", "stiffer_scene"]

#: The penalty constant of each penalty term, absolute then relative spelling (an absolute
#: value of 0 means "from the relative one", rodsim/core/terms/centerline.py and
#: rodsim/core/terms/_relative.py).
PENALTIES: dict[str, tuple[str, ...]] = {
    "centerline": ("K_P", "K_P_relative"),
    "lumen": ("K_L", "K_L_relative"),
    "endpoint_compliance": ("K_E", "K_E_relative"),
    "endpoint_coupling": ("K_C", "K_C_relative"),
    "joint": ("K_J", "K_J_relative"),
}

#: Above this estimate (in units of L) a run is flagged: its answer depends on a penalty.
TRUST_WARNING = 1e-3


@dataclass(frozen=True)
class PenaltyError:
    """The estimate of :func:`penalty_error`."""

    #: Estimated distance of the result from the penalty-free one, in units of L (NaN when
    #: the stiffer solve failed; 0 when the scene has no penalty).
    error: float
    #: The largest control-point change of the stiffer solve [m].
    change: float
    #: The factor every penalty constant was multiplied by.
    factor: float
    #: The length L the error is measured in [m].
    length: float
    #: How many penalty constants were scaled.
    penalties: int

    @property
    def warning(self) -> bool:
        """True when the estimate exceeds :data:`TRUST_WARNING` (or could not be made)."""
        return not self.error <= TRUST_WARNING

    def text(self) -> str:
        """The CLI's summary line."""
        if self.penalties == 0:
            return "penalty     none in this scene (no penalty error)"
        if not np.isfinite(self.error):
            return (f"penalty     error estimate unavailable: the solve with penalties ×"
                    f"{self.factor:g} failed (warning: the result may depend on a penalty)")
        line = (f"penalty     error ≈ {self.error:.2g} L ({self.error * self.length:.2g} m; "
                f"from a re-solve with every penalty ×{self.factor:g})")
        if self.warning:
            line += (f"\nwarning     the penalty error exceeds {TRUST_WARNING:g} L: stiffen the "
                     "penalties (e.g. K_P_relative, K_L) and compare")
        return line


def stiffer_scene(scene: Scene, factor: float) -> tuple[dict[str, Any], int]:
    """The resolved scene dict with every penalty constant multiplied by ``factor``, and how
    many constants were scaled."""
    data = copy.deepcopy(scene.data)
    count = 0
    for owner in ("rods", "tendons"):
        for table in data.get(owner, {}).values():
            for term in table.get("terms", []):
                options = table.get(term)
                if term not in PENALTIES or not isinstance(options, dict):
                    continue
                for key in PENALTIES[term]:  # the first one set is the one in use
                    if options.get(key):
                        options[key] = float(options[key]) * factor
                        count += 1
                        break
    return data, count


def penalty_error(result: Result, factor: float = 10.0,
                  model: Model | None = None) -> PenaltyError:
    """Estimate how far ``result`` (a converged run) is from the penalty-free equilibrium by
    one warm static solve with every penalty ×``factor`` (module docstring). ``model``: the
    model ``result`` was solved with, when its friction anchors are not the rest state (a
    track's step): the stiffer solve keeps them (:meth:`Model.with_scene`)."""
    from rodsim.app.api import load_scene, solve

    length = _longest(result)
    data, count = stiffer_scene(result.scene, factor)
    if count == 0:
        return PenaltyError(0.0, 0.0, factor, length, 0)
    # its own budget: never more than the scene's, nor above twice the run (10 s at least)
    data["solver"]["max_wall_time"] = min(float(result.scene.solver.max_wall_time),
                                          max(10.0, 2.0 * result.stats.get("wall_time", 0.0)))
    scene: Scene | dict[str, Any] = data
    stiffer_model = None
    if model is not None:
        scene = load_scene(data)
        stiffer_model = model.with_scene(scene)
    stiffer = solve(scene, DEFAULT_INTEGRATOR, model=stiffer_model, initial_state=result.state)
    if not stiffer.success:
        return PenaltyError(float("nan"), float("nan"), factor, length, count)
    change = max(float(np.max(np.linalg.norm(stiffer.rods[name].positions - shape.positions,
                                             axis=1)))
                 for name, shape in result.rods.items())
    return PenaltyError(change * factor / (factor - 1.0) / length, change, factor, length,
                        count)


def _longest(result: Result) -> float:
    """The longest rod's length [m] (the largest arc length of its nodes)."""
    return max(float(shape.s[-1]) for shape in result.rods.values())


def tendon_compression(result: Result) -> dict[str, float]:
    """Rod tendons (couplings 'paper' and 'conserving') that carry compression somewhere: a
    tendon cannot push. Returns the most compressive axial force E_s A (|r_{j+1} − r_j|/h − 1)
    [N] (negative) of each such tendon; a string tendon is a tension by construction."""
    from rodsim.core.model import Model

    out: dict[str, float] = {}
    rods = None
    for name, options in result.scene.tendons.items():
        if options.coupling == "string" or name not in result.rods:
            continue
        rods = rods or Model(result.scene).rods
        rod = rods[name]
        positions = result.rods[name].positions
        h = rod.geometry.segment_length
        strain = np.linalg.norm(np.diff(positions, axis=0), axis=1) / h - 1.0
        force = rod.segment_stretch_stiffness() * strain
        scale = float(np.max(np.abs(force))) if force.size else 0.0
        if force.size and force.min() < -max(1e-6 * scale, 1e-12):
            out[name] = float(force.min())
    return out


def compression_text(compressed: dict[str, float]) -> str:
    """The CLI's warning lines for :func:`tendon_compression`."""
    return "\n".join(
        f"warning     tendon {name} is in compression ({force:.3g} N at its most compressed "
        "segment): a tendon cannot push; the scene is not physical (docs/tendon.md)"
        for name, force in compressed.items())


def assess(result: Result, model: Model | None = None) -> PenaltyError:
    """Estimate ``result``'s penalty error and check its tendons for compression, storing
    both on it (``penalty_error``, ``tendon_compression``: the run archive's attributes);
    returns the estimate. What ``rodsim run``, ``fit`` and ``reach`` do with their result
    (``model``: see :func:`penalty_error`)."""
    estimate = penalty_error(result, model=model)
    result.penalty_error = estimate.error
    result.tendon_compression = tendon_compression(result)
    return estimate


def last_step_result(track: Any) -> Result | None:
    """The last completed step of a :class:`~rodsim.app.inverse.track.Track` as a static
    result (a warm solve of the scene at that step's values from that step's state: already
    at equilibrium, so one Newton iteration), for :func:`assess`; None without a step or
    when that solve fails."""
    from rodsim.app.api import solve

    if not track.steps:
        return None
    last = track.steps - 1
    values: dict[str, float | list[float]] = {}
    vectors: dict[str, list[float]] = {}
    for column, key in enumerate(track.keys):
        value = float(track.values[last, column])
        if key.index is None:
            values[key.path] = value
        else:
            vector = vectors.setdefault(key.path, list(track.scene.get(key.path)))
            vector[key.index] = value
            values[key.path] = vector
    scene = track.scene.with_values(values)
    # The last step's own model for that scene: with friction, the anchors of that step.
    last_model = getattr(track, "last_model", None)
    model = last_model.with_values(scene) if last_model is not None else None
    result = solve(scene, DEFAULT_INTEGRATOR, model=model,
                   initial_state=track.states[-1][track.model.free])
    return result if result.success else None
