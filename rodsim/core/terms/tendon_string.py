"""A frictionless tendon under a controlled tension, as a string: V = T ℓ(x) (not in the paper).

A tendon pulled with tension T at its proximal end and routed without friction through
points its catheter carries stores the potential T ℓ, ℓ the length of its path from the
entry (s = start) to its termination (s = end). Added to the catheter's elastic energy, its
gradient is the Rucker–Webster load (Rucker & Webster, IEEE T-RO 27(6), 2011, Eqs. (16)–(18)
and the point wrench at the termination): a distributed force from the path's curvature,
its moment about the centerline, and the point force −T t and moment at the termination,
including the kink a tendon that ends makes in the path of those that pass on. No tendon
rod, no lumen penalty, no registration (docs/tendon.md, "String tendon").

Discretisation: the path is the polygon through routing points on the catheter — the
entry, the nodes inside the span, the section boundaries where G J changes off a node, the
termination — each on the centerline interpolated in its segment plus the routing's offset
R(q̂) ρ, q̂ interpolated between the frame knots (rodsim/core/terms/_string_points.py: the
choices, and the orders they were measured at against the Rucker–Webster reference).

ℓ = Σ_k |p_{k+1} − p_k|: one element per chord, on the coordinates of its two points
(r_m, r_{m+1} and the two knot quaternions of each: 28 coordinates). With d = p_B − p_A,
u = d/|d| and p's derivatives J = ∂p/∂x_point,

    ∂E/∂x = T [−J_Aᵀ u, J_Bᵀ u],
    ∂²E/∂x² = T Jdᵀ (I − u uᵀ) Jd / |d| + T Σ_m u_m (∂²p_B[m] − ∂²p_A[m]),   Jd = [−J_A, J_B],

with ∂²p[m]/∂q² = ∇²f_m of f = g/n (rodsim/core/terms/_string_points.py).
The tension is a load (the static solver ramps it); its force scale is T.

Friction (``friction`` μ > 0, rodsim/core/tendon_friction.py): chord e carries its own
tension τ_e, the capstan profile from the turning angles and the stored profile of the
last equilibrium (the anchors); F = −Σ_e τ_e ∂ℓ_e/∂x. τ_e depends on every turn up to
chord e: where it slides ∂τ_e/∂x = σ_e Σ_{j≤e} μ_j ∂θ_j/∂x (σ_e = ∓τ_e), each θ_j the turn
in 3-D as ``turning_angles`` makes it (the entry's blended split turn, the split points;
its gradient: rodsim/core/turn_gradient.py). By default the tendon is one element per
chord with the frozen-tension Jacobian plus, on a path that turns one way in one plane from
a held entry frame (a tendon bending its catheter from a clamped base), each chord's own
coupling: there the wrap Θ_e is ψ_e = ∠(d3, u_e), whose gradient lies on chord e's
coordinates, so with one μ the Jacobian is exact; off such paths (3-D, S-shaped, a moving
entry) Newton converges linearly, at a rate of order μ, and the band is kept. With
``exact_jacobian`` (and, without it, where μ varies between the points on a non-helical
routing from a held entry: ``friction_points``, ``friction_profile``, or stiction,
``static_friction``, a stick/slip state per point carried with the anchors, and
``TendonString.freed`` for a breakaway within a step) the tendon is one element on the
coordinates of its span (rodsim/core/terms/_string_span.py, kernel
rodsim/core/kernels/tendon_string_span.py), whose Jacobian is the chords' at frozen tension
plus Σ_e f_e ⊗ ∂τ_e/∂x: exact on every path and Newton quadratic (issue 34, "the Jacobian
stays exact"; tests/test_term_contract.py, tests/test_friction_jacobian_3d.py), at the
price of the span's dense block (the linear solves go dense). Over more than
``MAX_COUPLED_NODES`` nodes the chord elements are kept. The term is not conservative (no
energy). With μ = 0 every τ_e is T and nothing of this runs: the frictionless numbers,
bitwise.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from rodsim.core.friction_profile_knots import checked_knots
from rodsim.core.rod.quaternion import DIRECTOR_FORMS
from rodsim.core.routing import ROUTINGS, Routing, string_span
from rodsim.core.schema import Options, Parameter, SceneError
from rodsim.core.static_friction_profile import check_static_profile, static_profile_coefficients
from rodsim.core.tendon import MAX_TENSION, Tendon
from rodsim.core.tendon_friction import (
    MAX_FRICTION,
    SLIDING_IN,
    bound_coefficients,
    chord_tensions,
    profile_coefficients,
    slip_states,
    turning_angles,
    weighted_chord_tensions,
)
from rodsim.core.terms._string_friction_coupling import one_way_coupling, span_turn_coupling
from rodsim.core.terms._string_group import stacked_arguments
from rodsim.core.terms._string_points import (
    POINT_SIZE,
    PointGeometry,
    entry_directions,
    point_forms,
    point_geometry,
    routing_points,
)
from rodsim.core.terms._string_span import coupled_span
from rodsim.core.terms.base import KernelArguments, TendonTerm, Term


@dataclass(frozen=True, kw_only=True)
class TendonStringOptions(Options):
    """The options of the ``tendon_string`` term: one field per
    parameter, checked against them when the term class is defined."""

    tension: float = 1.0
    start: float = 0.0
    end: float = 0.0
    routing: str = "constant"
    table_s: list[float] = field(default_factory=list)
    table_y: list[float] = field(default_factory=list)
    table_z: list[float] = field(default_factory=list)
    helix_radius: float = 0.0
    helix_pitch: float = 0.0
    helix_phase: float = 0.0
    spacers: bool = False
    disk_radius: float = 0.0
    control: str = "tension"
    displacement: float = 0.0
    stiffness: float = 0.0
    friction: float = 0.0
    friction_points: list[float] = field(default_factory=list)
    friction_profile: list[float] = field(default_factory=list)
    friction_profile_s: list[float] = field(default_factory=list)
    static_friction: float = 0.0
    static_friction_profile: list[float] = field(default_factory=list)
    exact_jacobian: bool = False


#: The options ``TendonString.with_options`` compares, all but the tension (a new tension
#: keeps the routing): named once, not through ``dataclasses.replace`` at every step.
_KEPT_OPTIONS = tuple(f.name for f in dataclasses.fields(TendonStringOptions)
                      if f.name != "tension")


class TendonString(TendonTerm):
    """V = T ℓ: a frictionless tendon under tension T routed along its catheter."""

    name = "tendon_string"
    figure_layer = "tendon"
    Options = TendonStringOptions
    options: TendonStringOptions
    equation = "V = T ℓ (Rucker & Webster 2011, Eqs. 16–18; not in the paper)"
    #: How the tendon's table selects this variant of the key ``tendon_string``.
    selection = 'control = "tension"'
    is_load = True
    parameters = (
        Parameter("tension", "float", 1.0, "N", "tendon tension T, applied at its entry",
                  0.0, MAX_TENSION),
        Parameter("start", "float", 0.0, "m",
                  "arc length of the tendon's entry (0: the catheter's base)", 0.0, 100.0),
        Parameter("end", "float", 0.0, "m",
                  "arc length of the termination; 0 (default) means the catheter's tip L",
                  0.0, 100.0),
        Parameter("routing", "str", "constant", "-",
                  "'constant' (the tendon table's offset and direction), 'table' "
                  "(table_s/y/z, cubic spline) or 'helix' (helix_radius/pitch/phase)",
                  choices=ROUTINGS),
        Parameter("table_s", "vector", [], "m",
                  "routing = 'table': increasing arc lengths covering [start, end]",
                  0.0, 100.0),
        Parameter("table_y", "vector", [], "m", "routing = 'table': ρ along d1 at table_s",
                  -10.0, 10.0),
        Parameter("table_z", "vector", [], "m", "routing = 'table': ρ along d2 at table_s",
                  -10.0, 10.0),
        Parameter("helix_radius", "float", 0.0, "m",
                  "routing = 'helix': distance from the centerline", 0.0, 10.0),
        Parameter("helix_pitch", "float", 0.0, "m",
                  "routing = 'helix': arc length per turn (negative: the other hand)",
                  -1e3, 1e3),
        Parameter("helix_phase", "float", 0.0, "rad",
                  "routing = 'helix': angle from d1 toward d2 at s = 0", -1e3, 1e3),
        Parameter("spacers", "bool", False, "-",
                  "the tendon rides on spacer disks: offsets beyond the catheter's radius "
                  "allowed"),
        Parameter("disk_radius", "float", 0.0, "m",
                  "spacers = true: the radius of the spacer disks, as the figures and the 3D "
                  "view draw them (the model has no disk size); at least the routing's "
                  "largest offset; 0 (default): 1.2 × that offset", 0.0, 10.0),
        Parameter("control", "str", "tension", "-",
                  "'tension' (T given: tension) or 'displacement' (the tendon pulled in by "
                  "displacement, an elastic string of axial stiffness E A: "
                  "rodsim/core/terms/tendon_string_displacement.py)",
                  choices=("tension", "displacement")),
        Parameter("displacement", "float", 0.0, "m",
                  "control = 'displacement': length pulled in at the entry (negative: let "
                  "out)", -100.0, 100.0),
        Parameter("stiffness", "float", 0.0, "N",
                  "control = 'displacement': the tendon's axial stiffness E A (required)",
                  0.0, 1e12),
        Parameter("friction", "float", 0.0, "-",
                  "Coulomb coefficient μ between the tendon and its routing (spacer disks or "
                  "lumen; capstan law, rodsim/core/tendon_friction.py); 0: frictionless",
                  0.0, MAX_FRICTION),
        Parameter("friction_points", "vector", [], "-",
                  "a kinetic μ per routing point (the entry, every node inside the span, "
                  "a section boundary between nodes, the termination: one value each, in "
                  "order of arc length), overriding friction; [] (default): friction at "
                  "every point", 0.0, MAX_FRICTION),
        Parameter("friction_profile", "vector", [], "-",
                  "the kinetic μ as a function of arc length: its values at "
                  "friction_profile_s, linear between them and constant beyond, whatever the "
                  "discretisation; overrides friction; [] (default): not used",
                  0.0, MAX_FRICTION),
        Parameter("friction_profile_s", "vector", [], "m",
                  "friction_profile's arc lengths on the catheter: increasing, within the "
                  "tendon's [start, end]", 0.0, 100.0),
        Parameter("static_friction", "float", 0.0, "-",
                  "static μ_s >= the kinetic friction (every friction_points or "
                  "friction_profile value): a "
                  "point that stuck at the last equilibrium holds until the tension ratio "
                  "over it exceeds e^(μ_s θ); 0 (default): μ_s = μ_k", 0.0, MAX_FRICTION),
        Parameter("static_friction_profile", "vector", [], "-",
                  "the static μ_s as a function of arc length: its values at "
                  "friction_profile_s (beside friction_profile, each >= its value there), "
                  "linear between them and constant beyond; [] (default): not used",
                  0.0, MAX_FRICTION),
        Parameter("exact_jacobian", "bool", False, "-",
                  "with friction: the Jacobian couples every chord's tension to every turn "
                  "up to it (one dense element on the tendon's span, up to 300 nodes), "
                  "exact on 3-D and "
                  "S-shaped paths, Newton quadratic, each linear solve dense; false "
                  "(default): exact on paths turning one way in one plane (and with a "
                  "varying μ), the band kept"),
    )

    @classmethod
    def selected_by(cls, owner: Mapping[str, Any]) -> bool:
        """The tendon's ``tendon_string.control`` is 'tension' (the default)."""
        table = owner.get("tendon_string", {})
        return not isinstance(table, Mapping) or table.get("control", "tension") != (
            "displacement")

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        for key in ("displacement", "stiffness"):
            if getattr(options, key) != 0.0:
                raise SceneError(f"{prefix}.{key} = {getattr(options, key)!r}: read only with "
                                 f"control = 'displacement'; allowed: set {prefix}.control = "
                                 "'displacement' (and no tension), or leave it unset")
        static = options.static_friction
        listed = options.friction_points or options.friction_profile
        kinetic = max(listed) if listed else options.friction
        if static != 0.0 and static < kinetic:
            which = ("friction" if not listed else "the largest friction_points value"
                     if options.friction_points else "the largest friction_profile value")
            raise SceneError(f"{prefix}.static_friction = {static!r}: smaller than the "
                             f"kinetic coefficient ({which} = {kinetic!r}); allowed: a number "
                             f">= {kinetic!r} and <= {MAX_FRICTION:g}, or 0 (μ_s = μ_k)")
        check_static_profile(options, prefix)

    def __init__(self, tendon: Tendon, options: TendonStringOptions) -> None:
        super().__init__(tendon, options)
        catheter = tendon.catheter
        self.routing = Routing.of(tendon.offset, (tendon.alpha, tendon.beta), options)
        self.start, self.end = string_span(options, catheter.length)
        self.points = routing_points(tendon, self.routing, self.start, self.end)
        self.tension = float(options.tension)
        self.dofs = np.concatenate([self.points.dofs[:-1], self.points.dofs[1:]], axis=1)
        #: G_m = ρ_y A[0, m] + ρ_z A[1, m] of every point, (P, 3, 4, 4).
        self._forms = point_forms(self.points)
        #: Coulomb coefficient μ (rodsim/core/tendon_friction.py); 0: frictionless.
        self.friction = float(options.friction)
        chords = len(self.points.s) - 1
        #: The kinetic μ_k of every turn (routing points 0 … P − 2), (P − 1,).
        self.kinetic = np.full(chords, self.friction)
        if options.friction_points:
            values = np.asarray(options.friction_points, dtype=float)
            if len(values) != chords + 1:
                raise SceneError(
                    f"tendons.{tendon.name}.tendon_string.friction_points has {len(values)} "
                    f"values, expected {chords + 1}: one per routing point at this "
                    f"discretisation (the entry at s = {self.start:.6g} m, "
                    f"{chords - 1} points inside the span, the termination at "
                    f"s = {self.end:.6g} m); allowed: a list of {chords + 1} numbers, or "
                    "friction alone")
            self.kinetic = np.ascontiguousarray(values[:-1])
        if options.friction_profile or options.friction_profile_s:
            knots = checked_knots(f"tendons.{tendon.name}.tendon_string", options,
                                     self.start, self.end)
            self.kinetic = np.ascontiguousarray(profile_coefficients(
                knots, np.asarray(options.friction_profile), self.points.s))
        #: The static μ_s of every turn (rodsim/core/tendon_friction.py, "Per-point
        #: coefficients and stiction"): μ_k where static_friction is not set, (P − 1,).
        self.static = np.maximum(float(options.static_friction), self.kinetic)
        static_profile = static_profile_coefficients(options, self.points.s)
        if static_profile is not None:  # rodsim/core/static_friction_profile.py
            self.static = np.maximum(static_profile, self.kinetic)
        #: Whether a point's stick/slip state is history (μ_s above its μ_k somewhere).
        self.sticky = bool(np.any(self.static > self.kinetic))
        #: Whether the bounds take a coefficient per turn and side (friction_points, or
        #: stiction); otherwise the scalar μ: the uniform capstan's numbers, bitwise.
        self.weighted = (bool(options.friction_points) or bool(options.friction_profile)
                         or self.sticky)
        #: The chord tensions τ_old of the last converged equilibrium [N], (P − 1,): the
        #: friction's history. At first 0: pulled in from slack, monotonically.
        self.profile = np.zeros(chords)
        #: Each point's stick/slip state at the last equilibrium (−1 sliding in, 0 stuck,
        #: +1 sliding out), (P − 1,): at first sliding in (pulled in from slack).
        self.state = np.full(chords, SLIDING_IN)
        self._coefficients()
        #: ρ′ at the entry (the path's slope there), (2,).
        self._entry_slope = np.ascontiguousarray(self.routing.derivatives(
            np.array([self.start]))[0], dtype=float)
        self.conservative = not self.rubs
        #: The routing points whose turn is split through one-sided tangents (where another
        #: string tendon on the catheter starts or ends: rodsim/core/terms/_string_breaks.py), (P,).
        self.split = np.zeros(len(self.points.s), dtype=np.bool_)
        #: (state, tension, profile, chord tensions, μ_in) of the last chord_tensions call.
        self._memo: tuple[np.ndarray, float, np.ndarray, np.ndarray, np.ndarray] | None = (
            None)
        #: Each chord's coordinates (P − 1, 28): the elements, unless ``span`` (one element
        #: on the span's coordinates, rodsim/core/terms/_string_span.py) is set.
        self.chord_dofs = self.dofs
        self.span = coupled_span(self)
        if self.span is not None:
            self.dofs, self.kernel = self.span.dofs, "tendon_string_span"

    def with_options(self, options: TendonStringOptions) -> TendonString | None:
        """A copy with another tension when that is the only option changed (a tracking
        step): the routing, its points and their director forms depend on the other
        options only."""
        mine = self.options
        if type(options) is not type(mine):
            return None
        for name in _KEPT_OPTIONS:  # the dataclass's equality, field by field
            theirs, known = getattr(options, name), getattr(mine, name)
            if theirs is not known and theirs != known:
                return None
        other = copy.copy(self)
        other.options = options
        other.tension = float(options.tension)
        return other

    def linear_unit(self) -> tuple[tuple[Any, ...], float, Callable[[], Term]] | None:
        """Frictionless (``linear_in``): the tension times the force at 1 N, on the routing
        a copy of another tension shares."""
        if not self.linear_in("tension"):
            return None
        return ((self.points, self._forms, self.chord_dofs, self.span, self.split,
                 self._entry_slope), self.tension, self._unit)

    def _unit(self) -> TendonString:
        other = copy.copy(self)
        other.options = dataclasses.replace(self.options, tension=1.0)
        other.tension = 1.0
        return other

    @property
    def rubs(self) -> bool:
        """Whether the tendon has any friction (else the frictionless string, bitwise)."""
        return bool(np.any(self.static > 0.0)) if self.weighted else self.friction > 0.0

    def linear_in(self, option: str) -> bool:
        """Without friction every chord carries T: the force is linear in ``tension``
        (with friction the stick/slip bounds against the anchored tensions are not)."""
        return option == "tension" and not self.rubs

    def _coefficients(self) -> None:
        """μ_in, μ_out of every turn from the stick/slip state (``bound_coefficients``;
        μ_k both ways without stiction)."""
        self._mu_in, self._mu_out = (bound_coefficients(self.kinetic, self.static,
                                                        self.state) if self.sticky
                                     else (self.kinetic, self.kinetic))

    def anchor_positions(self) -> np.ndarray | None:
        """The stored chord tensions τ_old (P − 1,) [N] with friction, followed by the
        points' stick/slip states (P − 1,) with stiction; None without friction (the force
        then depends on the state alone)."""
        if not self.rubs:
            return None
        return np.concatenate([self.profile, self.state]) if self.sticky else self.profile

    def anchors_at(self, full: np.ndarray) -> np.ndarray | None:
        """The chord tensions the equilibrium ``full`` gives (the next step's history) and,
        with stiction, the points' stick/slip states there; None without friction."""
        if not self.rubs:
            return None
        tensions = self.chord_tensions(full)
        if not self.sticky:
            return tensions
        return np.concatenate([tensions, slip_states(
            self.tension, self._mu_in, self._mu_out, self.turning_angles(full),
            self.profile, self.state)])

    def anchored(self, anchors: np.ndarray) -> TendonString:
        """A copy of this term with the stored chord tensions ``anchors`` (P − 1,) [N]
        (followed by the stick/slip states with stiction: 2 (P − 1) values)."""
        anchors = np.ascontiguousarray(anchors, dtype=float)
        chords = len(self.profile)
        expected = (2 * chords,) if self.sticky else (chords,)
        if anchors.shape != expected:
            raise ValueError(f"a tension profile of shape {anchors.shape}, expected "
                             f"{expected}")
        other = copy.copy(self)
        if self.sticky:
            other.profile = np.ascontiguousarray(anchors[:chords])
            other.state = np.ascontiguousarray(anchors[chords:])
            other._coefficients()
        else:
            other.profile = anchors
        return other

    def freed(self, full: np.ndarray) -> TendonString | None:
        """With stiction: a copy whose points that broke loose at the equilibrium ``full``
        of this step (stuck at the last equilibrium, or sliding the other way, and on a
        bound now) slide at their kinetic μ_k, the stored tensions kept, for the step to be
        solved again (rodsim/core/tendon_friction.py, "Stiction"); None when none did."""
        if not self.sticky:
            return None
        states = slip_states(self.tension, self._mu_in, self._mu_out,
                             self.turning_angles(full), self.profile, self.state)
        broke = (states != 0.0) & (states != self.state)
        if not np.any(broke):
            return None
        other = copy.copy(self)
        other.state = np.where(broke, states, self.state)
        other._coefficients()
        return other

    def entry_directions(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(d3, t_in) at the entry point: the catheter's axis, along which the tendon comes
        in from the actuator, and the path's tangent t_in ∝ d3 + ρ′_y d1 + ρ′_z d2."""
        return entry_directions(self.points, self._entry_slope, x)

    def turning_angles(self, x: np.ndarray) -> np.ndarray:
        """θ_e of every chord (the entry's turn, then each routing point's) [rad]."""
        return turning_angles(*self.entry_directions(x), self.path(x), self.split)

    def chord_tensions(self, x: np.ndarray) -> np.ndarray:
        """τ_e of every chord [N]: T everywhere without friction, else the capstan profile
        with this term's history (rodsim/core/tendon_friction.py)."""
        chords = len(self.points.s) - 1
        if not self.rubs:
            return np.full(chords, self.tension)
        # The last state's, kept: a converged step reads them three times (result, record,
        # anchors) at one state and history (a step solved again after a breakaway: others).
        memo = self._memo
        if (memo is not None and memo[1] == self.tension and memo[2] is self.profile
                and memo[4] is self._mu_in and np.array_equal(memo[0], x)):
            return memo[3].copy()
        if self.weighted:
            out = weighted_chord_tensions(self.tension, self._mu_in, self._mu_out,
                                          self.turning_angles(x), self.profile)
        else:
            out = chord_tensions(self.tension, self.friction, self.turning_angles(x),
                                 self.profile)
        self._memo = (np.array(x, dtype=float), self.tension, self.profile, out, self._mu_in)
        return out.copy()

    def tension_profile(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(rest arc length of each chord's midpoint, τ_e) with friction; None without."""
        if not self.rubs:
            return None
        s = self.points.s
        return 0.5 * (s[:-1] + s[1:]), self.chord_tensions(x)

    def point_states(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(rest arc length of routing points 0 … P − 2 [m], the stick/slip state each has
        at the equilibrium ``x``: ``slip_states`` against this term's history) with
        friction; None without. Without stiction the state is not history and a point on
        both bounds (no wrap up to it) reads as sliding in."""
        if not self.rubs:
            return None
        return self.points.s[:-1], slip_states(
            self.tension, self._mu_in, self._mu_out, self.turning_angles(x), self.profile,
            self.state)

    def kernel_arguments(self) -> KernelArguments:
        pts = self.points
        arguments = {
            "dofs": self.chord_dofs, "weights": pts.weights, "constant": pts.constant,
            "forms": np.ascontiguousarray(self._forms), "tension": self.tension,
            "friction": (float(np.max(self.static, initial=0.0)) if self.weighted
                         else self.friction), "profile": self.profile,
            "weighted": self.weighted, "mu_in": np.ascontiguousarray(self._mu_in),
            "mu_out": np.ascontiguousarray(self._mu_out),
            "entry_forms": np.ascontiguousarray(DIRECTOR_FORMS),
            "entry_slope": self._entry_slope, "split": self.split}
        return arguments if self.span is None else self.span.arguments(arguments)

    def group_key(self) -> Hashable | None:
        """The catheter: its string tendons are evaluated in one kernel call
        (rodsim/core/kernel_group.py); None for one on its span's element (alone)."""
        if self.span is not None:
            return None
        return self.tendon.catheter.name

    @classmethod
    def group_arguments(cls, terms: Sequence[Term]) -> KernelArguments:
        """The ``kernel_arguments`` of ``terms`` stacked: the per-chord and per-point arrays
        concatenated in term order (``chord_start`` and ``point_start`` open each term's
        rows), the scalars one entry per term; and the chords that share their coordinates
        and weighted groups (the same ``dofs`` row, weights zero at the same places: the
        same distinct columns and Jacobian slots), listed together in ``shared_order``,
        each set from ``shared_start[i]`` to ``shared_start[i + 1]``, in order of first
        appearance and each set in term order."""
        strings = [t for t in terms if isinstance(t, TendonString)]
        assert len(strings) == len(terms)
        return stacked_arguments([t.kernel_arguments() for t in strings],
                                 [t.chord_keys for t in strings])

    @cached_property
    def chord_keys(self) -> list[bytes]:
        """Each chord's coordinates and which of its points' weights are not zero, as
        bytes: two chords of equal keys have the same distinct columns and Jacobian slots
        (``group_arguments``). Made once per term and kept by its copies (a new tension,
        anchors), whose chords are the same."""
        weighted = self.points.weights != 0.0
        rows = np.concatenate([self.chord_dofs, weighted[:-1], weighted[1:]], axis=1)
        return [row.tobytes() for row in rows]

    def load_scale(self, x: np.ndarray) -> float:
        """The tension: the termination's point force (the chords' forces cancel in pairs)."""
        return self.tension

    def _points(self, x: np.ndarray, derivatives: bool = True) -> PointGeometry:
        """p and, with ``derivatives``, ∂p/∂x_point and ∇²f (else empty arrays)."""
        return point_geometry(self.points, self._forms, x, derivatives)

    def path(self, x: np.ndarray) -> np.ndarray:
        """The tendon's path: the routing points in order, shape (P, 3) [m]."""
        return self._points(x, derivatives=False).p

    def length(self, x: np.ndarray) -> float:
        """ℓ(x), the length of the tendon's path [m]."""
        return float(np.sum(np.linalg.norm(np.diff(self.path(x), axis=0), axis=1)))

    def energy(self, x: np.ndarray) -> float | None:
        if self.rubs:
            return None  # the capstan profile is not the gradient of an energy
        return float(self.tension * np.sum(np.linalg.norm(np.diff(self.path(x), axis=0),
                                                          axis=1)))

    def _chords(self, x: np.ndarray) -> tuple[PointGeometry, np.ndarray, np.ndarray]:
        geometry = self._points(x)
        d = np.diff(geometry.p, axis=0)
        length = np.linalg.norm(d, axis=1)
        return geometry, d / length[:, None], length

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        geometry, u, _ = self._chords(x)
        pull = self.chord_tensions(x)[:, None] * u
        grad_a = -np.einsum("emk,em->ek", geometry.jac[:-1], pull)
        grad_b = np.einsum("emk,em->ek", geometry.jac[1:], pull)
        forces = -np.concatenate([grad_a, grad_b], axis=1)
        return forces if self.span is None else self.span.forces(forces)

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        geometry, u, length = self._chords(x)
        tension = self.chord_tensions(x)
        jd = np.concatenate([-geometry.jac[:-1], geometry.jac[1:]], axis=2)  # (E, 3, 28)
        proj = (np.eye(3) - u[:, :, None] * u[:, None, :]) * (tension / length)[:, None,
                                                                                  None]
        hess = np.einsum("eak,eab,ebl->ekl", jd, proj, jd)
        w = self.points.weights[:, 2:]
        pull = tension[:, None] * u
        for side, sign in ((0, -1.0), (1, 1.0)):
            points = slice(0, -1) if side == 0 else slice(1, None)
            curvature = sign * np.einsum("em,emij->eij", pull, geometry.hess[points])
            weights = w[points]
            offset = POINT_SIZE * side + 6
            for a in range(2):
                for b in range(2):
                    rows = slice(offset + 4 * a, offset + 4 * a + 4)
                    cols = slice(offset + 4 * b, offset + 4 * b + 4)
                    hess[:, rows, cols] += (weights[:, a] * weights[:, b])[:, None,
                                                                           None] * curvature
        jacobian = -hess
        if self.span is None:
            if self.rubs and not np.any(self.points.weights[0, 2:]):
                jacobian += one_way_coupling(self, x, u, length, jd)
            return jacobian
        return self.span.jacobian(jacobian, span_turn_coupling(self, x, u, length, jd))
