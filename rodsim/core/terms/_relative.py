"""A penalty constant given absolutely or relative to the scale of the rods it couples
(docs/model.md, "Penalties relative to the rod").

Each penalty term but the centerline (rodsim/core/terms/centerline.py, which has its own
spelling of the same rule) takes two parameters: the absolute constant (default 0, meaning
"from the relative one") and a dimensionless ``<name>_relative`` = constant / scale, where
the scale is the stiffness of the rod(s) the penalty holds in the sense in which the
penalty's give shows in the result:

* zero-length springs in series with a rod (endpoint compliance K_E, endpoint coupling K_C:
  the tendon, whose axial stiffness is E_T A_T / L_T; the joint K_J: the rod listing it,
  E_s A / L): the spring adds 1/relative of the rod's own axial compliance under the force
  it carries, whatever that force is;
* the lumen K_L, a distributed transverse spring: a tendon of tension T held in a lumen at
  offset r_L by a spring per unit length K_L gives by δ = T κ / K_L, which shifts its moment
  arm by δ. With T r_L L_T / (E I) = θ the turn it causes, δ / r_L = θ² E I / (K_L r_L² L_T²),
  so the scale is E I / (r_L² L_T²) [N/m²] (E I the catheter's least bending stiffness, r_L the
  lumen offset — the catheter radius for a central lumen — and L_T the tendon's length); per
  tendon point (coupling "paper", N/m) the same times the tendon's segment length.
"""

from __future__ import annotations

from typing import Any

from rodsim.core.schema import Parameter, SceneError


def penalty_parameters(key: str, unit: str, meaning: str, default_relative: float,
                       scale: str) -> tuple[Parameter, Parameter]:
    """The absolute and relative parameters of penalty ``key``."""
    return (
        Parameter(key, "float", 0.0, unit,
                  f"{meaning}; 0 (default): from {key}_relative", 0.0, 1e15),
        Parameter(f"{key}_relative", "float", default_relative, "-",
                  f"{meaning} relative to {scale}; used when {key} is not given",
                  0.0, 1e15, exclusive_minimum=True),
    )


def check_one(options: Any, key: str, default_relative: float, prefix: str) -> None:
    """One line when both spellings of penalty ``key`` are set."""
    absolute = getattr(options, key)
    relative = getattr(options, f"{key}_relative")
    if absolute > 0.0 and relative != default_relative:
        raise SceneError(f"{prefix}: {key} = {absolute!r} and {key}_relative = {relative!r} "
                         "both set the penalty; allowed: one of them")


def absolute(options: Any, key: str, scale: float) -> float:
    """The absolute constant of penalty ``key``: given, else relative × ``scale``."""
    value = float(getattr(options, key))
    if value > 0.0:
        return value
    return float(getattr(options, f"{key}_relative")) * scale


def tendon_axial_scale(tendon: Any) -> float:
    """E_T A_T / L_T [N/m], the tendon's axial stiffness (K_E, K_C)."""
    rod = tendon.rod
    return rod.stretch_stiffness / rod.length


def lumen_scale(tendon: Any) -> float:
    """E I / (r_L² L_T²) [N/m²] (module docstring; K_L per unit length)."""
    catheter = tendon.catheter
    arm = tendon.offset if tendon.offset > 0.0 else catheter.radius
    return catheter.smallest_bending_stiffness / (arm**2 * tendon.rod.length**2)
