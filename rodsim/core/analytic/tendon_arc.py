"""Constant-curvature limit of a tendon-driven catheter (docs/design.md, erratum 6).

A straight-routed tendon with tension T at offset r_L from the centerline loads the catheter,
through its distributed lumen contact and its tip attachment, with a constant bending
moment T r_L and an axial compression T. With the penalties of the momentum-conserving
coupling growing, catheter and tendon bend together, the moment carried by both bending
stiffnesses, into an arc of curvature

    κ = T r_L / (E I_catheter + E I_tendon)

per unit *rest* arc length (the strains of Eqs. 3–7 are measured along the rest length),
with the centerline shortened by the axial strain ε = T / (E_s A): at rest arc length s,
θ = κ s, x = (1 − ε) sin θ / κ, and (1 − ε)(1 − cos θ)/κ towards the tendon's side. This is
the continuum limit of rodsim's own equations; the simpler form θ = κ s (1 − ε) with the
catheter's E I alone differs from it by two ~0.3 % effects (docs/tendon.md).
"""

from __future__ import annotations

import numpy as np

from rodsim.core.analytic.elastica import ElasticaShape

__all__ = ["tendon_arc"]


def tendon_arc(tension: float, offset: float, bending_stiffness: float,
               stretch_stiffness: float, length: float,
               s: np.ndarray | None = None) -> ElasticaShape:
    """The arc as an ``ElasticaShape`` (x along the clamp axis, y towards the tendon).

    ``bending_stiffness`` is the sum of the catheter's and the tendon's E I [N m²];
    ``stretch_stiffness`` the catheter's E_s A [N]. ``tip_angle`` is the arc's total turning
    κ L [rad].
    """
    for name, value in (("tension", tension), ("offset", offset),
                        ("bending_stiffness", bending_stiffness),
                        ("stretch_stiffness", stretch_stiffness), ("length", length)):
        if not np.isfinite(value) or value < 0 or (value == 0 and name != "tension"):
            raise ValueError(f"{name} = {value!r}: must be finite and positive")
    s = np.linspace(0.0, length, 201) if s is None else np.asarray(s, dtype=float)
    stretch = 1.0 - tension / stretch_stiffness
    kappa = tension * offset / bending_stiffness
    angle = kappa * s
    if kappa == 0.0:
        return ElasticaShape(s, s * stretch, np.zeros_like(s), 0.0)
    return ElasticaShape(s, stretch * np.sin(angle) / kappa,
                         stretch * (1.0 - np.cos(angle)) / kappa, float(kappa * length))
