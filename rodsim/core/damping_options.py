"""The ``[rods.<rod>.damping]`` table of a scene (docs/dynamics.md): its parameters and
their validation, apart from the damping matrix (rodsim/core/damping.py), which needs the
model: the scene validates the table without importing the model."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from rodsim.core.schema import Options, Parameter, SceneError, validate_table

__all__ = ["DAMPING_PARAMETERS", "DampingOptions", "ELASTIC_TERMS", "STRAIN_KINDS",
           "STRAIN_PARAMETERS", "resolve_damping"]

#: The strain kinds a per-strain retardation time may name: the ``strain_kinds`` of the rod
#: terms (stretch Eq. 6, the centerline penalty's shear Eq. 9, bending and twist Eqs. 7–8).
STRAIN_KINDS = ("stretch", "shear", "bending", "twist")

_BASE_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("retardation_time", "float", 0.0, "s",
              "Kelvin-Voigt retardation time tau: each strain's viscosity is tau times its "
              "stiffness (damping ratio tau*omega/2); retardation_time_<kind> overrides it "
              "per strain", 0.0, 1e3),
    Parameter("drag", "float", 0.0, "N*s/m^2",
              "linear viscous drag per unit length on the centerline (a fluid around the rod)",
              0.0, 1e9),
)

#: Per strain kind, a retardation time of its own; an omitted one follows
#: ``retardation_time`` (shear excepted: 0, the centerline penalty is a constraint that
#: Kelvin–Voigt leaves undamped unless asked; docs/dynamics.md). Kept out of the resolved
#: table when omitted, so that a ``retardation_time`` set later still applies to them.
STRAIN_PARAMETERS: tuple[Parameter, ...] = tuple(
    Parameter(f"retardation_time_{kind}", "float", 0.0, "s",
              f"Kelvin-Voigt retardation time of the {kind} strain alone (omitted: "
              + ("0, the centerline penalty undamped)" if kind == "shear"
                 else "retardation_time)"), 0.0, 1e3)
    for kind in STRAIN_KINDS)

DAMPING_PARAMETERS: tuple[Parameter, ...] = _BASE_PARAMETERS + STRAIN_PARAMETERS

#: The rod terms of the rod's own stiffness (paper Eqs. 6–8), which a program may not
#: vary in time (rodsim/app/programs.py).
ELASTIC_TERMS = ("stretch", "bend_twist")


@dataclass(frozen=True, kw_only=True)
class DampingOptions(Options):
    """A validated ``[rods.<rod>.damping]`` table: one field per ``DAMPING_PARAMETERS``, a
    per-strain one None where the table omits it (``retardation`` then gives the time it
    follows)."""

    retardation_time: float = 0.0
    drag: float = 0.0
    #: The per-strain retardation times the table gives (``STRAIN_PARAMETERS``; omitted: None).
    retardation_time_stretch: float | None = None
    retardation_time_shear: float | None = None
    retardation_time_bending: float | None = None
    retardation_time_twist: float | None = None

    @classmethod
    def of(cls, table: Mapping[str, Any]) -> DampingOptions:
        """The typed view of a resolved damping table (per-strain keys may be absent)."""
        return cls(retardation_time=table.get("retardation_time", 0.0),
                   drag=table.get("drag", 0.0),
                   **{p.name: table[p.name] for p in STRAIN_PARAMETERS if p.name in table})

    def retardation(self, kind: str) -> float:
        """The retardation time τ [s] of strain ``kind`` (one of ``STRAIN_KINDS``): its own
        when given, else ``retardation_time`` (shear: 0)."""
        own = getattr(self, f"retardation_time_{kind}")
        if own is not None:
            return float(own)
        return 0.0 if kind == "shear" else self.retardation_time


def resolve_damping(rod: str, table: Mapping[str, Any]) -> dict[str, Any] | None:
    """The validated ``[rods.<rod>.damping]`` table of a rod table (defaults filled), or None
    when the rod has none; SceneError (one line) for a negative or unknown value."""
    if "damping" not in table:
        return None
    raw = table["damping"]
    if not isinstance(raw, Mapping):
        raise SceneError(f"rods.{rod}.damping: expected a table with retardation_time and "
                         "drag")
    prefix = f"rods.{rod}.damping"
    out = validate_table(raw, _BASE_PARAMETERS, prefix,
                         allow_extra=tuple(p.name for p in STRAIN_PARAMETERS))
    for parameter in STRAIN_PARAMETERS:  # only the given ones (see STRAIN_PARAMETERS)
        if parameter.name in raw:
            out[parameter.name] = parameter.check(raw[parameter.name],
                                                  f"{prefix}.{parameter.name}")
    return out
