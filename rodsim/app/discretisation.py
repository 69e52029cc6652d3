"""How far a result is from the continuum rod: an a-posteriori estimate of its discretisation
error (docs/model.md, "The discretisation-error estimate").

The discretisation (paper §2.2: nodes r_j, segment quaternions q_j, the bending elements
between them, Eqs. 3-9) converges at order p = 2 in the segment length h: an equilibrium
x(h) ≈ x(0) + C h². One warm solve of the same scene with every rod at about half its
segments (h_c = r h, r ≈ 2: ``coarser_nodes``) gives x(r h), and Richardson's
extrapolation

    x(h) − x(0) ≈ (x(h) − x(r h)) / (r² − 1),      x(0) ≈ x(h) + (x(h) − x(r h)) / (r² − 1),

compared at the coarse nodes' arc lengths (the fine shape interpolated there by a cubic
spline in s, whose own error is O(h⁴)), reported as the largest distance over every node
of every rod, in units of the longest rod's length L. The order 2 is the discretisation's
observed order (docs/model.md, measured on the user family of tests/test_error_estimates.py);
it is stated with the estimate, not fitted per run: a per-run order would need a third solve.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from rodsim.core.cubic_spline import cubic_spline
from rodsim.core.model import Model
from rodsim.core.scene import Scene, SceneError
from rodsim.solvers import DEFAULT_INTEGRATOR
from rodsim.solvers.result import Result

__all__ = ["BUDGET_FLOOR", "ORDER", "TRUST_WARNING", "DiscretisationError", "coarser_nodes",
           "discretisation_error"]

#: The discretisation's order in the segment length, used by the extrapolation (measured:
#: docs/model.md, "The discretisation-error estimate").
ORDER = 2.0

#: Above this estimate (in units of L) a result is flagged (the penalty estimate's threshold,
#: rodsim/app/trust.py).
TRUST_WARNING = 1e-3

#: The least wall-time budget [s] of an estimate's extra solve (else twice the run's, never
#: more than the scene's): where a warm start fails, the static solve starts over from rest,
#: which on a tendon scene can take several seconds on a loaded machine.
BUDGET_FLOOR = 60.0

#: The coarse solves' target ratios of segment length to the result's: two, so that a
#: coarse solve that happens to land near the result (a tendon's termination or a section
#: boundary whose place between nodes changes the error's constant) does not hide the error:
#: their mean is reported, never below half the larger (docs/model.md).
RATIOS = (2.0, 1.5)

#: How many coarse node counts are tried per ratio when the scene refuses one.
ATTEMPTS = 8

#: The fewest nodes a coarse rod may have (the schema's minimum, rodsim/core/rod/rod.py).
MIN_NODES = 3


@dataclass(frozen=True)
class DiscretisationError:
    """The estimate of ``discretisation_error``."""

    #: Estimated distance of the result from the continuum rod's equilibrium, in units of L
    #: (NaN when the coarse solve could not be made or failed; see ``reason``).
    error: float
    #: The length L the error is measured in [m].
    length: float
    #: The ratio of the coarse segment length to the result's, r (the smallest over rods),
    #: of the first coarse solve (which gives ``nodes`` and ``extrapolated``).
    ratio: float
    #: The node count of each rod in that coarse solve.
    nodes: dict[str, int] = field(default_factory=dict)
    #: The Richardson-extrapolated positions (N, 3) [m] of each rod at the result's nodes.
    extrapolated: dict[str, np.ndarray] = field(default_factory=dict)
    #: CPU time of the coarse solve [s].
    cpu_time: float = 0.0
    #: Why there is no estimate (empty when there is one).
    reason: str = ""
    #: (r, estimate in units of L) of each coarse solve made.
    levels: tuple[tuple[float, float], ...] = ()
    #: True when the coarse scene was refused (e.g. a support no longer on a node).
    refused: bool = False

    @property
    def order(self) -> float:
        """The order the extrapolation assumes (``ORDER``)."""
        return ORDER

    @property
    def warning(self) -> bool:
        """True when the estimate exceeds ``TRUST_WARNING`` (or could not be made)."""
        return not self.error <= TRUST_WARNING

    def text(self, prefix: str = "") -> str:
        """The CLI's summary line (and its warning); ``prefix`` after the label."""
        if not np.isfinite(self.error):
            return (f"discretis.  {prefix}error estimate unavailable: {self.reason} "
                    "(warning: compare with a run at twice the nodes)")
        size = self.error * self.length
        line = (f"discretis.  {prefix}error ≈ {self.error:.2g} L ({size:.2g} m; Richardson at "
                f"order {ORDER:g} from re-solves at about 1/2 and 2/3 of the nodes)")
        if self.warning:
            line += (f"\nwarning     the discretisation error exceeds {TRUST_WARNING:g} L: raise "
                     "the rods' nodes (rods.<name>.nodes; the error falls as N^-2)")
        return line


def coarser_nodes(nodes: int, ratio: float = 2.0) -> int:
    """About 1/``ratio`` of the segments of a rod of ``nodes`` nodes: round((N − 1)/ratio) +
    1 nodes, at least ``MIN_NODES``."""
    return max(MIN_NODES, int(np.floor((nodes - 1) / ratio + 0.5)) + 1)


def coarser_scene(scene: Scene, target: float = 2.0,
                  attempt: int = 0) -> tuple[dict[str, Any], dict[str, int], float]:
    """The resolved scene dict with every rod at about 1/``target`` of its segments, the
    coarse node counts and the smallest ratio r of coarse to fine segment length over the
    rods. ``attempt`` k takes each rod's k-th count by closeness to ``coarser_nodes``
    among those with a ratio in [1.25, 2.6] (a support must stay on a node: the next
    attempt when a scene is refused)."""
    data = copy.deepcopy(scene.data)
    nodes: dict[str, int] = {}
    ratio = np.inf
    for name, table in data.get("rods", {}).items():
        fine = int(table["nodes"])
        nodes[name] = _candidates(fine, target)[attempt] if attempt else coarser_nodes(fine,
                                                                                     target)
        table["nodes"] = nodes[name]
        ratio = min(ratio, (fine - 1) / (nodes[name] - 1))
    _resample_friction_points(scene, data)
    return data, nodes, float(ratio)


def _string_points(model: Model) -> dict[str, np.ndarray]:
    """The rest arc lengths of each string tendon's routing points in ``model``."""
    from rodsim.core.terms.tendon_string import TendonString

    return {term.tendon.name: term.points.s for term in model.terms
            if isinstance(term, TendonString)}


def _resample_friction_points(scene: Scene, data: dict[str, Any]) -> None:
    """Give every string tendon's ``friction_points`` (one μ per routing point, so as many
    as the fine rod's points) the coarse rod's count in ``data``: each coarse point takes
    the μ of the fine point nearest to it in arc length."""
    tables = {name: table["tendon_string"] for name, table in data.get("tendons", {}).items()
              if isinstance(table.get("tendon_string"), dict)
              and table["tendon_string"].get("friction_points")}
    if not tables:
        return
    probe = copy.deepcopy(data)
    for name in tables:  # the coarse points without the fine values (their count differs)
        for key in ("friction_points", "static_friction"):
            probe["tendons"][name]["tendon_string"].pop(key, None)
    try:
        fine, coarse = _string_points(Model(scene)), _string_points(Model(Scene.from_dict(
            probe)))
    except SceneError:
        return  # the coarse scene is refused anyway, and says why
    for name, table in tables.items():
        values = np.asarray(table["friction_points"], dtype=float)
        nearest = np.argmin(np.abs(coarse[name][:, None] - fine[name][None, :]), axis=1)
        table["friction_points"] = [float(v) for v in values[nearest]]


def _candidates(fine: int, target: float) -> list[int]:
    """Coarse node counts of a rod of ``fine`` nodes, closest to 1/``target`` of its segments
    first, with ratios in [1.25, 2.6] (the nearest one alone when none is); repeated to
    ``ATTEMPTS`` entries."""
    best = coarser_nodes(fine, target)
    counts = sorted((m for m in range(MIN_NODES, fine) if 1.25 <= (fine - 1) / (m - 1) <= 2.6),
                    key=lambda m: (abs(m - best), m))
    counts = counts or [best]
    return [counts[min(k, len(counts) - 1)] for k in range(ATTEMPTS)]


def discretisation_error(result: Result, model: Model | None = None) -> DiscretisationError:
    """Estimate how far ``result`` (a converged run) is from the continuum equilibrium by
    static solves at about 1/2 and 2/3 of the segments (``RATIOS``), each started from
    ``result``'s shape, and the mean of their Richardson estimates (module docstring); the
    extrapolated shape is the first one's.
    ``model``: the model ``result`` was solved with (unused: the layout changes, and a
    friction model's coarse anchors are the coarse model's own rest state)."""
    length = max(float(shape.s[-1]) for shape in result.rods.values())
    started = time.process_time()
    made: list[DiscretisationError] = []
    for target in RATIOS:
        for attempt in range(ATTEMPTS):
            data, nodes, ratio = coarser_scene(result.scene, target, attempt)
            if ratio <= 1.0 or any(level.ratio == ratio for level in made):
                level = None
                break
            level = _level(result, data, nodes, ratio, length)
            if not level.refused:
                break
        if level is None:
            continue
        if not np.isfinite(level.error):
            return replace(level, cpu_time=time.process_time() - started)
        made.append(level)
    cpu = time.process_time() - started
    if not made:
        return DiscretisationError(float("nan"), length, 1.0, reason=(
            f"a rod has {MIN_NODES} nodes: none fewer to compare"), cpu_time=cpu)
    return replace(made[0], error=float(np.mean([level.error for level in made])),
                   cpu_time=cpu, levels=tuple((level.ratio, level.error) for level in made))


def _level(result: Result, data: dict[str, Any], nodes: dict[str, int], ratio: float,
           length: float) -> DiscretisationError:
    """The Richardson estimate from one coarse solve of the scene ``data``."""
    from rodsim.app.api import load_scene, solve

    # its own budget: never more than the scene's, nor above twice the run (a floor at least)
    data["solver"]["max_wall_time"] = min(
        float(result.scene.solver.max_wall_time),
        max(BUDGET_FLOOR, 2.0 * result.stats.get("wall_time", 0.0)))
    counts = ", ".join(f"{name} {count}" for name, count in nodes.items())
    try:
        coarse_scene = load_scene(data)
    except SceneError as exc:
        return DiscretisationError(float("nan"), length, ratio, nodes, reason=(
            f"the scene at {counts} nodes is refused: {exc}"), refused=True)
    coarse_model = Model(coarse_scene)
    coarse = solve(coarse_scene, DEFAULT_INTEGRATOR, model=coarse_model,
                   initial_state=warm_state(result, coarse_model))
    if not coarse.success:
        coarse = solve(coarse_scene, result.integrator)
    if not coarse.success:
        return DiscretisationError(float("nan"), length, ratio, nodes, reason=(
            f"the solve at {counts} nodes failed: {coarse.message}"))
    factor = 1.0 / (ratio**ORDER - 1.0)
    change = 0.0
    extrapolated: dict[str, np.ndarray] = {}
    for name, shape in result.rods.items():
        other = coarse.rods[name]
        fine_at_coarse = cubic_spline(shape.s, shape.positions)(other.s)
        change = max(change, float(np.max(np.linalg.norm(fine_at_coarse - other.positions,
                                                         axis=1))))
        coarse_at_fine = cubic_spline(other.s, other.positions)(shape.s)
        extrapolated[name] = shape.positions + factor * (shape.positions - coarse_at_fine)
    return DiscretisationError(change * factor / length, length, ratio, nodes, extrapolated)


def warm_state(result: Result, coarse: Model) -> np.ndarray:
    """The free coordinates of ``coarse`` (the scene at fewer nodes) from ``result``'s shape:
    positions at the coarse nodes' arc lengths and quaternions at the coarse segments'
    midpoints, by cubic splines in s (quaternions made of one sign along the rod first, then
    normalised); fixed coordinates from the coarse model's rest state."""
    full = coarse.rest_full.copy()
    for name, rod in coarse.rods.items():
        shape = result.rods[name]
        full[rod.layout.position_index] = cubic_spline(shape.s, shape.positions)(
            rod.geometry.node_s)
        quaternions = np.array(shape.quaternions, dtype=float)
        flips = np.cumprod(np.where(np.sum(quaternions[1:] * quaternions[:-1], axis=1) < 0,
                                    -1.0, 1.0))
        quaternions[1:] *= flips[:, None]
        if len(shape.segment_s) > 1:
            q = cubic_spline(shape.segment_s, quaternions)(rod.geometry.segment_s)
        else:
            q = np.repeat(quaternions, len(rod.geometry.segment_s), axis=0)
        full[rod.layout.quaternion_index] = q / np.linalg.norm(q, axis=1, keepdims=True)
    return coarse.state_of(full)
