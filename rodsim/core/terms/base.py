"""The Term contract and the registry that collects every term.

An energy term is one file in ``rodsim.core.terms`` defining one ``Term`` subclass with a
unique ``name``. Defining the class registers it; a scene names the terms it uses and only
those are built, so a term a scene does not list costs nothing.

A term is a sum over *elements* (segments, interior nodes, tendon points …). Each element
touches a fixed, small set of global coordinates, ``dofs[e]``; the term returns, per
element, the generalised force on those coordinates and its derivative:

- ``element_forces(x)``    -> (n_elem, k):     F_e = −∂E_e/∂x_e
- ``element_jacobians(x)`` -> (n_elem, k, k):  ∂F_e/∂x_e (analytic, never finite differences)
- ``energy(x)``            -> float:           Σ E_e (``None`` for non-conservative terms)

These numpy methods are the readable reference. Each term also has a compiled kernel, one
file in ``rodsim.core.kernels`` named after the term (or ``kernel``), which computes the same
element forces and Jacobians with numba and accumulates them straight into the model's force
vector and CSC Jacobian data; ``kernel_arguments`` hands it the term's constants by the
names of the kernel's parameters (bound to its signature by name). The model
picks the path (``solver.kernels``); the contract test checks both against each other and
against finite differences.

A term is immutable once built: a dynamic term's registration (a tendon point's parent) is
changed by building a new term (``Term.registered``), so are a path-dependent term's
anchors (friction: ``Term.anchored``, set between the steps of a track), and a
penalty's continuation scale and a load's fraction are applied by the model as a factor on
the term's whole output.

The model scatters these into the global force vector and sparse Jacobian; the sparsity
pattern is the union of the element blocks, declared once by ``dofs``. The contract test
(tests/test_term_contract.py) checks every registered term against finite differences with
no per-term test code: force = −∂E/∂x, Jacobian = ∂F/∂x, symmetry when conservative.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Hashable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from rodsim.core.schema import Options, Parameter, register_with_options

if TYPE_CHECKING:
    from rodsim.core.rod.rod import Rod
    from rodsim.core.tendon import Tendon

__all__ = ["Term", "RodTerm", "TendonTerm", "REGISTRY", "KernelArguments", "FIGURE_LAYERS"]

#: The figure layers a term may be drawn in (``Term.figure_layer``).
FIGURE_LAYERS = ("shape", "tendon", "load", "contact")

#: What :meth:`Term.kernel_arguments` returns: the compiled kernel's constants by the names of
#: its parameters (rodsim/core/kernels/__init__.py orders them by the kernel's signature).
KernelArguments = Mapping[str, Any]

#: Every defined term class, by name. Filled by ``Term.__init_subclass__``.
REGISTRY: dict[str, type[Term]] = {}


class Term(ABC):
    """Contract of an energy (or penalty-force) term; see the module docstring.

    Class attributes every subclass sets
    ------------------------------------
    name
        Registry key, used in scenes.
    equation
        The paper's equation(s) the term implements, e.g. ``"Eq. (9)"``.
    parameters
        The term's own scene values (validated, with units and defaults).

    Declared beside the class, or made from ``parameters`` when it is defined
    -------------------------------------------------------------------------
    Options
        A frozen dataclass with one typed field per parameter; a term is built with an
        instance of it (``Options.of(table)`` types a validated table) and reads attributes
        (``self.options.K_P``). Every shipped term declares its own
        (``rodsim.core.schema.Options`` subclass, ``Options = CenterlineOptions``;
        annotate ``options: CenterlineOptions`` for the type checker), which is checked
        against ``parameters`` when the class is defined; a term that declares none gets
        one made at run time (a type checker then sees only the base class).
    conservative
        ``True`` when the force is −∇ of ``energy``; the Jacobian is then symmetric.
    is_load
        ``True`` for external loads; the static solver scales them during load continuation.
    has_jacobian
        ``False`` for state-independent forces (no Jacobian entries, no pattern).
    dynamic
        ``True`` when an element's coordinates depend on a discrete state of the term (a
        tendon point's parent catheter node), which ``registration`` applies to a state
        and ``registered`` sets, between solver steps; ``dofs`` changes with it.

    ``conservative``, ``is_load`` and ``has_jacobian`` may be overridden per instance
    (a term whose behaviour depends on its parameters).
    """

    name: ClassVar[str]
    equation: ClassVar[str]
    scope: ClassVar[str]
    parameters: ClassVar[tuple[Parameter, ...]] = ()
    # Not ClassVar: a term may set these per instance (see above).
    conservative: bool = True
    is_load: bool = False
    has_jacobian: bool = True
    dynamic: ClassVar[bool] = False
    #: True for a term evaluated on the offset state (:meth:`rodsim.core.model.Model.offsets`,
    #: docs/model.md, "The offset state and the residual floor"): the state it is given holds
    #: each position's displacement from its rest place and each quaternion's difference from
    #: its rest quaternion (:attr:`rodsim.core.model.Model.reference`), not the positions and
    #: quaternions themselves; its kernel takes the same. The stiff terms whose forces are
    #: small differences of large numbers (stretch, centerline) are; the others are given
    #: the full state.
    offsets: ClassVar[bool] = False
    #: The strain kinds of ``material_stiffness``, in the order of its ``weights``
    #: (``rodsim.core.damping_options.STRAIN_KINDS``: stretch, shear, bending, twist); empty
    #: for a term with no material strain, which Kelvin–Voigt damping leaves out.
    strain_kinds: ClassVar[tuple[str, ...]] = ()
    #: True for a constraint penalty whose constant a solver may raise gradually; the term
    #: must be linear in its constant, so that scaling its output scales the constant. A
    #: penalty term must also set :attr:`penalty_ratio` (checked when a model is built).
    penalty: ClassVar[bool] = False
    #: A penalty term's stiffness relative to the physics it constrains at the scale of one
    #: element (the centerline penalty: K_P l² / (E I), l the segment length), a finite
    #: positive number. The solvers that lower stiff penalties before loading (``static``,
    #: the SUNDIALS finish) scale the term's output by ``their_ratio / penalty_ratio`` when
    #: it is larger than theirs (:meth:`rodsim.core.model.Model.with_term_scales`). Set by
    #: penalty terms only (``penalty = True``), per instance: it depends on the options and
    #: the rod.
    penalty_ratio: float
    #: The scene key of this term's constraint-penalty constant, absolute spelling (a
    #: relative one is ``<key>_relative``, rodsim/core/terms/_relative.py): a constant whose
    #: limit K → ∞ is the model itself — a constraint the continuum rod holds exactly (d3
    #: along the tangent, a tendon in its lumen, two rods joined, a rigid obstacle) — so that
    #: its finite value is a numerical error, which rodsim/app/trust.py estimates by
    #: stiffening it. Empty for a term whose constants are physics: a stiffness or a load of
    #: the model, among them the paper's endpoint springs K_E (Eq. 28) and K_C (Eq. 29),
    #: parameters of its tendon model fitted to experiment (Table 3), not penalties to
    #: stiffen (docs/model.md, "Which constants are penalties"). Wider than :attr:`penalty`,
    #: which marks the penalties a solver may lower and raise gradually.
    constraint_constant: ClassVar[str] = ""
    #: The top-level scene table whose entries build this term, instead of a rod's or a
    #: tendon's ``terms`` list (contact: ``"obstacles"``); the model calls
    #: :meth:`from_table` on each entry. Empty: a term a rod or a tendon lists.
    scene_table: ClassVar[str] = ""
    #: True for a rod term that ties its rod's base to a node of another rod (a joint,
    #: rodsim/core/anchors.py): its options name that rod (``rod``) and the arclength on it
    #: (``s``), it also ``holds_base``, and it is built with the model's rods as a third
    #: argument, ``Term(rod, options, rods)``. The scene and the model find a joined rod by
    #: this flag, never by the term's name.
    joins_rods: ClassVar[bool] = False
    #: True for a rod term that holds its rod's base in place of a rigid support (a joint
    #: to another rod, an elastic base): the rod's ``clamp`` must be ``"free"``, and no
    #: other term may hold the same base (rodsim/core/scene.py).
    holds_base: ClassVar[bool] = False
    #: True for a one-sided constraint: a penalty that acts only where it is violated, so a
    #: state away from rest may meet a stiffness the rest Jacobian does not show (contact,
    #: whose ``latent_stiffness`` says which; the contract test ties the two). The solvers'
    #: "auto" retraction takes "lengths" for a model holding one
    #: (``rodsim.solvers.base.retraction_of``).
    unilateral: ClassVar[bool] = False
    #: How the figures show this term (rodsim/app/figures/scene_parts.py), one of
    #: ``FIGURE_LAYERS``: in the rods' ``"shape"`` (an elastic or constraint term), as a
    #: ``"tendon"``'s path (a coupling of a tendon), as ``"load"`` arrows, or as the
    #: ``"contact"`` forces on the obstacles. No default: every registered term declares it
    #: (tests/test_term_contract.py).
    figure_layer: ClassVar[str]
    #: For a term with a ``constraint_constant``: what the penalty-error warning asks the
    #: user to raise when stiffening this term's constant moves the result most
    #: (rodsim/app/trust.py), its name and scene keys, e.g. ``"the joint penalty
    #: (rods.<name>.joint.K_J_relative, or K_J)"``. Empty for a term without one (checked by
    #: tests/test_term_contract.py).
    penalty_advice: ClassVar[str] = ""
    #: Module of :mod:`rodsim.core.kernels` holding the compiled kernel (default: ``name``).
    #: A term may pick its kernel per instance (the proximal pull: ``constant_force``).
    kernel: str = ""
    #: False for a term with no compiled kernel: the compiled path evaluates its numpy
    #: methods (``rodsim.core.kernels.load_kernel``), one call per term, as the numpy path
    #: does (a support kind that brings no kernel of its own, ``SupportKind.energy_kernel``).
    #: May be set per instance.
    compiled: bool = True
    #: The scene key of the term: what a rod's or a tendon's ``terms`` lists and the name of
    #: its options sub-table (default: ``name``). Terms sharing a key are variants of one
    #: concept (the lumen's paper and conserving couplings); the owner's table picks one of
    #: them with :meth:`selected_by`, and each variant declares the same option keys.
    key: ClassVar[str] = ""
    #: For a variant whose table has the same keys as the others': what in the owner's
    #: table selects it (e.g. ``control = "displacement"``), for the scene reference.
    selection: ClassVar[str] = ""

    #: The frozen dataclass of this term's options (see above).
    Options: ClassVar[type[Options]]

    #: How much dearer per entry of its element arrays this term's numpy reference is than
    #: the typical term's (1): what the ``tiered`` path charges for its numpy evaluations
    #: (:func:`rodsim.core.kernel_tier.nominal_cost`), measured, not timed at run time.
    numpy_cost_factor: ClassVar[float] = 1.0

    #: Global coordinate indices of each element, shape (n_elem, k).
    dofs: np.ndarray

    def __init__(self, owner: Any, options: Any, *context: Any) -> None:
        """A term is built from its owner (a ``rodsim.core.rod.rod.Rod`` or a
        ``rodsim.core.tendon.Tendon``), its ``Options`` and, for a term that
        ``joins_rods``, the model's rods (``RodTerm``, ``TendonTerm``)."""
        self.options = options

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__ and not cls.key:
            cls.key = cls.name
        register_with_options(cls, REGISTRY, "term")

    @classmethod
    def selected_by(cls, owner: Mapping[str, Any]) -> bool:
        """Whether the owner's table (a rod's or a tendon's own values, validated) selects
        this class for its ``key``; a key with one class: always."""
        return True

    @abstractmethod
    def element_forces(self, x: np.ndarray) -> np.ndarray:
        """Generalised force on each element's coordinates, shape (n_elem, k)."""

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        """Checks of this term's ``options`` that need its owner's values (a rod term: the
        rod's ``rodsim.core.rod.rod.RodOptions``, e.g. an arclength within the rod's
        length); raise ``rodsim.core.schema.SceneError`` with a one-line message
        naming ``prefix``. Called once per use when a scene is resolved; default: none."""
        return None

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        """∂(element force)/∂(element coordinates), shape (n_elem, k, k)."""
        raise NotImplementedError(f"term {self.name!r} declares no Jacobian")

    def energy(self, x: np.ndarray) -> float | None:
        """Potential energy [J]; ``None`` when the term is not conservative."""
        return None

    def load_scale(self, x: np.ndarray) -> float:
        """A load's magnitude [N] at the full state ``x``, summed into the model's force
        scale F_ref: by default the sum of its element forces' norms."""
        return float(np.sum(np.linalg.norm(self.element_forces(x), axis=1)))

    def kernel_arguments(self) -> KernelArguments:
        """The constants the compiled kernel takes after the state (arrays and floats), by
        the names of the kernel's parameters: the model binds them to the kernel's signature
        by name (``rodsim.core.kernels.Kernel.bind``), so their order does not matter and
        a missing or unknown name is an error. A term without a compiled kernel
        (``compiled`` False) hands itself, ``{"term": self}``."""
        if not self.compiled:
            return {"term": self}
        raise NotImplementedError(f"term {self.name!r} has no compiled kernel")

    def group_key(self) -> Hashable | None:
        """What this term shares with the terms its kernel may evaluate in one call
        (``group_arguments``; the string tendons of one catheter), or ``None``: evaluated
        alone (the default). The model groups the consecutive terms of equal keys
        (rodsim/core/kernel_group.py): terms of one class whose kernel module has an
        ``evaluate_group`` and whose elements have the same width."""
        return None

    @classmethod
    def group_arguments(cls, terms: Sequence[Term]) -> KernelArguments:
        """The constants of ``terms`` (of this class, equal ``group_key``) packed for their
        kernel's ``evaluate_group``, by the names of its parameters."""
        raise NotImplementedError(f"term {cls.name!r} is not evaluated in groups")

    def registration(self, x: np.ndarray, exact: bool = False,
                     compiled: bool = False) -> np.ndarray | None:
        """A dynamic term's registration rule applied to the full state ``x``: the new
        discrete state if it differs from this term's, else ``None``.

        ``exact`` drops any hysteresis the term uses between solver steps: at equilibrium
        the state must be the one its own registration rule gives, so that the equilibrium
        does not depend on the path a solver took to it. ``compiled``: the model evaluates
        with the compiled kernels, and a term may apply a compiled form of its rule, which
        must give the same state."""
        return None

    def registered(self, state: np.ndarray) -> Term:
        """A copy of this dynamic term with the discrete state ``state`` (and its ``dofs``)."""
        raise NotImplementedError(f"term {self.name!r} has no registration")

    @classmethod
    def from_table(cls, name: str, table: Mapping[str, Any],
                   rods: Mapping[str, Rod]) -> list[tuple[str, Term]]:
        """The terms one entry ``[<scene_table>.<name>]`` of a term with a
        ``scene_table`` builds, each with its key (unique within the entry: the model
        names the term ``(scene_table, name, key)``), from the validated ``table`` and the
        model's rods."""
        raise NotImplementedError(f"term {cls.name!r} is not built from a scene table")

    def rigid_links(self) -> np.ndarray:
        """Global position indices (a, b), shape (k, 6), of the stiff two-point links of
        fixed length this term holds, which a Newton step keeps to first order
        (``rodsim.core.model.Model.step``); none by default."""
        return np.zeros((0, 6), dtype=int)

    def latent_stiffness(self) -> tuple[np.ndarray, float] | None:
        """(global indices, stiffness) of the stiffness this term may put on those coordinates
        away from the rest state although its Jacobian at rest shows none — a contact that
        appears (rodsim/core/terms/contact.py) — or ``None`` (every other term: its rest
        Jacobian is its stiffness's scale). The pseudo-dynamics' mass scaling counts it
        (``rodsim.solvers.pseudo_dynamics.pseudo_masses``)."""
        return None

    def point_masses(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(global position indices (k, 3), masses (k,) [kg]) of the point masses this term
        attaches to control points — a hanging mass's inertia (rodsim/core/terms/tip_load.py)
        — or ``None`` (every other term). The physical mass model adds them
        (``rodsim.core.inertia``); statics and the pseudo-dynamics do not read them."""
        return None

    def material_stiffness(self, x: np.ndarray, weights: np.ndarray | None = None
                           ) -> np.ndarray | None:
        """The material part of the element stiffness at ``x`` (the state the term is
        evaluated on), shape (n_elem, k, k): Σ (∂ε/∂x_e)ᵀ C (∂ε/∂x_e) over the element's
        strains ε and their stiffnesses C — the Gauss–Newton part of −∂F_e/∂x_e, positive
        semi-definite at any state, without the stress times the strains' second
        derivatives. What Kelvin–Voigt damping is made of, a viscosity per strain rate
        (rodsim/core/damping.py). ``weights``: one factor per ``strain_kinds`` entry that
        multiplies that kind's C (a retardation time per strain: the viscosities τ_k C_k);
        None: 1 for all. None for a term with no material strain (the default)."""
        return None

    def anchor_positions(self) -> np.ndarray | None:
        """A path-dependent term's anchors — the state of the last converged equilibrium its
        force depends on (a frictional contact's node positions,
        rodsim/core/terms/contact.py; a string tendon's chord tensions with friction,
        rodsim/core/tendon_friction.py) — or ``None`` for a term whose force depends on the
        state alone (every other term; a contact or a tendon without friction)."""
        return None

    def anchors_at(self, full: np.ndarray) -> np.ndarray | None:
        """The anchors the equilibrium ``full`` (full state) gives this path-dependent term,
        or ``None`` (see ``anchor_positions``)."""
        return None

    def anchored(self, anchors: np.ndarray) -> Term:
        """A copy of this path-dependent term with the anchors ``anchors``
        (``rodsim.core.model.Model.anchored`` sets them after a converged step)."""
        raise NotImplementedError(f"term {self.name!r} holds no anchors")

    def freed(self, full: np.ndarray) -> Term | None:
        """A copy of this path-dependent term in which what broke loose at the equilibrium
        ``full`` of this step slides with its kinetic friction (a string tendon's points
        with stiction, rodsim/core/tendon_friction.py), for the step to be solved again;
        ``None`` when nothing broke loose (the default: no stiction)."""
        return None

    def registration_state(self) -> np.ndarray | None:
        """A dynamic term's current discrete state (what ``registered`` takes), or
        ``None`` for a term without registration."""
        return None

    def linear_in(self, option: str) -> bool:
        """Whether this term's force is linear in its option ``option`` (all else held):
        a sensitivity then differences F on one point instead of a fourth-order stencil
        (rodsim/app/inverse/sensitivity.py). False unless a term says so."""
        return False

    def linear_unit(self) -> tuple[tuple[Any, ...], float, Callable[[], Term]] | None:
        """When this term's force (so its Jacobian) is a constant c times that of its unit,
        this term at c = 1: (the objects the unit's force depends on, which a copy of this
        term at another c shares; c; a function making the unit). c is the value of the
        option the force is linear in (``linear_in``). The model's rest diagonal takes c
        times the unit's share (rodsim/core/model_scales.py), a sensitivity to that option
        the unit's force (rodsim/core/value_change.py, ``unit_forces``). None (the
        default): not so."""
        return None

    def with_options(self, options: Any) -> Term | None:
        """This term with the options ``options`` (an ``Options`` of its class) made
        from this one without rebuilding what they do not change — the same elements,
        registration and geometry, new constants (a string tendon's tension: its routing
        points kept) — or ``None``: build it anew (the default;
        ``rodsim.core.model.Model.with_values``). The term returned must equal the one
        the constructor builds from ``options``."""
        return None


class RodTerm(Term):
    """A term acting on one rod, configured by ``[rods.<rod>.<term name>]``."""

    scope: ClassVar[str] = "rod"

    def __init__(self, rod: Rod, options: Any) -> None:
        self.rod = rod
        #: This term's validated options, an :attr:`Options` instance.
        self.options = options


class TendonTerm(Term):
    """A term coupling a tendon rod to its catheter, configured by ``[tendons.<rod>]`` and
    ``[tendons.<rod>.<term name>]`` (see ``rodsim.core.tendon``)."""

    scope: ClassVar[str] = "tendon"

    def __init__(self, tendon: Tendon, options: Any) -> None:
        self.tendon = tendon
        #: This term's validated options, an :attr:`Options` instance.
        self.options = options

    def tension_outcome(self, x: np.ndarray) -> float | None:
        """The tendon's tension [N] at the full state ``x`` when it is an outcome of the
        solve (displacement control), reported with the result; None when it is an input
        (or not one number)."""
        return None

    def tension_profile(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(rest arc length of each chord's midpoint [m], its tension [N]) along a tendon
        whose tension varies along its path (a string with friction) at the full state
        ``x``; None when it is one number."""
        return None

    def point_states(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(rest arc length of the routing point at the start of each chord [m], the
        stick/slip state of that point at the full state ``x``: −1 sliding in, 0 stuck,
        +1 sliding out) along a tendon with friction; None without."""
        return None
