"""Constant-curvature limit of a tendon-driven catheter (DESIGN erratum 6).

A straight-routed tendon with tension T at offset r_L from the centerline loads the catheter,
through its distributed lumen contact and its tip attachment, with a constant bending
moment T r_L and an axial compression T. With the penalties of the momentum-conserving
coupling growing, the catheter therefore tends to an arc of curvature

    κ = T r_L / (E I),

of rest length L shortened by the axial strain T / (E_s A): at rest arc length s the point
is at θ = κ s (1 − T/(E_s A)), x = sin θ / κ, and a distance (1 − cos θ)/κ towards the
tendon's side.
"""

from __future__ import annotations

import numpy as np

from rodsim.analytic.elastica import ElasticaShape

__all__ = ["tendon_arc"]


def tendon_arc(tension: float, offset: float, bending_stiffness: float,
               stretch_stiffness: float, length: float,
               s: np.ndarray | None = None) -> ElasticaShape:
    """The arc as an :class:`ElasticaShape` (x along the clamp axis, y towards the tendon).

    ``tip_angle`` is the arc's total turning κ L (1 − T/(E_s A)) [rad].
    """
    for name, value in (("tension", tension), ("offset", offset),
                        ("bending_stiffness", bending_stiffness),
                        ("stretch_stiffness", stretch_stiffness), ("length", length)):
        if not np.isfinite(value) or value < 0 or (value == 0 and name != "tension"):
            raise ValueError(f"{name} = {value!r}: must be finite and positive")
    s = np.linspace(0.0, length, 201) if s is None else np.asarray(s, dtype=float)
    stretch = 1.0 - tension / stretch_stiffness
    kappa = tension * offset / bending_stiffness
    angle = kappa * s * stretch
    if kappa == 0.0:
        return ElasticaShape(s, s * stretch, np.zeros_like(s), 0.0)
    return ElasticaShape(s, np.sin(angle) / kappa, (1.0 - np.cos(angle)) / kappa,
                         float(kappa * length * stretch))
