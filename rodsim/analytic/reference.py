"""Continuum references for a scene: which analytic solution a run can be scored against.

A scene qualifies when its first rod is a cantilever (``frame`` or ``first_segment``
clamp, rest along +x) loaded only by a dead tip force along −y (``tip_load`` without
``force``, no ``gravity``) — the paper's hanging-mass experiment (Figs. 5–9).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rodsim.analytic.elastica import ElasticaShape, exact_elastica, load_parameter
from rodsim.analytic.extensible import extensible_elastica
from rodsim.analytic.paper_model import paper_model
from rodsim.model import Model
from rodsim.scene import Scene

__all__ = ["CantileverReference", "cantilever_reference"]


@dataclass(frozen=True)
class CantileverReference:
    """Analytic shapes of the scene's first rod: corrected paper model, exact elastica, and
    the extensible elastica with the rod's own E_s A."""

    force: float
    bending_stiffness: float
    length: float
    paper: ElasticaShape
    exact: ElasticaShape
    extensible: ElasticaShape

    @property
    def alpha(self) -> float:
        """Load parameter α = F L² / (2 E I) (paper §3, corrected)."""
        return load_parameter(self.force, self.bending_stiffness, self.length)

    def tip_error(self, positions: np.ndarray, shape: str = "exact") -> float:
        """|tip − reference tip| / L, the paper's accuracy metric (Figs. 6–7)."""
        ref = getattr(self, shape)
        return float(np.hypot(positions[-1, 0] - ref.x[-1], positions[-1, 1] - ref.y[-1])
                     / self.length)


def cantilever_reference(scene: Scene, samples: int = 201) -> CantileverReference | None:
    """The references for ``scene``'s first rod, or ``None`` if the scene does not qualify."""
    name, rod = next(iter(scene.data["rods"].items()))
    if len(scene.data["rods"]) > 1 or "tip_load" not in rod["terms"] or "gravity" in rod["terms"]:
        return None
    load = rod["tip_load"]
    if any(load["force"]) or rod["origin"] != [0.0, 0.0, 0.0]:
        return None
    model_rod = Model(scene).rods[name]
    force = load["mass"] * load["gravity"]
    ei, length = model_rod.bending_stiffness, model_rod.length
    if force <= 0.0:
        return None
    s = np.linspace(0.0, length, samples)
    return CantileverReference(
        force, ei, length, paper_model(force, ei, length, samples),
        exact_elastica(force, ei, length, s),
        extensible_elastica((0.0, -force), ei, model_rod.stretch_stiffness, length, s))
