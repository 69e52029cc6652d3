"""Lumen constraint with the paper's coupling, Eqs. (24)–(27) and (32)–(35): tendon points
held on the lumen (``[tendons.<rod>] coupling = "paper"``).

Each tendon point p_i but the endpoint (held by Eqs. 28–29 instead) is registered to exactly
one parent catheter node j — the nearest lumen point L_j = r_j + r_L d_t(q_j) (§4.1). Its
offset Δ = L_j − p_i is penalised across the lumen:

    C_t = Δ · d_t  (Eqs. 26, 34),   C_n = Δ · d_n  (d_n = d3 × d_t),
    F_i = K_L (C_t d_t + C_n d_n)   (Eqs. 25, 33, 35 — the paper has only the d_t part)

``constrain = "d_t"`` keeps the paper's one-directional form; the default ``"both"`` also
holds the tendon in the other transverse direction, without which a tendon point is free
to drift out of the d_t–d3 plane (the paper assumes it stays close to it). Sliding along
the lumen is free. K_L is a force per unit offset per tendon point [N/m].

Each catheter node receives the *average* of the lumen forces of the tendon points
registered to it, applied at the node (§4.1). Not momentum-conserving.

The conserving coupling (``coupling = "conserving"``, docs/design.md erratum 13) is the other
term of the scene key ``lumen``: ``rodsim.core.terms.lumen_conserving``. The tendon's
``coupling`` selects which of the two a tendon's ``lumen`` builds
(``rodsim.core.terms.base.Term.selected_by``); both read the same ``[tendons.<rod>.lumen]``
table, so a scene's table stays valid when its coupling changes.

Registration (§4.1) is state of the term (``LumenCoupling``, shared by both couplings):
``LumenCoupling.registration`` applies the rule to a state and
``LumenCoupling.registered`` builds the term with the new parents (the model builds a
new model around it, ``Model.reregistered``). It is updated between solver steps (after
every time step, Newton solve or CVODE/IDA step), not inside a force evaluation: the
nearest-lumen-point rule switches the lumen line a point is held to and so makes the force
discontinuous, which stalls Newton and the BDF error control. Between updates each element
couples exactly (p_i, r_j, q_j) here, so the Jacobian pattern is exact; an update that
changes a parent rebuilds the pattern (§4.2's "redefined on every iteration") and the
SUNDIALS integrators re-initialise. During a run a point switches parent only when another
lumen point is closer (paper), or it lies beyond the boundary plane of its lumen segment
(conserving), by ``hysteresis`` × the catheter's segment length, so a transient on a
switching boundary cannot flip-flop; once a run is at equilibrium, every point is re-
registered to its nearest lumen point without hysteresis and the run goes on if a parent
changed (``Model.reregistered(x, exact=True)``), so the equilibrium does not depend on the
path a solver took (with hysteresis alone, CVODE and static ended with different parents on a four-
tendon scene, 3.7e-4 L apart).
"""

from __future__ import annotations

import copy
from abc import abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from rodsim.core.rod.quaternion import form_combination
from rodsim.core.rod.rod import Rod
from rodsim.core.schema import Options, Parameter
from rodsim.core.tendon import Tendon
from rodsim.core.terms._relative import absolute, check_one, lumen_scale, penalty_parameters
from rodsim.core.terms.base import KernelArguments, TendonTerm

#: Largest temporary of a registration pass [bytes]: the rules compare every held tendon
#: point with every lumen point, so the points go in blocks whose (points × lumen points × 3)
#: float arrays stay below this (a catheter of 60 000 nodes with a tendon of 20 000 asked
#: 27 GiB at once and failed with numpy's MemoryError).
REGISTRATION_BLOCK_BYTES = 32 * 1024 ** 2

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


def lumen_parameters(unit: str, meaning: str, scale: str) -> tuple[Parameter, ...]:
    """The ``[tendons.<rod>.lumen]`` table of both couplings: the same keys (a table stays
    valid when the tendon's coupling changes), with each coupling's unit of K_L."""
    return (
        *penalty_parameters("K_L", unit, meaning, DEFAULT_K_L_RELATIVE, scale),
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


class LumenCoupling(TendonTerm):
    """What the two lumen couplings share: the scene key ``lumen`` (the tendon's ``coupling``
    selects the class), the tendon points held (every one but the termination), their
    parents on the catheter and the registration rule with hysteresis (module docstring).
    Not registered itself (no ``name``)."""

    key: ClassVar[str] = "lumen"
    constraint_constant: ClassVar[str] = "K_L"
    penalty_advice: ClassVar[str] = (
        "the lumen penalty (tendons.<name>.lumen.K_L_relative, or K_L)")
    equation = "Eqs. (24)–(27), (32)–(35)"
    dynamic = True
    #: The tendon's ``coupling`` this class implements.
    coupling: ClassVar[str]
    #: Each held tendon point's parent: a catheter node (paper) or lumen segment (conserving).
    parent: np.ndarray

    @classmethod
    def selected_by(cls, owner: Mapping[str, Any]) -> bool:
        """The tendon's ``coupling`` names this class's (the paper's also answers a coupling
        that has no lumen, which rodsim/core/tendon.py then refuses with its own message)."""
        coupling = owner.get("coupling")
        return coupling == cls.coupling or (cls.coupling == "paper"
                                            and coupling != "conserving")

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        check_one(options, "K_L", DEFAULT_K_L_RELATIVE, prefix)

    def __init__(self, tendon: Tendon, options: Any) -> None:
        super().__init__(tendon, options)
        #: The tendon's rod (a lumen coupling holds a rod tendon, never a string).
        self.rod: Rod = tendon.tendon_rod
        #: The absolute lumen penalty constant: given, or ``K_L_relative`` × the coupling's
        #: :meth:`penalty_scale`.
        self.K_L = absolute(options, "K_L", self.penalty_scale())
        self._margin = options.hysteresis * tendon.catheter.geometry.segment_length
        # Every tendon point but the endpoint, which Eqs. (28)–(29) hold instead (§4.1:
        # "we will define a distinct penalty force on the tendon endpoint").
        self._last = tendon.termination.node
        self._points = self.rod.layout.position_index[:self._last]
        layout = tendon.catheter.layout
        #: The compiled rule's index maps (rodsim/core/kernels/_registration.py): the
        #: catheter's positions and quaternions and the held points, in the full state.
        self._registration_maps = tuple(
            np.ascontiguousarray(index, dtype=np.int64)
            for index in (layout.position_index, layout.quaternion_index, self._points))

    def _rest_state(self) -> np.ndarray:
        """The catheter's and the held tendon points' rest coordinates in a full state."""
        catheter, rod = self.tendon.catheter, self.rod
        rest = np.zeros(max(catheter.layout.offset + catheter.layout.size,
                            rod.layout.offset + rod.layout.size))
        rest[catheter.layout.position_index] = catheter.rest_positions()
        rest[catheter.layout.quaternion_index] = catheter.rest_quaternions()
        rest[self._points] = rod.rest_positions()[:self._last]
        return rest

    def _blocks(self) -> list[slice]:
        """The held points in blocks for a registration pass (``REGISTRATION_BLOCK_BYTES``):
        each block's rows give the same numbers as the whole would."""
        points = len(self._points)
        per_point = 24 * self.tendon.catheter.nodes  # one (lumen points × 3) float row
        size = max(1, REGISTRATION_BLOCK_BYTES // per_point)
        return [slice(start, start + size) for start in range(0, points, size)]

    @abstractmethod
    def penalty_scale(self) -> float:
        """The scale K_L_relative multiplies, in this coupling's unit of K_L."""

    @abstractmethod
    def _exact(self, x: np.ndarray) -> np.ndarray:
        """Every point's parent by the registration rule without hysteresis."""

    @abstractmethod
    def _switches(self, x: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
        """(every point's parent without hysteresis, which points switch to it with
        ``margin``)."""

    @abstractmethod
    def _set_dofs(self) -> None:
        """``dofs`` from ``parent``."""

    #: The name of the compiled form of :meth:`_switches` in
    #: rodsim/core/kernels/_registration.py.
    _compiled_rule: ClassVar[str]

    def registration(self, x: np.ndarray, exact: bool = False,
                     compiled: bool = False) -> np.ndarray | None:
        """Every tendon point's parent by the registration rule (with hysteresis, or without
        it when ``exact``), or None when no parent changes.

        ``compiled``: by the rule's numba kernel (rodsim/core/kernels/_registration.py; 28
        calls of the numpy rule were 3.2 ms of a 21 ms four-tendons solve), which decides
        every point as ``_switches`` does and leaves a comparison within round-off of
        its threshold to it."""
        margin = 0.0 if exact else self._margin
        if compiled:
            from rodsim.core.kernels import _registration

            rule = getattr(_registration, self._compiled_rule)
            parents = np.empty_like(self.parent)
            answer = rule(x, *self._registration_maps, float(self.tendon.alpha),
                          float(self.tendon.beta), float(self.tendon.offset), self.parent,
                          margin, parents)
            if answer == _registration.UNCHANGED:
                return None
            if answer == _registration.CHANGED:
                return parents
        nearest, switch = self._switches(x, margin)
        if not np.any(switch):
            return None
        return np.where(switch, nearest, self.parent)

    def registered(self, state: np.ndarray) -> LumenCoupling:
        other = copy.copy(self)
        other.parent = np.asarray(state).copy()
        other._set_dofs()
        return other

    def registration_state(self) -> np.ndarray:
        return self.parent.copy()


@dataclass(frozen=True, kw_only=True)
class LumenOptions(Options):
    """The options of the ``lumen`` term (both couplings): one field per
    parameter, checked against them when the term class is defined."""

    K_L: float = 0.0
    K_L_relative: float = DEFAULT_K_L_RELATIVE
    constrain: str = "both"
    hysteresis: float = 0.1
    chord_correction: bool = True


class Lumen(LumenCoupling):
    """Penalty keeping the tendon's points on the catheter's lumen with the paper's coupling,
    Eqs. (24)–(27), (32)–(35): K_L [N/m] per tendon point, the averaged reaction on the
    parent node."""

    name = "lumen"
    figure_layer = "tendon"
    Options = LumenOptions
    options: LumenOptions
    coupling = "paper"
    conservative = False
    _compiled_rule = "nearest_node_switches"
    parameters = lumen_parameters(
        "N/m", "lumen penalty constant per tendon point (coupling 'paper')",
        "E I / (r_L² L_T²) × the tendon's segment length (catheter's least E I, lumen "
        "offset, tendon length)")

    def __init__(self, tendon: Tendon, options: LumenOptions) -> None:
        super().__init__(tendon, options)
        self._stiffness = self.K_L
        self._both = options.constrain == "both"
        self.parent = self._exact(self._rest_state())
        self._set_dofs()

    def penalty_scale(self) -> float:
        """E I / (r_L² L_T²) × the tendon's segment length [N/m] (rodsim/core/terms/_relative.py,
        per tendon point)."""
        return lumen_scale(self.tendon) * self.rod.geometry.segment_length

    # --------------------------------------------------------- registration
    def _distances(self, x: np.ndarray, block: slice) -> np.ndarray:
        """Distances (block points × lumen points) of the held points in ``block``."""
        lumen = self.tendon.lumen_points(x)
        p = x[self._points[block]]
        return np.sqrt(np.sum((lumen[None, :, :] - p[:, None, :]) ** 2, axis=2))

    def _exact(self, x: np.ndarray) -> np.ndarray:
        """The nearest lumen point of every tendon point."""
        return np.concatenate([np.argmin(self._distances(x, block), axis=1)
                               for block in self._blocks()])

    def _switches(self, x: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
        """A point switches when another lumen point is closer by ``margin``."""
        nearest, switch = [], []
        for block in self._blocks():
            distance = self._distances(x, block)
            rows = np.arange(len(distance))
            closest = np.argmin(distance, axis=1)
            nearest.append(closest)
            switch.append(distance[rows, closest]
                          < distance[rows, self.parent[block]] - margin)
        return np.concatenate(nearest), np.concatenate(switch)

    def _set_dofs(self) -> None:
        layout = self.tendon.catheter.layout
        r = layout.position_index[self.parent]
        q = layout.quaternion_index[self.tendon.lumen_segment(self.parent)]
        self.dofs = np.concatenate([self._points, r, q], axis=1)

    # ----------------------------------------------------------- evaluation
    def kernel_arguments(self) -> KernelArguments:
        tendon = self.tendon
        return {"dofs": self.dofs, "alpha": float(tendon.alpha), "beta": float(tendon.beta),
                "offset": float(tendon.offset), "stiffness": float(self._stiffness),
                "both": self._both, "share": self._reaction_share()}

    def _kinematics(self, x: np.ndarray) -> PointOnLumen:
        local = x[self.dofs]
        return PointOnLumen(self.tendon, local[:, 0:3], local[:, 3:6], local[:, 6:10])

    def _reaction_share(self) -> np.ndarray:
        """The paper's averaging: 1 / (number of tendon points sharing each point's parent)."""
        counts = np.bincount(self.parent, minlength=self.tendon.catheter.nodes)
        return 1.0 / counts[self.parent]

    def element_forces(self, x: np.ndarray) -> np.ndarray:
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
