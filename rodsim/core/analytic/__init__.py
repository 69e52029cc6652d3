"""Continuum references for validating the discrete Cosserat rod (docs/design.md, erratum 9, §4).

All three describe a cantilever clamped at the origin, pointing along +x when unloaded, in
SI units, and return an ``ElasticaShape`` (rest arc length s, world x and y, tip angle
positive downward):

- ``exact_elastica`` -- the inextensible, unshearable elastica under a dead tip load along
  -y, in closed form with elliptic integrals. The reference for discretization error.
- ``paper_model`` -- the paper's analytical model, Eqs. (21)-(23), by quadrature, with
  Eq. (22) corrected; ``paper_model_as_printed`` keeps the printed (wrong) Eq. (22) to
  document the erratum, and ``tip_angle_from_load`` solves Eq. (21) for phi0.
- ``extensible_elastica`` -- the extensible Kirchhoff elastica (axial stiffness EA) under
  any constant tip force (Fx, Fy), solved by shooting to ~1e-12. The reference for rods whose
  stretch matters (Table 1's E_s) and for inclined loads; EA = inf is the exact elastica.

``tendon_arc`` is the constant-curvature limit of a catheter bent by a tendon under
tension (the physical check of the momentum-conserving tendon coupling).

``tendon_rod`` is the Rucker–Webster rod driven by frictionless tendons of general
routing ending anywhere, with piecewise sections and a tip wrench, solved by shooting to
~1e-12 (the reference of the string tendon; ``scene_reference`` reads a scene).

``load_parameter`` is the paper's alpha = F L^2 / (2 EI) (printed with 2 E L).
See docs/analytic.md.
"""

from rodsim.core.analytic.elastica import ElasticaShape, exact_elastica, load_parameter
from rodsim.core.analytic.extensible import ExtensibleShape, extensible_elastica
from rodsim.core.analytic.paper_model import (
    paper_model,
    paper_model_as_printed,
    tip_angle_from_load,
)
from rodsim.core.analytic.tendon_arc import tendon_arc
from rodsim.core.analytic.tendon_bvp import scene_reference, tendon_rod

__all__ = [
    "ElasticaShape",
    "ExtensibleShape",
    "exact_elastica",
    "extensible_elastica",
    "load_parameter",
    "paper_model",
    "paper_model_as_printed",
    "tip_angle_from_load",
    "tendon_arc",
    "tendon_rod",
    "scene_reference",
]
