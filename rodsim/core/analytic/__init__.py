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

import sys
from importlib import import_module
from types import ModuleType
from typing import Any

#: name -> the module that defines it. Imported on first use: the models import
#: scipy.integrate, scipy.optimize and scipy.special (~0.05–0.2 s of CPU), which a command
#: whose scene has no reference never needs (docs/benchmarks.md, "Start-up").
_HOMES = {
    "ElasticaShape": "elastica",
    "exact_elastica": "elastica",
    "load_parameter": "elastica",
    "ExtensibleShape": "extensible",
    "extensible_elastica": "extensible",
    "paper_model": "paper_model",
    "paper_model_as_printed": "paper_model",
    "tip_angle_from_load": "paper_model",
    "tendon_arc": "tendon_arc",
    "scene_reference": "tendon_bvp",
    "tendon_rod": "tendon_bvp",
}

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


def __getattr__(name: str) -> Any:
    """The models, imported from their modules on first use."""
    if name in _HOMES:
        return getattr(import_module(f"rodsim.core.analytic.{_HOMES[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _Package(ModuleType):
    """This package's module type: a submodule named as the model it defines
    (``paper_model``, ``tendon_arc``) leaves the package's name bound to the model when the
    import system records the submodule on it, as the eager imports of before did."""

    def __setattr__(self, name: str, value: Any) -> None:
        if isinstance(value, ModuleType) and _HOMES.get(name) == name:
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
