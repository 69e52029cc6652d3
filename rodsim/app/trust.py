"""How far to trust a result: an a-posteriori estimate of its penalty error, beside its
discretisation error (rodsim/app/discretisation.py), and the tendon-compression check
(docs/model.md, "The error estimates every result carries").

Every constraint penalty (a term's ``rodsim.core.terms.base.Term.constraint_constant``:
centerline K_P, lumen K_L, joint K_J, an obstacle's contact stiffness; not the paper's
fitted endpoint springs K_E, K_C, which are physics) holds a constraint only to within
force/K, so an equilibrium x(K) differs from the constrained one x(∞) by an error that, for
stiff enough penalties, falls as 1/K: x(K) ≈ x(∞) + c/K. One warm Newton solve with every
such constant ×f from the converged state gives x(fK), and

    x(K) − x(∞) ≈ (x(K) − x(fK)) · f / (f − 1),

reported as the largest distance over every control point of every rod, in units of the
longest rod's length L. Checked against the change a 100× stiffer solve makes on the user
scene and the random family (tests/test_user_robot.py, tests/test_error_estimates.py).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.app.discretisation import (
    BUDGET_FLOOR,
    TRUST_WARNING,
    DiscretisationError,
    discretisation_error,
)
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.terms import registered_terms
from rodsim.solvers import DEFAULT_INTEGRATOR
from rodsim.solvers.result import Result

__all__ = ["Estimates", "PenaltyError", "TRUST_WARNING", "assess", "largest_move",
           "last_step_result", "penalty_advice", "penalty_constants", "penalty_error",
           "penalty_estimate", "stiffer_scene"]


def penalty_constants() -> dict[str, tuple[str, ...]]:
    """The constraint-penalty constant of each term that has one, by the scene key a rod's
    or a tendon's ``terms`` lists it under (or the top-level table of a term built from one,
    ``obstacles``): absolute then relative spelling, from the terms' own declaration
    (``rodsim.core.terms.base.Term.constraint_constant``). The paper's endpoint springs
    K_E and K_C are physics and not among them (docs/model.md, "Which constants are
    penalties")."""
    out: dict[str, tuple[str, ...]] = {}
    for kind in registered_terms().values():
        key = kind.constraint_constant
        if not key:
            continue
        spellings = tuple(name for name in (key, f"{key}_relative")
                          if any(p.name == name for p in kind.parameters)) or (key,)
        out[kind.scene_table or kind.key] = spellings
    return out


def penalty_advice() -> dict[str, str]:
    """What the penalty warning asks to raise, by the scene key of the dominant kind of
    penalty (as ``penalty_constants``), from the terms' own declaration
    (``rodsim.core.terms.base.Term.penalty_advice``); under ``""`` every constant at once,
    for a warning with no dominant kind."""
    constants = penalty_constants()
    out: dict[str, str] = {}
    every: list[str] = []
    for kind in registered_terms().values():
        key = kind.scene_table or kind.key
        if kind.constraint_constant and key not in out:
            out[key] = f"{kind.penalty_advice}, which moves the result most"
            spelling = constants[key][-1]
            every.append(f"{key}.<name>.{spelling}" if kind.scene_table else spelling)
    out[""] = f"the penalty constants ({', '.join(every)})"
    return out


@dataclass(frozen=True)
class PenaltyError:
    """The estimate of ``penalty_error``."""

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
    #: Above the warning: the scene key of the kind of penalty whose stiffening alone moves
    #: the result most (``centerline``, ``lumen``, ``joint``, ``obstacles``); else empty.
    dominant: str = ""

    @property
    def warning(self) -> bool:
        """True when the estimate exceeds ``TRUST_WARNING`` (or could not be made)."""
        return not self.error <= TRUST_WARNING

    def text(self, prefix: str = "") -> str:
        """The CLI's summary line (and its warning); ``prefix`` after the label (e.g.
        ``"last step: "``)."""
        if self.penalties == 0:
            return f"penalty     {prefix}none in this scene (no penalty error)"
        if not np.isfinite(self.error):
            return (f"penalty     {prefix}error estimate unavailable: the solve with penalties ×"
                    f"{self.factor:g} failed (warning: the result may depend on a penalty)")
        size = self.error * self.length
        line = (f"penalty     {prefix}error ≈ {self.error:.2g} L ({size:.2g} m; "
                f"from a re-solve with every penalty ×{self.factor:g})")
        if self.warning:
            advice = penalty_advice()
            line += (f"\nwarning     the penalty error exceeds {TRUST_WARNING:g} L: raise "
                     f"{advice.get(self.dominant, advice[''])} and compare")
        return line


def stiffer_scene(scene: Scene, factor: float,
                  only: str | None = None) -> tuple[dict[str, Any], int]:
    """The resolved scene dict with every constraint-penalty constant
    (``penalty_constants``; ``only``: those of that scene key alone) multiplied by
    ``factor``, and how many constants were scaled."""
    data = copy.deepcopy(scene.data)
    constants = penalty_constants()
    count = 0
    for owner in ("rods", "tendons"):
        for table in data.get(owner, {}).values():
            for term in table.get("terms", []):
                options = table.get(term)
                if (term not in constants or not isinstance(options, dict)
                        or only not in (None, term)):
                    continue
                count += _scale_first(options, constants[term], factor)
    for kind in registered_terms().values():  # terms built from a top-level table
        if kind.scene_table and kind.constraint_constant and only in (None, kind.scene_table):
            for table in data.get(kind.scene_table, {}).values():
                count += _scale_first(table, constants[kind.scene_table], factor)
    return data, count


def _scale_first(options: dict[str, Any], spellings: tuple[str, ...], factor: float) -> int:
    """Multiply the first of ``spellings`` set (non-zero) in ``options`` by ``factor`` (the
    one in use: an absolute value of 0 means "from the relative one"); 1 if one was."""
    for key in spellings:
        if options.get(key):
            options[key] = float(options[key]) * factor
            return 1
    return 0


def penalty_error(result: Result, factor: float = 10.0,
                  model: Model | None = None) -> PenaltyError:
    """Estimate how far ``result`` (a converged run) is from the penalty-free equilibrium by
    one warm static solve with every penalty ×``factor`` (module docstring). ``model``: the
    model ``result`` was solved with, when its friction anchors are not the rest state (a
    track's step): the stiffer solve keeps them (``Model.with_scene``). Above
    ``TRUST_WARNING``, one more solve per kind of penalty (each alone ×``factor``)
    names the one that moves the result most (``dominant``)."""
    length = _longest(result)
    data, count = stiffer_scene(result.scene, factor)
    if count == 0:
        return PenaltyError(0.0, 0.0, factor, length, 0)
    change = _change(result, data, model)
    if not np.isfinite(change):
        return PenaltyError(float("nan"), float("nan"), factor, length, count)
    error = change * factor / (factor - 1.0) / length
    dominant = ""
    if error > TRUST_WARNING:
        kinds = {key: stiffer_scene(result.scene, factor, only=key)
                 for key in penalty_constants()}
        changes = {key: _change(result, scaled, model)
                   for key, (scaled, scaled_count) in kinds.items() if scaled_count}
        if len(changes) > 1:
            dominant = max(changes, key=lambda key: np.nan_to_num(changes[key], nan=-1.0))
        elif changes:
            dominant = next(iter(changes))
    return PenaltyError(error, change, factor, length, count, dominant)


def _change(result: Result, data: dict[str, Any], model: Model | None) -> float:
    """The largest control-point move [m] of a warm static solve of the scene ``data`` from
    ``result``'s state (NaN when it fails), in its own budget: never more than the scene's,
    nor above twice the run (``BUDGET_FLOOR`` at least)."""
    from rodsim.app.api import load_scene, solve

    data["solver"]["max_wall_time"] = min(
        float(result.scene.solver.max_wall_time),
        max(BUDGET_FLOOR, 2.0 * result.stats.get("wall_time", 0.0)))
    scene: Scene | dict[str, Any] = data
    stiffer_model = None
    if model is not None:
        scene = load_scene(data)
        stiffer_model = model.with_scene(scene)
    stiffer = solve(scene, DEFAULT_INTEGRATOR, model=stiffer_model, initial_state=result.state)
    if not stiffer.success:
        return float("nan")
    return largest_move(result, stiffer)


def largest_move(result: Result, stiffer: Result) -> float:
    """The largest control-point distance [m] between ``result`` and ``stiffer`` (a solve
    of the same scene with stiffer penalties)."""
    return max(float(np.max(np.linalg.norm(stiffer.rods[name].positions - shape.positions,
                                           axis=1)))
               for name, shape in result.rods.items())


def penalty_estimate(result: Result, stiffer: Result, factor: float) -> float:
    """``penalty_error``'s estimate [L] from ``result`` and the converged solve ``stiffer``
    of its scene with every penalty ×``factor`` (a batch case's: rodsim/app/batch_penalty.py)."""
    return largest_move(result, stiffer) * factor / (factor - 1.0) / _longest(result)


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
    """The CLI's warning lines for ``tendon_compression``."""
    return "\n".join(
        f"warning     tendon {name} is in compression ({force:.3g} N at its most compressed "
        "segment): a tendon cannot push; the scene is not physical (docs/tendon.md)"
        for name, force in compressed.items())


@dataclass(frozen=True)
class Estimates:
    """What ``assess`` found: the penalty and the discretisation error estimates."""

    penalty: PenaltyError
    discretisation: DiscretisationError

    @property
    def warning(self) -> bool:
        """True when either estimate exceeds ``TRUST_WARNING`` (or could not be made)."""
        return self.penalty.warning or self.discretisation.warning

    def text(self, prefix: str = "") -> str:
        """The CLI's summary lines, each estimate's after its label with ``prefix`` (e.g.
        ``"last step: "``)."""
        return self.discretisation.text(prefix) + "\n" + self.penalty.text(prefix)


def assess(result: Result, model: Model | None = None) -> Estimates:
    """Estimate ``result``'s discretisation and penalty errors and check its tendons for
    compression, storing them on it (``discretisation_error``, ``penalty_error``,
    ``tendon_compression``: the run archive's attributes); returns the estimates. What
    ``rodsim run``, ``fit`` and ``reach`` do with their result (``model``: see
    ``penalty_error``)."""
    penalty = penalty_error(result, model=model)
    discretisation = discretisation_error(result, model=model)
    result.penalty_error = penalty.error
    result.discretisation_error = discretisation.error
    result.tendon_compression = tendon_compression(result)
    return Estimates(penalty, discretisation)


def last_step_result(track: Any) -> Result | None:
    """The last completed step of a ``rodsim.app.inverse.track.Track`` as a static
    result (a warm solve of the scene at that step's values from that step's state: already
    at equilibrium, so one Newton iteration), for ``assess``; None without a step or
    when that solve fails."""
    from rodsim.app.api import build_model, solve

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
    model = last_model.with_values(scene) if last_model is not None else build_model(scene)
    # The free coordinates are offsets from that model's rest state (Model.state_of).
    result = solve(scene, DEFAULT_INTEGRATOR, model=model,
                   initial_state=model.state_of(track.states[-1]))
    return result if result.success else None
