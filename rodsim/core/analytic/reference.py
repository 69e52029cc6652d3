"""Continuum references for a scene: which analytic solution a run can be scored against.

A hanging-mass scene qualifies when its first rod is a uniform cantilever (rest along +x;
sections that change along it rule the references out, a uniform set of sections is read
through the rod's E I and E_s A) loaded only by a dead tip force along −y (``tip_load``
without ``force``, no ``gravity``) — the paper's experiment of Figs. 5–9. A tendon scene
qualifies for the constant-curvature arc when it has one tendon pulled at its base (the
physical check of the conserving coupling).

The references read the rods' constants (E I, E_s A, L, the base) from the scene alone
(``scene_rods``): no model is assembled, no kernel loaded.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from rodsim.core.base_places import base_place
from rodsim.core.model import scene_rod
from rodsim.core.rod.layout import RodLayout
from rodsim.core.rod.rod import Rod
from rodsim.core.scene import Scene
from rodsim.core.tendon import Tendon

if TYPE_CHECKING:
    from rodsim.core.analytic.elastica import ElasticaShape

# The continuum models (rodsim.core.analytic.elastica, extensible, paper_model, tendon_arc)
# are imported where a scene qualifies: they import scipy.integrate, scipy.optimize and
# scipy.special, which a run of a scene without references never needs.

__all__ = ["CantileverReference", "cantilever_reference", "REFERENCE_KINDS",
           "reference_centerline", "scene_rods"]


def scene_rods(scene: Scene, names: tuple[str, ...]) -> dict[str, Rod]:
    """The rods ``names`` of ``scene`` (and the catheters or joint parents their bases are
    placed on), with their constants and base supports as a model builds them, but no
    model: no layout in a state vector, no terms, no assembly."""
    rods: dict[str, Rod] = {}

    def build(name: str) -> Rod:
        if name not in rods:
            parent = base_place(scene, name).parent(scene, name)
            if parent is not None:
                build(parent)
            rods[name] = scene_rod(scene, name, RodLayout(scene.rods[name].nodes, 0), rods)
        return rods[name]

    return {name: build(name) for name in names}


@dataclass(frozen=True)
class CantileverReference:
    """Analytic shapes of the scene's first rod: corrected paper model, exact elastica, and
    the extensible elastica with the rod's own E_s A (``None`` when the tip force reaches
    E_s A, where ``extensible_elastica`` has no solution)."""

    force: float
    bending_stiffness: float
    length: float
    paper: ElasticaShape
    exact: ElasticaShape
    extensible: ElasticaShape | None

    @property
    def alpha(self) -> float:
        """Load parameter α = F L² / (2 E I) (paper §3, corrected)."""
        from rodsim.core.analytic.elastica import load_parameter

        return load_parameter(self.force, self.bending_stiffness, self.length)

    def tip_error(self, positions: np.ndarray, shape: str = "exact") -> float:
        """|tip − reference tip| / L, the paper's accuracy metric (Figs. 6–7); NaN when the
        reference does not exist."""
        ref = getattr(self, shape)
        if ref is None:
            return float("nan")
        return float(np.hypot(positions[-1, 0] - ref.x[-1], positions[-1, 1] - ref.y[-1])
                     / self.length)


def cantilever_reference(scene: Scene, samples: int = 201) -> CantileverReference | None:
    """The references for ``scene``'s first rod, or ``None`` if the scene does not qualify."""
    rods = scene.rods
    name, rod = next(iter(rods.items()))
    if len(rods) > 1 or "tip_load" not in rod.terms or "gravity" in rod.terms:
        return None
    load = scene.term_options("rods", name, "tip_load")
    if any(load.force) or rod.origin != [0.0, 0.0, 0.0]:
        return None
    model_rod = scene_rods(scene, (name,))[name]
    if model_rod.varying:  # the references are for a uniform rod
        return None
    force = load.mass * load.gravity
    ei, length = model_rod.bending_stiffness, model_rod.length
    if force <= 0.0:
        return None
    from rodsim.core.analytic.elastica import exact_elastica
    from rodsim.core.analytic.extensible import extensible_elastica
    from rodsim.core.analytic.paper_model import paper_model

    s = np.linspace(0.0, length, samples)
    stretch = model_rod.stretch_stiffness
    return CantileverReference(
        force, ei, length, paper_model(force, ei, length, samples),
        exact_elastica(force, ei, length, s),
        extensible_elastica((0.0, -force), ei, stretch, length, s) if force < stretch else None)


#: Continuum references a study can score its first rod against.
REFERENCE_KINDS = ("exact", "paper", "extensible", "arc")


@lru_cache(maxsize=16)
def _fine_paper_model(force: float, ei: float, length: float) -> ElasticaShape:
    """The paper's model at 2001 points in φ (4000 quadratures, ~40 ms), remembered per
    process: the points of a study that sweeps N or K_P share their load (fig7b's seven
    points computed it seven times). Only read (interpolated) by its caller."""
    from rodsim.core.analytic.paper_model import paper_model

    return paper_model(force, ei, length, 2001)


def reference_centerline(scene: Scene, kind: str, s: np.ndarray) -> np.ndarray | None:
    """Reference positions (len(s), 3) [m] of the scene's first rod at rest arc lengths ``s``.

    ``exact``, ``paper`` and ``extensible`` need a hanging-mass cantilever (see
    ``cantilever_reference``); ``arc`` needs a single tendon pulled at its base
    (``rodsim.core.analytic.tendon_arc.tendon_arc``). Returns ``None`` when the scene does
    not qualify.
    """
    if kind not in REFERENCE_KINDS:
        raise ValueError(f"unknown reference {kind!r}; known: {', '.join(REFERENCE_KINDS)}")
    out = np.zeros((len(s), 3))
    if kind == "arc":
        tendons = scene.tendons
        if len(tendons) != 1:
            return None
        (name, options), = tendons.items()
        actuation = scene.term_options("tendons", name, "tendon_actuation")
        if actuation is None or actuation.point != "proximal":
            return None
        if options.catheter != next(iter(scene.rods)):
            return None
        rods = scene_rods(scene, (options.catheter, name))
        catheter = rods[options.catheter]
        if catheter.varying:
            return None
        from rodsim.core.analytic.tendon_arc import tendon_arc

        shape = tendon_arc(actuation.force, options.offset,
                           catheter.bending_stiffness + rods[name].bending_stiffness,
                           catheter.stretch_stiffness, catheter.length, s)
        tendon = Tendon.of(name, rods, options)
        alpha, beta = tendon.alpha, tendon.beta
        out[:, 0] = shape.x
        out[:, 1] = alpha * shape.y
        out[:, 2] = beta * shape.y
        return out + catheter.origin
    reference = cantilever_reference(scene)
    if reference is None:
        return None
    from rodsim.core.analytic.elastica import ElasticaShape, exact_elastica
    from rodsim.core.analytic.extensible import extensible_elastica

    length = reference.length
    force, ei = reference.force, reference.bending_stiffness
    if kind == "exact":
        shape = exact_elastica(force, ei, length, s)
    elif kind == "extensible":
        first = next(iter(scene.rods))
        stretch = scene_rods(scene, (first,))[first].stretch_stiffness
        if force >= stretch:
            return None
        shape = extensible_elastica((0.0, -force), ei, stretch, length, s)
    else:  # the paper's model is sampled in φ: interpolate it at s
        fine = _fine_paper_model(force, ei, length)
        shape = ElasticaShape(s, np.interp(s, fine.s, fine.x), np.interp(s, fine.s, fine.y),
                              fine.tip_angle)
    out[:, 0], out[:, 1] = shape.x, shape.y
    return out
