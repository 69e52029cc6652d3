"""The ``[rods.<rod>.damping]`` table of a scene (docs/dynamics.md): its parameters and
their validation, apart from the damping matrix (rodsim/core/damping.py), which needs the
model: the scene validates the table without importing the model."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from rodsim.core.schema import Options, Parameter, SceneError, validate_table

__all__ = ["DAMPING_PARAMETERS", "DampingOptions", "ELASTIC_TERMS", "resolve_damping"]

DAMPING_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("retardation_time", "float", 0.0, "s",
              "Kelvin-Voigt retardation time tau: each strain's viscosity is tau times its "
              "stiffness (damping ratio tau*omega/2)", 0.0, 1e3),
    Parameter("drag", "float", 0.0, "N*s/m^2",
              "linear viscous drag per unit length on the centerline (a fluid around the rod)",
              0.0, 1e9),
)

#: The rod terms whose stiffness Kelvin–Voigt damping scales (paper Eqs. 6, 7, 9).
ELASTIC_TERMS = ("stretch", "bend_twist")


@dataclass(frozen=True, kw_only=True)
class DampingOptions(Options):
    """A validated ``[rods.<rod>.damping]`` table: one field per ``DAMPING_PARAMETERS``."""

    retardation_time: float = 0.0
    drag: float = 0.0


def resolve_damping(rod: str, table: Mapping[str, Any]) -> dict[str, Any] | None:
    """The validated ``[rods.<rod>.damping]`` table of a rod table (defaults filled), or None
    when the rod has none; SceneError (one line) for a negative or unknown value."""
    if "damping" not in table:
        return None
    raw = table["damping"]
    if not isinstance(raw, Mapping):
        raise SceneError(f"rods.{rod}.damping: expected a table with retardation_time and "
                         "drag")
    return validate_table(raw, DAMPING_PARAMETERS, f"rods.{rod}.damping")
