"""A tendon pulled by a prescribed displacement: an elastic string whose free length is set
(not in the paper; issue 20, "displacement control"), frictionless or with the capstan law.

A motor that winds a tendon in by d prescribes the tendon's free length ℓ* = ℓ₀ − d (ℓ₀ the
length of its rest path from the entry to the termination) rather than its tension. The
tendon is an elastic string of axial stiffness E A (``stiffness``) routed without friction
through the same points as a tension-controlled string (rodsim/core/terms/tendon_string.py):
its tension is T = (E A / ℓ*) (ℓ(x) − ℓ*) while it is taut and 0 when slack (ℓ ≤ ℓ*: a
tendon does not push), and it stores

    V = ½ (E A / ℓ*) max(0, ℓ(x) − ℓ*)²,
    ∂V/∂x = T ∇ℓ,   ∂²V/∂x² = T ∇²ℓ + (E A / ℓ*) ∇ℓ ∇ℓᵀ   (taut).

The first two are the tension-controlled string's at the tension T(x) — the same routing
points, chords and stencils, evaluated by that term's code — so at equilibrium the two
models agree exactly when the string's tension is set to T (tests/test_string_tendon.py).
The last is the tendon's own stiffness: it couples every coordinate along the tendon's path
(ℓ depends on all of them), so the term is one element holding all of them and its
Jacobian block is dense — m² entries for the m coordinates of the span (7 per node), and a
band as wide as the span. A scene refuses spans of more than ``MAX_SPAN_NODES`` nodes
(tension control has no such limit).

E A is physical, not a penalty: a tendon of 0.2 mm stainless steel wire has E A ≈ 6 kN, a
braided polymer line 1–5 kN; the stiffer the tendon, the closer the free length is to the
path's length. The term is a load for the solvers (static ramps it in with the other loads).

Friction (``friction`` μ > 0; rodsim/core/displacement_friction.py, docs/tendon.md,
"Friction under displacement control"): the chords carry the tension-controlled string's
capstan profile with this term's history (the stored chord tensions and the actuator's
tension of the last equilibrium, the anchors) at the actuator tension T_0 that makes the
chords hold the free length ℓ*: Σ_e ℓ_e / (1 + τ_e / E A) = ℓ*. The force is
−Σ_e τ_e ∇ℓ_e, the Jacobian the tension-controlled string's at T_0 (exact where that one
is: a path turning one way in one plane from a held entry frame) plus the rank-one
coupling through dT_0/dx. Not conservative (no energy); a cold solve assumes the tendon
was pulled in from slack, monotonically (no stored tension). One μ per tendon: per-point,
per-arc-length and static coefficients are refused. With μ = 0 nothing of this runs.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from rodsim.core.displacement_friction import actuator_tension, chord_states
from rodsim.core.routing import string_span
from rodsim.core.schema import SceneError
from rodsim.core.tendon import Tendon
from rodsim.core.tendon_friction import SLIDING_IN
from rodsim.core.terms._string_friction_coupling import one_way_parts
from rodsim.core.terms.base import KernelArguments, TendonTerm
from rodsim.core.terms.tendon_string import TendonString, TendonStringOptions

#: Most catheter nodes a displacement-controlled tendon may span (its dense Jacobian block
#: holds (7 n)² entries: 35 MB at 300 nodes).
MAX_SPAN_NODES = 300


class TendonStringDisplacement(TendonTerm):
    """V = ½ (E A / ℓ*) max(0, ℓ − ℓ*)²: a tendon pulled in by ``displacement``."""

    name = "tendon_string_displacement"
    figure_layer = "tendon"
    key = "tendon_string"
    Options = TendonStringOptions
    options: TendonStringOptions
    equation = "V = ½ (E A / ℓ*) (ℓ − ℓ*)₊² (Rucker & Webster 2011 loads; not in the paper)"
    #: How the tendon's table selects this variant of the key ``tendon_string``.
    selection = 'control = "displacement"'
    is_load = True
    parameters = TendonString.parameters

    @classmethod
    def selected_by(cls, owner: Mapping[str, Any]) -> bool:
        """The tendon's ``tendon_string.control`` is 'displacement'."""
        table = owner.get("tendon_string", {})
        return isinstance(table, Mapping) and table.get("control") == "displacement"

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        for key in ("friction_points", "friction_profile", "friction_profile_s",
                    "static_friction", "static_friction_profile", "exact_jacobian"):
            if getattr(options, key):
                raise SceneError(f"{prefix}.{key} = {getattr(options, key)!r}: friction "
                                 "per point, along the arc length or static is modelled on a "
                                 "tension-controlled string only; allowed: one kinetic μ "
                                 f"(friction) with control = 'displacement', {key} unset")
        if not options.stiffness > 0.0:
            raise SceneError(f"{prefix}.stiffness = {options.stiffness!r}: control = "
                             "'displacement' needs the tendon's axial stiffness E A; allowed: "
                             "a number > 0 [N] (0.2 mm steel wire: about 6e3)")

    def __init__(self, tendon: Tendon, options: TendonStringOptions) -> None:
        super().__init__(tendon, options)
        #: The same string under unit tension: the path, its chords and their stencils.
        self.string = TendonString(tendon, dataclasses.replace(options, tension=1.0))
        catheter = tendon.catheter
        start, end = string_span(options, catheter.length)
        span_nodes = int(np.sum((catheter.geometry.node_s >= start)
                                & (catheter.geometry.node_s <= end)))
        if span_nodes > MAX_SPAN_NODES:
            raise SceneError(
                f"tendons.{tendon.name}.tendon_string.control = 'displacement': the tendon "
                f"spans {span_nodes} nodes of {catheter.name!r}, more than {MAX_SPAN_NODES} "
                "(its stiffness couples every coordinate along it: a dense Jacobian block); "
                "allowed: fewer nodes, or control = 'tension'")
        chords = self.string.dofs
        span = np.unique(chords)
        self.dofs = span[None, :]
        #: Each chord's coordinates as positions in the span, (E, 28).
        self._chord_local = np.searchsorted(span, chords).astype(np.int64)
        m = len(span)
        self._chord_pairs = (self._chord_local[:, :, None] * m
                             + self._chord_local[:, None, :]).astype(np.int64)
        rest = np.zeros(catheter.layout.offset + catheter.layout.size)
        rest[catheter.layout.position_index] = catheter.rest_positions()
        rest[catheter.layout.quaternion_index] = catheter.rest_quaternions()
        #: ℓ₀, the rest path's length, and ℓ* = ℓ₀ − d, the free length [m].
        self.rest_length = self.string.length(rest)
        self.free_length = self.rest_length - float(options.displacement)
        if not self.free_length > 0.0:
            raise SceneError(
                f"tendons.{tendon.name}.tendon_string.displacement = "
                f"{options.displacement!r}: not shorter than the tendon's rest path "
                f"({self.rest_length:.6g} m); allowed: displacement < {self.rest_length:.6g}")
        #: E A / ℓ*, the tendon's stiffness [N/m].
        self.spring = float(options.stiffness) / self.free_length
        self._offset = float(np.mean(np.hypot(*self.string.points.offset.T)))
        self._span = end - start
        #: Coulomb coefficient μ (rodsim/core/displacement_friction.py); 0: frictionless.
        self.friction = float(options.friction)
        count = len(self.string.points.s) - 1
        #: The chord tensions τ_old and the actuator's tension T_old of the last converged
        #: equilibrium [N] (the friction's history): at first 0, pulled in from slack.
        self.profile = np.zeros(count)
        self.last_tension = 0.0
        #: Each chord's state while a step is solved (−1 sliding in, 0 stuck, +1 sliding
        #: out; ``freed`` checks it against the clip rule at the step's equilibrium): at
        #: first the last equilibrium's, sliding in from slack.
        self.pattern = np.full(count, SLIDING_IN)
        #: Whether T_0 is held ≥ 0 while the step is solved (``actuator_tension``): not at
        #: first, so that Newton's iterates see G smooth through slack; set by ``freed``
        #: when the step's equilibrium would need a tendon that pushes.
        self.clamp = False
        self.conservative = not self.rubs
        if self.rubs:
            self.kernel = "tendon_string_displacement_friction"
            #: The string at unit tension without friction: each chord's force and
            #: Jacobian per unit tension.
            self._unit = copy.copy(self.string)
            self._unit.friction = 0.0

    @property
    def rubs(self) -> bool:
        """Whether the tendon has friction (else the frictionless string, bitwise)."""
        return self.friction > 0.0

    def with_options(self, options: TendonStringOptions) -> TendonStringDisplacement | None:
        """A copy with another displacement when that is the only option changed (a
        tracking step): the path and the friction's history kept."""
        if dataclasses.replace(options, displacement=self.options.displacement) != (
                self.options):
            return None
        free_length = self.rest_length - float(options.displacement)
        if not free_length > 0.0:
            return None  # rebuilt, which says why
        other = copy.copy(self)
        other.options = options
        other.free_length = free_length
        other.spring = float(options.stiffness) / free_length
        return other

    def anchor_positions(self) -> np.ndarray | None:
        """The stored chord tensions τ_old (E,), the actuator's tension T_old [N] and the
        chords' states (E,) with friction; None without."""
        if not self.rubs:
            return None
        return np.concatenate([self.profile, [self.last_tension], self.pattern,
                               [float(self.clamp)]])

    def anchors_at(self, full: np.ndarray) -> np.ndarray | None:
        """The history the equilibrium ``full`` leaves (the next step's): its chord
        tensions, actuator tension and chord states by the clip rule; None without
        friction."""
        if not self.rubs:
            return None
        tension, tau, states = self._tensions(full, rule=True)
        return np.concatenate([tau, [tension], states, [0.0]])

    def anchored(self, anchors: np.ndarray) -> TendonStringDisplacement:
        """A copy with the history ``anchors`` (``anchor_positions``' layout)."""
        anchors = np.ascontiguousarray(anchors, dtype=float)
        chords = len(self.profile)
        if anchors.shape != (2 * chords + 2,):
            raise ValueError(f"a tension history of shape {anchors.shape}, expected "
                             f"({2 * chords + 2},)")
        other = copy.copy(self)
        other.profile = np.ascontiguousarray(anchors[:chords])
        other.last_tension = float(anchors[chords])
        other.pattern = np.ascontiguousarray(anchors[chords + 1:-1])
        other.clamp = bool(anchors[-1])
        return other

    def freed(self, full: np.ndarray) -> TendonStringDisplacement | None:
        """A copy whose chord states are the clip rule's at the equilibrium ``full`` of
        this step, for the step to be solved again, when they differ from those it was
        solved with, or with T_0 held ≥ 0 when the step ended on a tendon that pushes;
        None when they agree (the equilibrium is the rule's)."""
        if not self.rubs:
            return None
        _, _, states = self._tensions(full, rule=True)
        pushes = not self.clamp and self._tensions(full)[0] < 0.0
        if np.array_equal(states, self.pattern) and not pushes:
            return None
        other = copy.copy(self)
        other.pattern = states
        other.clamp = self.clamp or pushes
        return other

    def _bounds(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(θ_e, ℓ_e, e^{−μΘ_e}, e^{+μΘ_e}) of every chord at the full state ``x``."""
        theta = self.string.turning_angles(x)
        wrap = np.cumsum(theta)
        lengths = np.linalg.norm(np.diff(self.string.path(x), axis=0), axis=1)
        return (theta, lengths, np.exp(-self.friction * wrap),
                np.exp(self.friction * wrap))

    def _tensions(self, x: np.ndarray, rule: bool = False
                  ) -> tuple[float, np.ndarray, np.ndarray]:
        """(T_0, τ_e, the chords' states) at the full state ``x``: with the chord states
        this term is solved with, or (``rule``) by the clip rule."""
        _, lengths, low, high = self._bounds(x)
        pattern = np.full(len(lengths), np.nan) if rule else self.pattern
        tension = actuator_tension(lengths, low, high, self.profile, pattern,
                                   float(self.options.stiffness), self.free_length,
                                   self.last_tension, rule or self.clamp)
        states = np.empty(len(lengths))
        chord_states(tension, low, high, self.profile, pattern, states)
        tau = np.where(states < 0.0, tension * low,
                       np.where(states > 0.0, tension * high, self.profile))
        return tension, tau, states

    def kernel_arguments(self) -> KernelArguments:
        chord = self.string.kernel_arguments()
        common = {"dofs": self.dofs, "chord_dofs": chord["dofs"], "weights": chord["weights"],
                  "constant": chord["constant"], "forms": chord["forms"],
                  "chord_local": self._chord_local, "chord_pairs": self._chord_pairs,
                  "free_length": self.free_length}
        if not self.rubs:
            return common | {"spring": self.spring}
        return common | {"stiffness": float(self.options.stiffness),
                         "friction": self.friction, "profile": self.profile,
                         "pattern": self.pattern, "clamp": self.clamp,
                         "last_tension": self.last_tension,
                         "entry_forms": chord["entry_forms"],
                         "entry_slope": chord["entry_slope"], "split": chord["split"]}

    def path_length(self, x: np.ndarray) -> float:
        """ℓ(x), the length of the tendon's path at the full state ``x`` [m]."""
        return self.string.length(x)

    def tension(self, x: np.ndarray) -> float:
        """The actuator's tension at the full state ``x`` [N]: (E A / ℓ*) max(0, ℓ(x) − ℓ*)
        without friction, the root T_0 of the length constraint by the clip rule with it
        (what an equilibrium records: the chord states a step was solved with agree with
        the rule there, ``freed``)."""
        if self.rubs:
            return self._tensions(x, rule=True)[0]
        return self.spring * max(0.0, self.path_length(x) - self.free_length)

    def drawn_in(self, x: np.ndarray, chords: np.ndarray) -> float:
        """The actuator's displacement ℓ₀ − Σ_e ℓ_e / (1 + τ_e / E A) at the full state
        ``x`` with the chord tensions ``chords`` [m] (with friction; the frictionless string
        with its one tension): ``displacement`` at an equilibrium, to round-off."""
        lengths = np.linalg.norm(np.diff(self.string.path(x), axis=0), axis=1)
        return self.rest_length - float(np.sum(lengths / (1.0 + chords
                                                          / float(self.options.stiffness))))

    def tension_outcome(self, x: np.ndarray) -> float | None:
        return self.tension(x)

    def tension_profile(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(rest arc length of each chord's midpoint, τ_e by the clip rule) with friction;
        None without."""
        if not self.rubs:
            return None
        s = self.string.points.s
        return 0.5 * (s[:-1] + s[1:]), self._tensions(x, rule=True)[1]

    def point_states(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(rest arc length of routing points 0 … P − 2, the state of the chord each
        starts at ``x`` by the clip rule: −1 sliding in, 0 stuck, +1 sliding out) with
        friction; None without."""
        if not self.rubs:
            return None
        return self.string.points.s[:-1], self._tensions(x, rule=True)[2]

    def load_scale(self, x: np.ndarray) -> float:
        """An estimate of the tension [N]: the pull over the sum of the tendon's compliance
        ℓ*/(E A) and the catheter's, ρ² (span)/(E I) (a tension T bends the span to
        curvature T ρ / (E I), which shortens the path by about ρ² T span / (E I))."""
        pull = float(self.options.displacement)
        if pull <= 0.0:
            return 0.0
        bending = self.tendon.catheter.bending_stiffness
        return pull / (1.0 / self.spring + self._offset**2 * self._span / bending)

    def energy(self, x: np.ndarray) -> float | None:
        if self.rubs:
            return None  # the capstan profile is not the gradient of an energy
        stretch = max(0.0, self.path_length(x) - self.free_length)
        return 0.5 * self.spring * stretch * stretch

    def _gradient(self, x: np.ndarray) -> np.ndarray:
        """∇ℓ on the span's coordinates, (m,)."""
        g = np.zeros(self.dofs.shape[1])
        np.add.at(g, self._chord_local, -self.string.element_forces(x))
        return g

    def _span_sum(self, chords: np.ndarray) -> np.ndarray:
        """Chord rows (E, 28) summed onto the span's coordinates, (m,)."""
        out = np.zeros(self.dofs.shape[1])
        np.add.at(out, self._chord_local, chords)
        return out

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        if self.rubs:
            _, tau, _ = self._tensions(x)
            return self._span_sum(tau[:, None] * self._unit.element_forces(x))[None, :]
        return -(self.tension(x) * self._gradient(x))[None, :]

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        if self.rubs:
            return self._friction_jacobian(x)[None]
        m = self.dofs.shape[1]
        tension = self.tension(x)
        jacobian = np.zeros((m, m))
        chords = self.string.element_jacobians(x)  # −∇²ℓ of each chord, unit tension
        np.add.at(jacobian, (self._chord_local[:, :, None], self._chord_local[:, None, :]),
                  tension * chords)
        if self.path_length(x) > self.free_length:
            g = self._gradient(x)
            jacobian -= self.spring * np.outer(g, g)
        return jacobian[None]

    def _friction_jacobian(self, x: np.ndarray) -> np.ndarray:
        """∂F/∂x with friction (rodsim/core/displacement_friction.py): each chord's at its
        frozen τ_e, the sliding chords' own coupling f_e ⊗ ∂τ_e/∂x|_{T_0} on a path turning
        one way in one plane from a held entry frame, and (Σ s_e ∇ℓ_e) ⊗ (∂G/∂x)/(∂G/∂T_0)."""
        m = self.dofs.shape[1]
        jacobian = np.zeros((m, m))
        tension, tau, states = self._tensions(x)
        np.add.at(jacobian, (self._chord_local[:, :, None], self._chord_local[:, None, :]),
                  tau[:, None, None] * self._unit.element_jacobians(x))
        geometry, u, length = self._unit._chords(x)
        jd = np.concatenate([-geometry.jac[:-1], geometry.jac[1:]], axis=2)
        _, one_way, slope, unit_force = one_way_parts(self.string, x, u, length, jd)
        _, lengths, low, high = self._bounds(x)
        held = not np.any(self.string.points.weights[0, 2:])
        s = np.where(states < 0.0, low, np.where(states > 0.0, high, 0.0))
        rate = np.where(one_way & held, self.friction * np.where(
            states < 0.0, -tension * low, np.where(states > 0.0, tension * high, 0.0)), 0.0)
        coupling = (unit_force[:, :, None] * (rate[:, None] * slope)[:, None, :])
        np.add.at(jacobian, (self._chord_local[:, :, None], self._chord_local[:, None, :]),
                  coupling)
        share = 1.0 / (1.0 + tau / float(self.options.stiffness))
        v = lengths * share * share / float(self.options.stiffness)
        slope_g = -float(np.sum(v * s))
        if slope_g == 0.0 or (self.clamp and tension == 0.0):
            return jacobian  # T_0 held (slack, or no chord slides): no coupling through it
        grad_length = -unit_force  # ∇ℓ_e, (E, 28)
        dg = self._span_sum(share[:, None] * grad_length - v[:, None] * rate[:, None] * slope)
        c = self._span_sum(s[:, None] * grad_length)
        return jacobian + np.outer(c, dg) / slope_g
