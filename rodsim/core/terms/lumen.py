"""Lumen constraint, paper Eqs. (24)–(27) and (32)–(35): tendon points held on the lumen.

``coupling = "paper"``: each tendon point p_i but the endpoint (held by Eqs. 28–29 instead)
is registered to exactly one parent catheter node j — the nearest lumen point
L_j = r_j + r_L d_t(q_j) (§4.1). Its offset Δ = L_j − p_i is penalised across the lumen:

    C_t = Δ · d_t  (Eqs. 26, 34),   C_n = Δ · d_n  (d_n = d3 × d_t),
    F_i = K_L (C_t d_t + C_n d_n)   (Eqs. 25, 33, 35 — the paper has only the d_t part)

``constrain = "d_t"`` keeps the paper's one-directional form; the default ``"both"`` also
holds the tendon in the other transverse direction, without which a tendon point is free
to drift out of the d_t–d3 plane (the paper assumes it stays close to it). Sliding along
the lumen is free. K_L is a force per unit offset per tendon point [N/m].

Each catheter node receives the *average* of the lumen forces of the tendon points
registered to it, applied at the node (§4.1). Not momentum-conserving.

``coupling = "conserving"`` (docs/design.md, erratum 13;
:mod:`rodsim.core.terms._lumen_segment`): the lumen is the smooth (C¹) curve through the
node lumen points L_j = r_j + r_L d_t(Q_j), Q_j the bisector of the two segments' frames at
node j, tangent to d3(Q_j) there; each point is
registered to the lumen *segment* it lies alongside and held at its distance from that
segment's curve, E = Σ_i ½ K_L w_i |Δ_i|² with K_L per unit tendon length [N/m²] and w_i the
point's share of the tendon's rest length [m] (l_T/2 for the base point, l_T for the
others), the curve offset by the chord correction (l_C² − l_T²)/24 × the curvature
vector of the tendon's chain at the point, so that the tendon's chords measure it as the
catheter's chords do (``chord_correction``; :mod:`rodsim.core.terms._lumen_segment`). It is
a gradient: the reaction −F_i acts where the tendon touches the lumen, on
r_j, r_{j+1} and, through the offsets and tangents, on q_{j−1}, q_j, q_{j+1} (and, through
the correction's curvature, on the tendon points p_{b−1}, p_b, p_{b+1} around it). Only
``constrain = "both"``: the distance from a curve holds the point in both transverse
directions.

Registration (§4.1) is state of the term: :meth:`Lumen.registration` applies the rule to a
state and :meth:`Lumen.registered` builds the term with the new parents (the model builds a
new model around it, ``Model.reregistered``). It is updated between solver steps (after
every time step, Newton solve or CVODE/IDA step), not inside a force evaluation: the
nearest-lumen-point rule switches the lumen line a point is held to and so makes the force
discontinuous, which stalls Newton and the BDF error control. Between updates each element
couples exactly (p_i, r_j, q_j) (paper) or (p_i, r_j, r_{j+1}, q_{j−1}, q_j, q_{j+1}) and
the chord correction's tendon stencil (conserving), so the Jacobian pattern is exact; an
update that changes a parent rebuilds the pattern (§4.2's "redefined on every iteration")
and the SUNDIALS integrators re-initialise. During a run a point switches parent only when
another lumen point is closer (paper), or it lies beyond the boundary plane of its lumen segment
(conserving), by ``hysteresis`` × the catheter's segment length, so a transient on a
switching boundary cannot flip-flop; once a run is at equilibrium, every point is re-
registered to its nearest lumen point without hysteresis and the run goes on if a parent
changed (``Model.reregistered(x, exact=True)``), so the equilibrium does not depend on the
path a solver took (with hysteresis alone, CVODE and static ended with different parents on a four-
tendon scene, 3.7e-4 L apart).
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from rodsim.core.rod.quaternion import form_combination
from rodsim.core.schema import Parameter
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
from rodsim.core.terms._relative import absolute, check_one, lumen_scale, penalty_parameters
from rodsim.core.terms.base import KernelArguments, TendonTerm

#: Default K_L / (E I / (r_L² L_T²)) (rodsim/core/terms/_relative.py): measured on the user
#: scene (tests/data/user-two-tendon.toml, coupling "conserving") and the user family.
DEFAULT_K_L_RELATIVE = 1e5


class PointOnLumen:
    """Kinematics of a penalty tying points p to lumen points L = r + r_L d_t(q).

    For the offset Δ = L − p, the compliances C_t = Δ·d_t (Eqs. 26, 34) and C_n = Δ·d_n,
    with their gradients and Hessians with respect to the local coordinates (p, r, q) (10
    per point). Shared by the lumen and endpoint-compliance terms.
    """

    def __init__(self, tendon: Tendon, p: np.ndarray, r: np.ndarray, q: np.ndarray) -> None:
        self.frame = f = tendon.lumen_frame(q)
        rl = tendon.offset
        self.delta = r + rl * f.dt - p
        self.offset = rl
        self.c_t = np.sum(self.delta * f.dt, axis=1)
        self.c_n = np.sum(self.delta * f.dn, axis=1)
        self.grad_t = np.concatenate(
            [-f.dt, f.dt, np.einsum("nma,nm->na", f.Dt, self.delta + rl * f.dt)],
            axis=1)
        self.grad_n = np.concatenate(
            [-f.dn, f.dn, np.einsum("nma,nm->na", f.Dn, self.delta)
             + rl * np.einsum("nma,nm->na", f.Dt, f.dn)], axis=1)

    def hessians(self) -> tuple[np.ndarray, np.ndarray]:
        """∇²C_t and ∇²C_n, shape (n, 10, 10) each."""
        f, rl, delta = self.frame, self.offset, self.delta
        n = len(delta)
        h_t = np.zeros((n, 10, 10))
        h_n = np.zeros((n, 10, 10))
        for h, d_mat in ((h_t, f.Dt), (h_n, f.Dn)):
            h[:, 0:3, 6:10] = -d_mat
            h[:, 3:6, 6:10] = d_mat
            h[:, 6:10, 0:3] = -d_mat.transpose(0, 2, 1)
            h[:, 6:10, 3:6] = d_mat.transpose(0, 2, 1)
        dt_t = np.matmul(f.Dt.transpose(0, 2, 1), f.Dt)
        h_t[:, 6:, 6:] = 2.0 * rl * dt_t + form_combination(delta + rl * f.dt, f.Ht)
        cross = np.matmul(f.Dn.transpose(0, 2, 1), f.Dt)
        h_n[:, 6:, 6:] = (rl * (cross + cross.transpose(0, 2, 1))
                          + form_combination(delta, f.Hn)
                          + rl * form_combination(f.dn, f.Ht))
        return h_t, h_n


class Lumen(TendonTerm):
    """Penalty keeping the tendon's points on the catheter's lumen, Eqs. (24)–(27), (32)–(35)."""

    name = "lumen"
    equation = "Eqs. (24)–(27), (32)–(35)"
    dynamic = True
    parameters = (
        *penalty_parameters(
            "K_L", "N/m or N/m²",
            "lumen penalty constant (N/m per tendon point with coupling 'paper', N/m² per "
            "unit tendon length with 'conserving')", DEFAULT_K_L_RELATIVE,
            "E I / (r_L² L_T²) (catheter's least E I, lumen offset, tendon length; × the "
            "tendon's segment length per point with 'paper')"),
        Parameter("constrain", "str", "both", "-",
                  "'both' transverse directions, or 'd_t' only as Eq. (34) (coupling 'paper')",
                  choices=("both", "d_t")),
        Parameter("hysteresis", "float", 0.1, "-",
                  "a point changes parent when another lumen point is closer (paper), or it "
                  "lies beyond its lumen segment's boundary plane (conserving), by this "
                  "fraction of the catheter's segment length", 0.0, 1.0),
        Parameter("chord_correction", "bool", True, "-",
                  "coupling 'conserving': offset the lumen curve by (l_C² − l_T²)/24 times "
                  "the curvature vector of the tendon's chain at the point, so that a chain "
                  "of tendon chords of rest length l_T measures the lumen as a chain of "
                  "catheter chords l_C does (docs/tendon.md); false holds the points on the "
                  "curve itself"),
    )

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        check_one(options, "K_L", DEFAULT_K_L_RELATIVE, prefix)

    def __init__(self, tendon: Tendon, options: Any) -> None:
        super().__init__(tendon, options)
        self.conservative = tendon.conserving
        scale = lumen_scale(tendon)
        if not self.conservative:
            scale *= tendon.rod.geometry.segment_length
        #: The absolute lumen penalty constant (N/m² conserving, N/m per point paper).
        self.K_L = absolute(options, "K_L", scale)
        self._both = options.constrain == "both"
        catheter = tendon.catheter
        self._margin = options.hysteresis * catheter.geometry.segment_length
        # Every tendon point but the endpoint, which Eqs. (28)–(29) hold instead (§4.1:
        # "we will define a distinct penalty force on the tendon endpoint").
        self._last = tendon.termination.node
        self._points = tendon.rod.layout.position_index[:self._last]
        if self.conservative:
            self.kernel = "lumen_segment"
            share = np.full(len(self._points), tendon.rod.geometry.segment_length)
            share[0] *= 0.5
            self._stiffness = self.K_L * share
            self._sagitta = np.zeros(len(self._points))
            # The correction's curvature is the tendon's turn at a vertex, so it needs a
            # tendon of at least three points.
            if options.chord_correction and len(self._points) >= 2:
                self._sagitta[:] = (catheter.geometry.segment_length**2
                                    - tendon.rod.geometry.segment_length**2) / 24.0
                if tendon.rod.geometry.segment_length > catheter.geometry.segment_length:
                    self._sagitta[-1] *= TIP_SHARE
        else:
            self._stiffness = self.K_L
        rest = np.zeros(max(catheter.layout.offset + catheter.layout.size,
                            tendon.rod.layout.offset + tendon.rod.layout.size))
        rest[catheter.layout.position_index] = catheter.rest_positions()
        rest[catheter.layout.quaternion_index] = catheter.rest_quaternions()
        rest[self._points] = tendon.rod.rest_positions()[:self._last]
        self.parent = self._exact(rest)
        self._set_dofs()

    # --------------------------------------------------------- registration
    def _distances(self, x: np.ndarray) -> np.ndarray:
        lumen = self.tendon.lumen_points(x)
        p = x[self._points]
        return np.sqrt(np.sum((lumen[None, :, :] - p[:, None, :]) ** 2, axis=2))

    def _exact(self, x: np.ndarray) -> np.ndarray:
        """The registration rule without hysteresis: the nearest lumen point (paper) or the
        lumen segment each point lies alongside (conserving)."""
        if self.conservative:
            return segment_of(*lumen_nodes(self.tendon, x), x[self._points])[0]
        return np.argmin(self._distances(x), axis=1)

    def registration(self, x: np.ndarray, exact: bool = False) -> np.ndarray | None:
        """Every tendon point's parent by the registration rule (with hysteresis, or without
        it when ``exact``), or None when no parent changes."""
        margin = 0.0 if exact else self._margin
        rows = np.arange(len(self.parent))
        if self.conservative:
            nearest, beyond = segment_of(*lumen_nodes(self.tendon, x), x[self._points])
            # Past the plane at the segment's far end, or before the one at its near end.
            padded = np.pad(beyond, ((0, 0), (1, 1)), constant_values=np.nan)
            switch = ((padded[rows, self.parent + 1] > margin)
                      | (padded[rows, self.parent] < -margin))
            switch &= nearest != self.parent
        else:
            distance = self._distances(x)
            nearest = np.argmin(distance, axis=1)
            switch = distance[rows, nearest] < distance[rows, self.parent] - margin
        if not np.any(switch):
            return None
        return np.where(switch, nearest, self.parent)

    def registered(self, state: np.ndarray) -> Lumen:
        other = copy.copy(self)
        other.parent = np.asarray(state).copy()
        other._set_dofs()
        return other

    def registration_state(self) -> np.ndarray:
        return self.parent.copy()

    def _set_dofs(self) -> None:
        layout = self.tendon.catheter.layout
        if self.conservative:
            r = layout.position_index[np.stack([self.parent, self.parent + 1], axis=1)]
            q = layout.quaternion_index[segment_quaternions(self.parent,
                                                            self.tendon.termination.to_node)]
            blocks = [self._points, r.reshape(len(r), 6), q.reshape(len(q), 12)]
            if np.any(self._sagitta):
                position = self.tendon.rod.layout.position_index
                blocks.append(position[tendon_stencil(len(self._points))].reshape(-1, 9))
            self.dofs = np.concatenate(blocks, axis=1)
            return
        r = layout.position_index[self.parent]
        q = layout.quaternion_index[self.tendon.lumen_segment(self.parent)]
        self.dofs = np.concatenate([self._points, r, q], axis=1)

    # ----------------------------------------------------------- evaluation
    def kernel_arguments(self) -> KernelArguments:
        tendon = self.tendon
        common = {"dofs": self.dofs, "alpha": float(tendon.alpha), "beta": float(tendon.beta),
                  "offset": float(tendon.offset)}
        if self.conservative:
            return {**common, "stiffness": self._stiffness,
                    "length": float(tendon.catheter.geometry.segment_length),
                    "ends": self._ends(), "weights": self._node_weights(),
                    "sagitta": self._sagitta,
                    "tendon_length": float(tendon.rod.geometry.segment_length)}
        return {**common, "stiffness": float(self._stiffness), "both": self._both,
                "conserving": self.conservative, "share": self._reaction_share()}

    def _kinematics(self, x: np.ndarray) -> PointOnLumen:
        local = x[self.dofs]
        return PointOnLumen(self.tendon, local[:, 0:3], local[:, 3:6], local[:, 6:10])

    def _on_segments(self, x: np.ndarray) -> PointOnLumenCurve:
        return PointOnLumenCurve(self.tendon, x[self.dofs], self._stiffness,
                                 self.tendon.catheter.geometry.segment_length, self._ends(),
                                 self._node_weights(), self._sagitta,
                                 self.tendon.rod.geometry.segment_length)

    def _node_weights(self) -> np.ndarray:
        return node_weights(self.parent, self.tendon.termination.to_node)

    def _ends(self) -> np.ndarray:
        """Per element: (on the catheter's first segment, on its last), shape (n, 2)."""
        return np.stack([self.parent == 0,
                         self.parent == self.tendon.termination.to_node - 1], axis=1)

    def energy(self, x: np.ndarray) -> float | None:
        if not self.conservative:
            return None
        return self._on_segments(x).energy()

    def _reaction_share(self) -> np.ndarray:
        """The paper's averaging: 1 / (number of tendon points sharing each point's parent)."""
        counts = np.bincount(self.parent, minlength=self.tendon.catheter.nodes)
        return 1.0 / counts[self.parent]

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        if self.conservative:
            return -self._on_segments(x).gradient()
        kin = self._kinematics(x)
        k = self._stiffness
        force = -k * kin.c_t[:, None] * kin.grad_t
        if self._both:
            force -= k * kin.c_n[:, None] * kin.grad_n
        # Eq. (35) on the tendon point; the averaged reaction on the parent node only.
        force[:, 3:6] = -self._reaction_share()[:, None] * force[:, 0:3]
        force[:, 6:] = 0.0
        return force

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        if self.conservative:
            return -self._on_segments(x).hessian()
        kin = self._kinematics(x)
        k = self._stiffness
        h_t, h_n = kin.hessians()
        jac = -k * (kin.grad_t[:, :, None] * kin.grad_t[:, None, :]
                    + kin.c_t[:, None, None] * h_t)
        if self._both:
            jac -= k * (kin.grad_n[:, :, None] * kin.grad_n[:, None, :]
                        + kin.c_n[:, None, None] * h_n)
        jac[:, 3:6, :] = -self._reaction_share()[:, None, None] * jac[:, 0:3, :]
        jac[:, 6:, :] = 0.0
        return jac
