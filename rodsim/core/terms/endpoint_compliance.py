"""Endpoint compliance, paper Eq. (28): the tendon's tip tethered to the lumen's end.

    F_E = K_E (L_N − t),   L_N = r_N + r_L d_t(q_last)   (a zero-length spring, K_E [N/m])

``coupling = "paper"``: F_E acts on the tendon tip only, as Eq. (28) is written — the
catheter feels no reaction, so the term removes force from the system, which is why K_E
works as the paper's fitting knob (Fig. 18, docs/tendon.md). ``coupling = "conserving"``:
the gradient of ½ K_E |L_N − t|², with the reaction on the catheter's last node and, through
the lumen offset, on its last quaternion.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.schema import Options
from rodsim.core.tendon import LumenFrame, Tendon
from rodsim.core.terms._relative import (
    absolute,
    check_one,
    penalty_parameters,
    tendon_axial_scale,
)
from rodsim.core.terms.base import KernelArguments, TendonTerm

#: Default K_E / (E_T A_T / L_T) (rodsim/core/terms/_relative.py): the spring adds 1e-4 of
#: the tendon's own axial compliance.
DEFAULT_K_E_RELATIVE = 1e4


@dataclass(frozen=True, kw_only=True)
class EndpointComplianceOptions(Options):
    """The options of the ``endpoint_compliance`` term: one field per
    parameter, checked against them when the term class is defined."""

    K_E: float = 0.0
    K_E_relative: float = DEFAULT_K_E_RELATIVE


class EndpointCompliance(TendonTerm):
    """Spring from the tendon tip to the lumen's end point, Eq. (28)."""

    name = "endpoint_compliance"
    figure_layer = "tendon"
    Options = EndpointComplianceOptions
    options: EndpointComplianceOptions
    equation = "Eq. (28)"
    parameters = (
        *penalty_parameters("K_E", "N/m", "endpoint compliance penalty constant",
                            DEFAULT_K_E_RELATIVE,
                            "the tendon's axial stiffness E_T A_T / L_T"),
    )

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        check_one(options, "K_E", DEFAULT_K_E_RELATIVE, prefix)

    def __init__(self, tendon: Tendon, options: EndpointComplianceOptions) -> None:
        super().__init__(tendon, options)
        self.conservative = tendon.conserving
        #: The absolute penalty constant [N/m].
        self.K_E = absolute(options, "K_E", tendon_axial_scale(tendon))
        self._stiffness = self.K_E
        end = tendon.termination
        self._tip = end.position_index
        self._end = end.to_position_index
        self._quaternion = end.to_quaternion_index
        self.dofs = np.concatenate([self._tip, self._end, self._quaternion])[None, :]

    def kernel_arguments(self) -> KernelArguments:
        tendon = self.tendon
        return {"dofs": self.dofs, "alpha": float(tendon.alpha), "beta": float(tendon.beta),
                "offset": float(tendon.offset), "stiffness": float(self._stiffness),
                "conserving": self.conservative}

    def _offset(self, x: np.ndarray) -> tuple[np.ndarray, LumenFrame]:
        frame = self.tendon.lumen_frame(x[self._quaternion][None, :])
        lumen_end = x[self._end] + self.tendon.offset * frame.dt[0]
        return lumen_end - x[self._tip], frame

    def energy(self, x: np.ndarray) -> float | None:
        if not self.conservative:
            return None
        delta, _ = self._offset(x)
        return float(0.5 * self._stiffness * delta @ delta)

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        delta, frame = self._offset(x)
        k, rl = self._stiffness, self.tendon.offset
        force = np.zeros(10)
        force[0:3] = k * delta
        if self.conservative:
            force[3:6] = -k * delta
            force[6:10] = -k * rl * frame.Dt[0].T @ delta
        return force[None, :]

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        delta, frame = self._offset(x)
        k, rl = self._stiffness, self.tendon.offset
        d_t = frame.Dt[0]  # ∂d_t/∂q (3 × 4)
        grad = np.zeros((3, 10))  # ∂Δ/∂(t, r_N, q)
        grad[:, 0:3] = -np.eye(3)
        grad[:, 3:6] = np.eye(3)
        grad[:, 6:10] = rl * d_t
        jac = np.zeros((10, 10))
        jac[0:3] = k * grad  # F_t = K_E Δ
        if self.conservative:
            # F = −K_E (∂Δ/∂x)ᵀ Δ;  J = −K_E [(∂Δ/∂x)ᵀ ∂Δ/∂x + Σ_m Δ_m ∂²Δ_m/∂x²]
            jac = -k * grad.T @ grad
            jac[6:10, 6:10] -= k * rl * np.einsum("m,mab->ab", delta, frame.Ht)
        return jac[None, :, :]
