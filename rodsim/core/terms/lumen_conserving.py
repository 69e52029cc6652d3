"""Lumen constraint with the momentum-conserving coupling, paper Eqs. (24)–(27) and (32)–(35)
with docs/design.md, erratum 13 (``[tendons.<rod>] coupling = "conserving"``).

The lumen is the smooth (C¹) curve through the node lumen points L_j = r_j + r_L d_t(Q_j),
Q_j the bisector of the two segments' frames at node j, tangent to d3(Q_j) there
(``rodsim.core.terms._lumen_segment``); each tendon point but the endpoint is registered
to the lumen *segment* it lies alongside and held at its distance from that segment's curve,

    E = Σ_i ½ K_L w_i |Δ_i|²

with K_L per unit tendon length [N/m²] and w_i the point's share of the tendon's rest length
[m] (l_T/2 for the base point, l_T for the others), the curve offset by the chord correction
(l_C² − l_T²)/24 × the curvature vector of the tendon's chain at the point, so that the
tendon's chords measure it as the catheter's chords do (``chord_correction``). It is a
gradient: the reaction −F_i acts where the tendon touches the lumen, on r_j, r_{j+1} and,
through the offsets and tangents, on q_{j−1}, q_j, q_{j+1} (and, through the correction's
curvature, on the tendon points p_{b−1}, p_b, p_{b+1} around it). Only ``constrain =
"both"`` (a ``d_t`` is refused when the scene is read): the distance from a curve holds the
point in both transverse directions.

The scene key is ``lumen``, shared with the paper's coupling
(``rodsim.core.terms.lumen``, which also describes the registration both share); the
tendon's ``coupling`` selects this term. Between registration updates each element couples
exactly (p_i, r_j, r_{j+1}, q_{j−1}, q_j, q_{j+1}) and the chord correction's tendon
stencil, so the Jacobian pattern is exact. During a run a point switches segment when it
lies beyond the boundary plane of its lumen segment by ``hysteresis`` × the catheter's
segment length. Kernel: ``rodsim.core.kernels.lumen_segment``.
"""

from __future__ import annotations

import numpy as np

from rodsim.core.tendon import Tendon
from rodsim.core.terms._lumen_segment import (
    TIP_SHARE,
    PointOnLumenCurve,
    lumen_nodes,
    node_weights,
    segment_of,
    segment_quaternions,
    tendon_stencil,
)
from rodsim.core.terms._relative import lumen_scale
from rodsim.core.terms.base import KernelArguments
from rodsim.core.terms.lumen import LumenCoupling, LumenOptions, lumen_parameters

__all__ = ["ConservingLumen"]


class ConservingLumen(LumenCoupling):
    """Penalty energy holding the tendon's points on the catheter's smooth lumen curve, the
    conserving coupling (erratum 13): K_L [N/m²] per unit tendon length."""

    name = "lumen_conserving"
    figure_layer = "tendon"
    Options = LumenOptions
    options: LumenOptions
    coupling = "conserving"
    conservative = True
    kernel = "lumen_segment"
    #: Its numpy reference costs ~800 ns an entry of ∂F/∂x against ~40 ns for the others
    #: (tendon-conserving, four-tendons; rodsim/core/kernel_tier.py).
    numpy_cost_factor = 16.0
    _compiled_rule = "segment_switches"
    parameters = lumen_parameters(
        "N/m²", "lumen penalty constant per unit tendon length (coupling 'conserving')",
        "E I / (r_L² L_T²) (catheter's least E I, lumen offset, tendon length)")

    def __init__(self, tendon: Tendon, options: LumenOptions) -> None:
        super().__init__(tendon, options)
        catheter = self.tendon.catheter
        share = np.full(len(self._points), self.rod.geometry.segment_length)
        share[0] *= 0.5
        self._stiffness = self.K_L * share
        self._sagitta = np.zeros(len(self._points))
        # The correction's curvature is the tendon's turn at a vertex, so it needs a
        # tendon of at least three points.
        if options.chord_correction and len(self._points) >= 2:
            self._sagitta[:] = (catheter.geometry.segment_length**2
                                - self.rod.geometry.segment_length**2) / 24.0
            if self.rod.geometry.segment_length > catheter.geometry.segment_length:
                self._sagitta[-1] *= TIP_SHARE
        self.parent = self._exact(self._rest_state())
        self._set_dofs()

    def penalty_scale(self) -> float:
        """E I / (r_L² L_T²) [N/m²] (rodsim/core/terms/_relative.py)."""
        return lumen_scale(self.tendon)

    # --------------------------------------------------------- registration
    def _exact(self, x: np.ndarray) -> np.ndarray:
        """The lumen segment each tendon point lies alongside."""
        lumen, tangent = lumen_nodes(self.tendon, x)
        points = x[self._points]
        return np.concatenate([segment_of(lumen, tangent, points[block])[0]
                               for block in self._blocks()])

    def _switches(self, x: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
        """A point switches when it lies past the plane at its segment's far end, or before
        the one at its near end, by ``margin``."""
        lumen, tangent = lumen_nodes(self.tendon, x)
        points = x[self._points]
        nearest_blocks, switch_blocks = [], []
        for block in self._blocks():
            nearest, beyond = segment_of(lumen, tangent, points[block])
            parent = self.parent[block]
            rows = np.arange(len(parent))
            padded = np.pad(beyond, ((0, 0), (1, 1)), constant_values=np.nan)
            nearest_blocks.append(nearest)
            switch_blocks.append((padded[rows, parent + 1] > margin)
                                 | (padded[rows, parent] < -margin))
        nearest = np.concatenate(nearest_blocks)
        switch = np.concatenate(switch_blocks)
        return nearest, switch & (nearest != self.parent)

    def _set_dofs(self) -> None:
        layout = self.tendon.catheter.layout
        r = layout.position_index[np.stack([self.parent, self.parent + 1], axis=1)]
        q = layout.quaternion_index[segment_quaternions(self.parent,
                                                        self.tendon.termination.to_node)]
        blocks = [self._points, r.reshape(len(r), 6), q.reshape(len(q), 12)]
        if np.any(self._sagitta):
            position = self.rod.layout.position_index
            blocks.append(position[tendon_stencil(len(self._points))].reshape(-1, 9))
        self.dofs = np.concatenate(blocks, axis=1)

    # ----------------------------------------------------------- evaluation
    def kernel_arguments(self) -> KernelArguments:
        tendon = self.tendon
        return {"dofs": self.dofs, "alpha": float(tendon.alpha), "beta": float(tendon.beta),
                "offset": float(tendon.offset), "stiffness": self._stiffness,
                "length": float(tendon.catheter.geometry.segment_length),
                "ends": self._ends(), "weights": self._node_weights(),
                "sagitta": self._sagitta,
                "tendon_length": float(self.rod.geometry.segment_length)}

    def _on_segments(self, x: np.ndarray) -> PointOnLumenCurve:
        return PointOnLumenCurve(self.tendon, x[self.dofs], self._stiffness,
                                 self.tendon.catheter.geometry.segment_length, self._ends(),
                                 self._node_weights(), self._sagitta,
                                 self.rod.geometry.segment_length)

    def _node_weights(self) -> np.ndarray:
        return node_weights(self.parent, self.tendon.termination.to_node)

    def _ends(self) -> np.ndarray:
        """Per element: (on the catheter's first segment, on its last), shape (n, 2)."""
        return np.stack([self.parent == 0,
                         self.parent == self.tendon.termination.to_node - 1], axis=1)

    def energy(self, x: np.ndarray) -> float:
        return self._on_segments(x).energy()

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        return -self._on_segments(x).gradient()

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        return -self._on_segments(x).hessian()
