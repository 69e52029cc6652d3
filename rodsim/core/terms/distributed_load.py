"""A load per unit length in the world frame (not in the paper), besides self-weight.

    V = −∫ q(s) · r(s) ds  ≈  −Σ_i F_i · r_i,   F_i = ∫ q(s) N_i(s) ds

q(s) [N/m] is ``force_per_length`` over the whole rod plus each of the ``spans``' own
``force_per_length`` on [start, end]. r(s) is the linear interpolation between control
points, so each control point gets the consistent share F_i of the load (N_i its hat
function, ``rodsim.core.rod.geometry.RodGeometry.hat_integrals``); for a load on the
whole rod that is the lumping of ``gravity`` (half a segment at each end), to the last bit.
A dead load: no Jacobian entries.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter, SceneError, shown
from rodsim.core.terms._dead_load import NodalDeadLoad

SPAN_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("start", "float", None, "m", "rest arclength where the span starts", 0.0, 100.0),
    Parameter("end", "float", None, "m", "rest arclength where the span ends (> start, <= L)",
              0.0, 100.0),
    Parameter("force_per_length", "vector", None, "N/m", "load per unit length on the span",
              -1e9, 1e9, length=3),
)


@dataclass(frozen=True, kw_only=True)
class DistributedLoadOptions(Options):
    """The options of the ``distributed_load`` term: one field per
    parameter, checked against them when the term class is defined."""

    force_per_length: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    spans: list[dict[str, Any]] = field(default_factory=list)


class DistributedLoad(NodalDeadLoad):
    """Constant or piecewise-constant force per unit length, world frame."""

    name = "distributed_load"
    figure_layer = "load"
    Options = DistributedLoadOptions
    options: DistributedLoadOptions
    equation = "load per length (not in the paper); enters F_net of Eq. (17)"
    parameters = (
        Parameter("force_per_length", "vector", [0.0, 0.0, 0.0], "N/m",
                  "load per unit length on the whole rod, world frame", -1e9, 1e9, length=3),
        Parameter("spans", "tables", [], "-",
                  "more load on parts of the rod, one [[rods.<name>.distributed_load.spans]] "
                  "table each (added to force_per_length)", items=SPAN_PARAMETERS),
    )

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        for i, span in enumerate(options.spans):
            key = f"{prefix}.spans.{i}"
            if not span["start"] < span["end"]:
                raise SceneError(f"{key}: start = {shown(span['start'])} is not below end = "
                                 f"{shown(span['end'])}; allowed: start < end", key=key,
                                 reason="empty span")
            if span["end"] > owner.length:
                raise SceneError(f"{key}.end = {shown(span['end'])}: beyond the rod's length "
                                 f"{owner.length!r} m; allowed: end <= length",
                                 key=f"{key}.end", value=span["end"], reason="out of range")

    def nodal_forces(self, rod: Rod, options: Any) -> np.ndarray:
        geometry = rod.geometry
        uniform = np.asarray(options.force_per_length, dtype=float)
        forces = geometry.node_mass_fraction[:, None] * uniform[None, :]
        for span in options.spans:
            share = geometry.hat_integrals(span["start"], span["end"])
            forces += share[:, None] * np.asarray(span["force_per_length"])[None, :]
        return forces
