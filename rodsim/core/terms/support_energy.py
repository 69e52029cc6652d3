"""The energy of a rod's support kind: one generic term for every kind that holds by springs
(``SupportKind.has_energy``, rodsim/core/supports.py; docs/architecture.md, "How to add a
support kind").

A kind that holds a rod's base by springs (the ``elastic`` base,
rodsim/core/support_kinds/elastic.py) declares its energy E, its force F = −∂E/∂x and its
exact Jacobian ∂F/∂x on the 7 coordinates (r, q) of the held node and the segment after it
(the base: r_0, q_0) as methods of the kind. This term, of scope ``"support"`` (no scene
lists it: ``SupportKind.terms`` adds it for such a kind, the model builds it under the
rod's key ``"base"``), is one element on those coordinates and asks the kind for each
value: the kind is all a new kind writes. Its options are the kind's name and its spring
constants (``SupportKind.energy_values``, from ``[rods.<rod>.base]``), so a changed spring
rebuilds it. On the compiled path it runs the kind's kernel (``energy_kernel``, by the names
of its parameters: ``dofs`` and the kind's constants), or, for a kind without one, the
kind's numpy methods (``Term.compiled``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter
from rodsim.core.supports import SUPPORT_ENERGY_TERM, support_kind
from rodsim.core.terms.base import KernelArguments, RodTerm


@dataclass(frozen=True, kw_only=True)
class SupportEnergyOptions(Options):
    """The options of the support energy (``SupportKind.terms`` builds them): one field per
    parameter, checked against them when the term class is defined."""

    kind: str
    values: list[float]


class SupportEnergy(RodTerm):
    """The energy of the rod's base support kind on (r_0, q_0) (module docstring)."""

    name = SUPPORT_ENERGY_TERM
    scope = "support"
    figure_layer = "shape"
    Options = SupportEnergyOptions
    options: SupportEnergyOptions
    equation = "support springs (not in the paper): the energy of the rod's support kind"
    parameters = (
        Parameter("kind", "str", None, "-",
                  "the support kind whose energy this is (rods.<rod>.clamp)"),
        Parameter("values", "vector", None, "-",
                  "the kind's spring constants (from its [rods.<rod>.base] keys)"),
    )

    def __init__(self, rod: Rod, options: SupportEnergyOptions) -> None:
        super().__init__(rod, options)
        support = rod.support
        #: The support kind whose energy this is.
        self.support_kind = support_kind(options.kind)
        layout = rod.layout
        self.dofs = np.concatenate([layout.position_index[support.node],
                                    layout.quaternion_index[support.node]])[None, :]
        #: The kind's constants (``SupportKind.energy_constants``).
        self.constants: dict[str, Any] = self.support_kind.energy_constants(
            options.values, support, rod)
        self.kernel = self.support_kind.energy_kernel
        self.compiled = bool(self.kernel)

    def kernel_arguments(self) -> KernelArguments:
        if not self.compiled:
            return super().kernel_arguments()
        return {"dofs": self.dofs, **self.constants}

    def energy(self, x: np.ndarray) -> float:
        return self.support_kind.energy(self.constants, x[self.dofs[0]])

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        return self.support_kind.forces(self.constants, x[self.dofs[0]])[None, :]

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        return self.support_kind.jacobian(self.constants, x[self.dofs[0]])[None, :, :]
