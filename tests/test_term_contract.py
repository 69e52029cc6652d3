"""The Term contract (rodsim/core/terms/base.py), checked generically for every registered term.

There is no per-term code here: every term the registry knows is looked up in the *contract
scenes* — the shipped scenes in data/ (with a third of their nodes), SMALL_SCENE (every rod
term, both clamp kinds), SMALL_TENDON_SCENE (the momentum-conserving tendon coupling, which
the shipped scenes do not use) and SMALL_PAPER_TENDON_SCENE (the paper's coupling with
shared parents and the lumen penalty of Eq. 34 only) and SMALL_JOINT_SCENE (backbone rods
joined by anchors, welded and ball joints, an actuated base; an elastic base) — and checked
by central finite differences at random non-trivial states:

(a) element forces scattered to the free coordinates equal −∂E/∂x (conservative terms);
(b) element Jacobians scattered to the free coordinates equal ∂F/∂x, block by block (rod ×
    positions/quaternions), each block to 1e-6 of its own largest entry;
(c) every entry of ∂F/∂x that finite differences find non-zero lies in ``model.pattern``;
(d) the Jacobian is symmetric when the term is conservative.

A term with ``has_jacobian = False`` must have a state-independent force and contribute no
pattern entries. A new term file is covered as soon as a contract scene lists it; a term
that no contract scene lists makes the test fail with instructions.
"""

from __future__ import annotations

import copy
import functools

import numpy as np
import pytest

import rodsim
from rodsim.core.model import Model
from rodsim.core.scene import Scene, scene_paths
from rodsim.core.terms import registered_terms
from rodsim.core.terms.base import FIGURE_LAYERS, RodTerm, Term

#: Two small rods listing every rod term, one per clamp kind, loaded out of plane.
SMALL_SCENE = {
    "name": "contract-every-rod-term",
    "rods": {
        "framed": {
            "length": 0.1, "radius": 0.004, "youngs_modulus": 2e6, "stretch_modulus": 5e6,
            "poisson_ratio": 0.3, "density": 1200.0, "nodes": 7, "clamp": "frame",
            "terms": ["stretch", "bend_twist", "centerline", "tip_load", "gravity",
                      "point_loads"],
            "centerline": {"K_P": 3e3},
            "tip_load": {"mass": 0.01, "force": [0.05, 0.0, -0.02]},
            "point_loads": {"loads": [{"s": 0.037, "force": [0.01, -0.03, 0.02]},
                                      {"s": 0.05, "force": [0.0, 0.02, 0.0]}]},
        },
        "first_segment": {
            "length": 0.08, "radius": 0.003, "youngs_modulus": 4e6, "stretch_modulus": 3e6,
            "density": 900.0, "nodes": 6, "clamp": "first_segment", "origin": [0.0, 0.05, 0.02],
            "terms": ["stretch", "bend_twist", "centerline", "tip_load", "gravity"],
            "bend_twist": {"stiffness": "corde"},
            "centerline": {"K_P": 5e2},
            "tip_load": {"mass": 0.02},
            "gravity": {"gravity": 3.7},
        },
    },
}

#: Follower and world-frame point wrenches (a moment in the clamped first segment too), a
#: load per length, and sections that change inside segments (a tube, a thinner tip).
SMALL_LOAD_SCENE = {
    "name": "contract-loads-and-sections",
    "rods": {
        "loaded": {
            "length": 0.1, "radius": 0.004, "youngs_modulus": 2e6, "stretch_modulus": 5e6,
            "poisson_ratio": 0.3, "density": 1200.0, "nodes": 7, "clamp": "first_segment",
            "terms": ["stretch", "bend_twist", "centerline", "point_loads",
                      "distributed_load", "gravity"],
            "sections": [
                {"start": 0.0, "end": 0.023, "youngs_modulus": 6e6, "inner_radius": 0.002},
                {"start": 0.023, "end": 0.07, "stretch_modulus": 2e6, "density": 2000.0},
                {"start": 0.07, "end": 0.1, "radius": 0.003, "shear_modulus": 5e5}],
            "distributed_load": {"force_per_length": [0.1, -0.2, 0.05], "spans": [
                {"start": 0.01, "end": 0.047, "force_per_length": [0.0, 0.3, -0.1]}]},
            "point_loads": {"loads": [
                {"s": 0.005, "moment": [0.001, 0.002, -0.001]},
                {"s": 0.031, "force": [0.01, -0.03, 0.02], "moment": [0.002, -0.001, 0.003],
                 "frame": "body"},
                {"s": 0.06, "force": [0.02, 0.01, -0.01], "moment": [-0.001, 0.003, 0.002]},
                {"s": 0.1, "force": [0.0, 0.03, 0.01], "frame": "body"}]},
        },
    },
}

#: The shipped scenes use the paper's (non-conservative) tendon coupling; this one has the
#: momentum-conserving coupling, whose coupling terms must be gradients of an energy, the
#: proximal actuation (a dead load) and a tendon base held by the 'orientation' clamp.
SMALL_TENDON_SCENE = {
    "name": "contract-conserving-tendon",
    "rods": {
        "catheter": {
            "length": 0.1, "radius": 0.005, "youngs_modulus": 3e6, "stretch_modulus": 3e6,
            "density": 1100.0, "nodes": 8, "clamp": "frame",
            "terms": ["stretch", "bend_twist", "centerline"],
        },
        "tendon": {
            "length": 0.1, "radius": 0.0005, "youngs_modulus": 1e8, "stretch_modulus": 1e8,
            "density": 5000.0, "nodes": 6, "clamp": "orientation",
            "terms": ["stretch", "bend_twist", "centerline"],
        },
    },
    "tendons": {
        "tendon": {
            "catheter": "catheter", "offset": 0.002, "direction": [0.6, 0.8],
            "coupling": "conserving",
            "terms": ["lumen", "endpoint_compliance", "endpoint_coupling", "tendon_actuation"],
            "lumen": {"K_L": 500.0},
            "endpoint_compliance": {"K_E": 800.0},
            "endpoint_coupling": {"K_C": 1e4},
            "tendon_actuation": {"force": 1.5, "point": "proximal"},
        },
    },
}

#: The paper's coupling with more tendon points than catheter nodes, so several tendon
#: points share a parent and the averaged reaction of §4.1 matters, and the lumen penalty
#: in the paper's one-directional form (Eq. 34, ``constrain = "d_t"``).
SMALL_PAPER_TENDON_SCENE = copy.deepcopy(SMALL_TENDON_SCENE) | {
    "name": "contract-paper-tendon-shared-parents"}
SMALL_PAPER_TENDON_SCENE["rods"]["catheter"]["nodes"] = 5
SMALL_PAPER_TENDON_SCENE["rods"]["tendon"] |= {"nodes": 9, "clamp": "frame"}
SMALL_PAPER_TENDON_SCENE["tendons"]["tendon"] |= {
    "coupling": "paper", "lumen": {"K_L": 500.0, "constrain": "d_t"},
    "tendon_actuation": {"force": 1.5, "point": "distal"}}

#: Contact (rodsim/core/terms/contact.py) with every obstacle type: a plane and a sphere the
#: rest rod already touches, a csv vessel of varying radius, a torus section and a helix; the
#: smoothing length is wide so that random states put nodes in the C² onset as well as in
#: the linear part and out of contact.
SMALL_CONTACT_SCENE = {
    "name": "contract-contact",
    "rods": {
        "catheter": {
            "length": 0.1, "radius": 0.004, "youngs_modulus": 2e6, "stretch_modulus": 5e6,
            "density": 1200.0, "nodes": 9, "terms": ["stretch", "bend_twist", "centerline"],
        },
        "wire": {
            "length": 0.08, "radius": 0.002, "youngs_modulus": 4e6, "stretch_modulus": 3e6,
            "density": 900.0, "nodes": 7, "origin": [0.0, 0.0, 0.3],
            "terms": ["stretch", "bend_twist", "centerline"],
        },
    },
    "obstacles": {
        "tissue": {"type": "plane", "rods": ["catheter"], "point": [0.05, 0.0, 0.0],
                   # tilted so that the clamped base lies outside it (a held node inside a
                   # solid obstacle is refused, rodsim/core/contact_depth.py) and the rod
                   # crosses it past x = 0.05 m
                   "normal": [-0.3, 1.0, 0.2], "smoothing_scale": 0.5},
        "bulge": {"type": "sphere", "rods": ["catheter"], "center": [0.05, 0.0, 0.036],
                  "radius": 0.04, "smoothing_scale": 0.5},
        "vessel": {"type": "tube", "rods": ["catheter"], "centerline": "csv",
                   "points": [-0.01, 0.0, 0.0, 0.011, 0.03, 0.003, 0.0, 0.013,
                              0.07, 0.0, 0.003, 0.012, 0.12, -0.004, 0.0, 0.011],
                   "smoothing_scale": 0.5},
        "torus": {"type": "tube", "rods": ["wire"], "centerline": "arc", "radius": 0.0045,
                  "start": [-0.01, 0.0, 0.3], "bend_radius": 2.0, "bend_toward": [0, 1, 1],
                  "angle": 0.5, "smoothing_scale": 0.5},
        "coil": {"type": "tube", "rods": ["wire"], "centerline": "helix", "radius": 0.0045,
                 "start": [-0.01, -0.002, 0.3], "direction": [1, 0, 0], "bend_radius": 0.002,
                 "pitch": 0.2, "turns": 0.6, "smoothing_scale": 0.5},
    },
}

#: Contact with regularised Coulomb friction (rodsim/core/terms/contact.py, μ > 0): the
#: anchors are the rest positions, so a random state has every touching node slipped by
#: 1–5 % of L. With ε = 0.125 r = 0.5 mm (the plane, the csv vessel whose varying radius
#: makes |∇φ| ≠ 1, the coil) the nodes are sliding (|v|/ε ≈ 2–10: g near the unit vector);
#: with ε = 10 r = 40 mm (the sphere, the torus) they stick (|v| ≪ ε: the tangential
#: spring). ε stays far above the finite-difference step (1e-7 m).
SMALL_FRICTION_SCENE = copy.deepcopy(SMALL_CONTACT_SCENE) | {"name": "contract-friction"}
for _name, (_mu, _slip) in {"tissue": (0.4, 0.125), "bulge": (0.5, 10.0),
                            "vessel": (0.3, 0.125), "torus": (0.6, 10.0),
                            "coil": (0.2, 0.125)}.items():
    SMALL_FRICTION_SCENE["obstacles"][_name] |= {"friction": _mu, "slip_scale": _slip}

#: Backbone rods joined by anchors (rodsim/core/terms/joint.py): a rod welded to the tip of
#: a base-actuated rod (inserted and turned), and a third one on a ball joint at an
#: interior node of the second; sections differ, so the welded frame's series stiffness
#: mixes both. Supports that hold the frame (rodsim/core/supports.py, ``orientation``): at
#: an interior node of the first rod (displaced) and at the tip of the second.
SMALL_JOINT_SCENE = {
    "name": "contract-joints",
    "rods": {
        "proximal": {
            "length": 0.1, "radius": 0.004, "youngs_modulus": 2e6, "stretch_modulus": 5e6,
            "poisson_ratio": 0.3, "density": 1200.0, "nodes": 6, "clamp": "frame",
            "terms": ["stretch", "bend_twist", "centerline"],
            "base": {"insertion": 0.01, "rotation": 0.3},
            "supports": {"guide": {"s": 0.06, "orientation": True,
                                   "displacement": [0.0, 0.002, -0.001]}},
        },
        "distal": {
            "length": 0.06, "radius": 0.003, "youngs_modulus": 4e6, "stretch_modulus": 3e6,
            "density": 900.0, "nodes": 5, "clamp": "free",
            "terms": ["stretch", "bend_twist", "centerline", "joint", "tip_load"],
            "joint": {"rod": "proximal", "s": 0.1, "K_J": 3e3},
            "tip_load": {"force": [0.0, -0.02, 0.03]},
            "supports": {"grip": {"s": 0.06, "orientation": True}},
        },
        "branch": {
            "length": 0.04, "radius": 0.002, "youngs_modulus": 4e6, "stretch_modulus": 3e6,
            "density": 900.0, "nodes": 4, "clamp": "free",
            "terms": ["stretch", "bend_twist", "centerline", "joint"],
            "joint": {"rod": "distal", "s": 0.03, "K_J": 2e3, "orientation": False},
        },
        "sprung": {
            "length": 0.05, "radius": 0.002, "youngs_modulus": 5e6, "stretch_modulus": 4e6,
            "density": 1000.0, "nodes": 5, "clamp": "elastic", "origin": [0.0, 0.08, 0.0],
            "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
            "base": {"insertion": 0.004, "rotation": -0.7, "translational_stiffness": 40.0,
                     "rotational_stiffness": 2e-3, "torsional_stiffness": 7e-4},
            "tip_load": {"force": [0.01, 0.02, -0.015]},
        },
    },
}

#: String tendons (coupling = "string", no tendon rod): one ending part-way at a constant
#: offset, a helical one entering past the base on spacer disks (both on a 'frame'-clamped
#: catheter, whose base frame is a frame knot), and a tabulated one on a 'first_segment'
#: catheter (no base frame: the frame is extrapolated below the first midpoint; 9 nodes, two
#: segments per knot spacing, rodsim/core/routing.py "Sampling"); and one
#: pulled in by a prescribed displacement (rodsim/core/terms/tendon_string_displacement.py:
#: one dense element; taut at the random states).
SMALL_STRING_SCENE = {
    "name": "contract-string-tendons",
    "rods": {
        "catheter": {
            "length": 0.1, "radius": 0.005, "youngs_modulus": 3e6, "stretch_modulus": 3e6,
            "density": 1100.0, "nodes": 8, "clamp": "frame",
            "terms": ["stretch", "bend_twist", "centerline"],
        },
        "shaft": {
            "length": 0.08, "radius": 0.004, "youngs_modulus": 5e6, "stretch_modulus": 5e6,
            "density": 1100.0, "nodes": 9, "clamp": "first_segment", "origin": [0.0, 0.05, 0.0],
            "terms": ["stretch", "bend_twist", "centerline"],
        },
    },
    "tendons": {
        "pull": {"catheter": "catheter", "coupling": "string", "offset": 0.002,
                 "direction": [0.6, 0.8], "tendon_string": {"tension": 1.5, "end": 0.073}},
        "helix": {"catheter": "catheter", "coupling": "string",
                  "tendon_string": {"tension": 0.7, "start": 0.01, "routing": "helix",
                                    "helix_radius": 0.008, "helix_pitch": 0.07,
                                    "helix_phase": 0.3, "spacers": True}},
        "pulled": {"catheter": "catheter", "coupling": "string", "offset": 0.003,
                   "direction": [-0.2, 1.0],
                   "tendon_string": {"control": "displacement", "displacement": 0.006,
                                     "stiffness": 40.0, "start": 0.02, "end": 0.09}},
        "table": {"catheter": "shaft", "coupling": "string",
                  "tendon_string": {"tension": 0.9, "routing": "table",
                                    "table_s": [0.0, 0.03, 0.06, 0.08],
                                    "table_y": [0.002, 0.001, -0.001, -0.002],
                                    "table_z": [0.0, 0.0015, 0.002, 0.001]}},
    },
}

#: String tendons with friction (rodsim/core/tendon_friction.py), whose Jacobian couples every
#: sliding chord's tension to every turn up to it (rodsim/core/turn_gradient.py): an S-shape
#: ("first" ends at a node, where "second", on the other side, has its turn split), a helix
#: entering past the base (3-D, its entry frame moving with the state), per-point friction
#: along the arc length and stiction (μ_s above μ_k), ``exact_jacobian`` on the one-μ
#: tendons (a varying μ takes the span element without it). Several μ (0.05 to 0.5). The tendons
#: carry a history (``FRICTION_HISTORY``) so that random states have chords sticking and
#: sliding both ways (tests/test_friction_jacobian_3d.py checks that they do).
SMALL_FRICTION_STRING_SCENE = {
    "name": "contract-friction-strings",
    "rods": {
        "catheter": {
            "length": 0.1, "radius": 0.005, "youngs_modulus": 3e6, "stretch_modulus": 3e6,
            "density": 1100.0, "nodes": 11, "clamp": "frame",
            "terms": ["stretch", "bend_twist", "centerline"],
        },
    },
    "tendons": {
        "first": {"catheter": "catheter", "coupling": "string", "offset": 0.002,
                  "direction": [0.6, 0.8],
                  "tendon_string": {"tension": 1.5, "end": 0.05, "friction": 0.3,
                                    "exact_jacobian": True}},
        "second": {"catheter": "catheter", "coupling": "string", "offset": 0.002,
                   "direction": [-0.6, -0.8],
                   "tendon_string": {"tension": 0.8, "friction": 0.1,
                                     "static_friction": 0.25}},
        "helix": {"catheter": "catheter", "coupling": "string",
                  "tendon_string": {"tension": 0.7, "start": 0.015, "routing": "helix",
                                    "helix_radius": 0.008, "helix_pitch": 0.07,
                                    "helix_phase": 0.3, "spacers": True, "friction": 0.2,
                                    "exact_jacobian": True}},
        "profile": {"catheter": "catheter", "coupling": "string", "offset": 0.003,
                    "direction": [1.0, 0.0],
                    "tendon_string": {"tension": 1.1, "friction_profile": [0.05, 0.5, 0.2],
                                      "friction_profile_s": [0.0, 0.05, 0.1]}},
    },
}


def friction_history(model: Model) -> Model:
    """The model with every string tendon with friction anchored at a history: the chord
    tensions of its rest state times 0.8 and 1.1 by turns (and, with stiction, the points'
    states −1, 0, +1 by turns), as a step of a track would hold them."""
    from rodsim.core.terms.tendon_string import TendonString

    x = model.full(np.zeros(model.n))
    terms = []
    for term in model.terms:
        if isinstance(term, TendonString) and term.rubs:
            tensions = term.chord_tensions(x)
            chords = np.arange(len(tensions))
            history = tensions * np.where(chords % 2 == 0, 0.8, 1.1)
            if term.sticky:
                history = np.concatenate([history, (chords % 3) - 1.0])
            term = term.anchored(history)
        terms.append(term)
    return model.with_terms(terms)


#: Contract scenes whose models carry a history (``friction_history``).
FRICTION_HISTORY = {"contract-friction-strings"}

#: Random states per (scene, term).
STATES = 2
FD_RELATIVE_STEP = 1e-6
TOLERANCE = 1e-6


SMALL_SCENES = {scene["name"]: scene for scene in (SMALL_SCENE, SMALL_LOAD_SCENE,
                                                    SMALL_TENDON_SCENE,
                                                    SMALL_PAPER_TENDON_SCENE,
                                                    SMALL_CONTACT_SCENE,
                                                    SMALL_FRICTION_SCENE, SMALL_JOINT_SCENE,
                                                    SMALL_STRING_SCENE,
                                                    SMALL_FRICTION_STRING_SCENE)}
#: Every contract scene by name: the shipped scenes, then the small ones above.
CONTRACT_SCENES = [*scene_paths(), *SMALL_SCENES]


#: The shipped scenes are checked with their rods' node counts divided by this (at least
#: MIN_NODES each): the contract is local to each element, so N does not matter to it, while
#: the dense finite differences cost ~N² (four-tendons at full size took 30 s).
NODE_DIVISOR = 3
MIN_NODES = 4


@functools.cache
def contract_model(name: str) -> Model:
    """One contract scene, assembled once (a shipped one with fewer nodes, same structure)."""
    if name in SMALL_SCENES:
        model = rodsim.build_model(copy.deepcopy(SMALL_SCENES[name]))
        return friction_history(model) if name in FRICTION_HISTORY else model
    scene = Scene.load(scene_paths()[name])
    return Model(scene.with_values({
        f"rods.{rod}.nodes": max(MIN_NODES, -(-table["nodes"] // NODE_DIVISOR))
        for rod, table in scene.data["rods"].items()}))


def contract_models() -> dict[str, Model]:
    return {name: contract_model(name) for name in CONTRACT_SCENES}


def free_index(model: Model) -> np.ndarray:
    """Free-coordinate index of every full-state coordinate (−1 where clamped)."""
    index = np.full(model.full_size, -1)
    index[model.free] = np.arange(model.n)
    return index


def state_for(model: Model, term: Term, x: np.ndarray) -> np.ndarray:
    """The full state ``term`` is evaluated on at the free coordinates ``x``: the offsets
    for a term on offsets (``Term.offsets``), else the positions and quaternions."""
    return model.offsets(x) if term.offsets else model.full(x)


def term_force(model: Model, term: Term, x: np.ndarray) -> np.ndarray:
    """One term's element forces scattered (with accumulation) onto the free coordinates."""
    target = free_index(model)[term.dofs]
    values = np.asarray(term.element_forces(state_for(model, term, x)), dtype=float)
    assert values.shape == term.dofs.shape, f"{term.name}: element_forces shape"
    keep = target >= 0
    return np.bincount(target[keep], weights=values[keep], minlength=model.n)


def term_jacobian(model: Model, term: Term, x: np.ndarray) -> np.ndarray:
    """One term's element Jacobians scattered (with accumulation) into a dense n × n array."""
    out = np.zeros((model.n, model.n))
    if not term.has_jacobian:
        return out
    target = free_index(model)[term.dofs]
    values = np.asarray(term.element_jacobians(state_for(model, term, x)), dtype=float)
    k = term.dofs.shape[1]
    assert values.shape == (len(term.dofs), k, k), f"{term.name}: element_jacobians shape"
    rows = np.broadcast_to(target[:, :, None], values.shape)
    cols = np.broadcast_to(target[:, None, :], values.shape)
    keep = (rows >= 0) & (cols >= 0)
    np.add.at(out, (rows[keep], cols[keep]), values[keep])
    return out


def coordinate_blocks(model: Model) -> list[np.ndarray]:
    """The free coordinates grouped by rod and kind (positions, quaternions): the Jacobian
    is compared block by block, each block relative to its own largest entry, because the
    blocks differ by orders of magnitude (a centerline's quaternion–quaternion block is
    ~1e4 below its position block) and one global scale would hide errors in the small
    ones."""
    index = free_index(model)
    blocks = []
    for rod in model.rods.values():
        for kind in (rod.layout.position_index, rod.layout.quaternion_index):
            free = index[np.ravel(kind)]
            if np.any(free >= 0):
                blocks.append(free[free >= 0])
    return blocks


def block_errors(model: Model, jac: np.ndarray, jac_fd: np.ndarray) -> list[tuple[float, str]]:
    """(relative error, block label) for every block pair with a non-zero entry."""
    blocks = coordinate_blocks(model)
    scale = max(np.max(np.abs(jac)), np.max(np.abs(jac_fd)))
    out = []
    for a, rows in enumerate(blocks):
        for b, cols in enumerate(blocks):
            analytic, numeric = jac[np.ix_(rows, cols)], jac_fd[np.ix_(rows, cols)]
            block_scale = max(np.max(np.abs(analytic)), np.max(np.abs(numeric)))
            if block_scale > 1e-12 * scale:
                out.append((float(np.max(np.abs(analytic - numeric)) / block_scale),
                            f"block ({a}, {b})"))
    return out


def term_energy(model: Model, term: Term, x: np.ndarray) -> float:
    return float(term.energy(state_for(model, term, x)))


def pattern_set(model: Model) -> set[tuple[int, int]]:
    coo = model.pattern.tocoo()
    return set(zip(coo.row.tolist(), coo.col.tolist(), strict=True))


def registered(model: Model, x: np.ndarray) -> Model:
    """The model at state ``x``: dynamic terms (a tendon point's parent catheter node) first
    take their registration from ``x``; it then stays frozen while finite differences
    perturb the state, as it does inside every solver evaluation."""
    return model.reregistered(x) or model


def cases_for(term_name: str) -> list[tuple[str, Model, int]]:
    """(scene, model, index of the term in model.terms) of every use of the term."""
    return [(scene, model, index) for scene, model in contract_models().items()
            for index, term in enumerate(model.terms) if term.name == term_name]


#: Terms whose contract takes more than ~10 s (every tendon scene uses the lumen).
SLOW_TERMS = {"lumen", "lumen_conserving"}


@pytest.mark.parametrize("term_name", [
    pytest.param(name, marks=pytest.mark.slow) if name in SLOW_TERMS else name
    for name in sorted(registered_terms())])
def test_term_contract(term_name, random_state, fd):
    cases = cases_for(term_name)
    if not cases:
        pytest.fail(f"registered term {term_name!r} appears in no contract scene: add it to a "
                    "shipped scene in data/ or to SMALL_SCENE / SMALL_TENDON_SCENE in "
                    "tests/test_term_contract.py (no new test code is needed)")
    exercised = 0
    for scene, rest_model, index in cases:
        label = f"term {term_name!r} in scene {scene!r}"
        steps = fd["steps"](rest_model, FD_RELATIVE_STEP)
        rng = np.random.default_rng(list(map(ord, scene + term_name)))
        for _ in range(STATES):
            x = random_state(rest_model, rng)
            model = registered(rest_model, x)
            term = model.terms[index]
            pattern = pattern_set(model)
            force = term_force(model, term, x)
            force_scale = np.max(np.abs(force))
            if force_scale == 0.0:
                # A shipped scene may hold a term idle at some states (a tendon at zero
                # tension, an obstacle out of reach): then its Jacobian must vanish too, and
                # the term must be exercised elsewhere (asserted below).
                jac_fd = fd["jacobian"](lambda y, t=term, m=model: term_force(m, t, y), x,
                                        steps)
                assert not np.any(term_jacobian(model, term, x)) and not np.any(jac_fd), (
                    f"{label}: zero force but a non-zero Jacobian at a random state")
                continue
            exercised += 1

            if not term.has_jacobian:
                other = random_state(model, rng)
                assert np.array_equal(force, term_force(model, term, other)), (
                    f"{label}: has_jacobian = False but the force depends on the state")

            if term.conservative:
                assert term.energy(state_for(model, term, x)) is not None, (
                    f"{label}: conservative but energy() returns None")
                grad = fd["gradient"](lambda y, t=term, m=model: term_energy(m, t, y), x, steps)
                error = np.max(np.abs(force + grad))
                assert error < TOLERANCE * force_scale, (
                    f"{label}: force != -dE/dx, max error {error:.3g} "
                    f"(force scale {force_scale:.3g})")

            jac = term_jacobian(model, term, x)
            jac_fd = fd["jacobian"](lambda y, t=term, m=model: term_force(m, t, y), x, steps)
            jac_scale = max(np.max(np.abs(jac)), np.max(np.abs(jac_fd)))
            error, block = max(block_errors(model, jac, jac_fd), default=(0.0, "-"))
            assert error <= TOLERANCE, (
                f"{label}: Jacobian != dF/dx, relative error {error:.3g} in {block} "
                "(blocks: rod × positions/quaternions)")

            if jac_scale > 0.0:
                rows, cols = np.nonzero(np.abs(jac_fd) > 1e-9 * jac_scale)
                outside = [(r, c) for r, c in zip(rows.tolist(), cols.tolist(), strict=True)
                           if (r, c) not in pattern]
                assert not outside, (
                    f"{label}: {len(outside)} non-zero dF/dx entries outside model.pattern, "
                    f"e.g. {outside[:5]}")
                rows, cols = np.nonzero(jac)
                outside = [(r, c) for r, c in zip(rows.tolist(), cols.tolist(), strict=True)
                           if (r, c) not in pattern]
                assert not outside, f"{label}: analytic entries outside model.pattern"

            if term.conservative:
                asymmetry = np.max(np.abs(jac - jac.T))
                assert asymmetry <= 1e-10 * max(jac_scale, 1e-300), (
                    f"{label}: conservative but the Jacobian is not symmetric "
                    f"(max |J - J^T| = {asymmetry:.3g})")
    assert exercised > 0, (f"term {term_name!r}: zero force at every random state of every "
                           "contract scene; give it non-trivial parameters in a contract scene")


@pytest.mark.parametrize("scene", CONTRACT_SCENES)
def test_pattern_is_exactly_the_union_of_jacobian_blocks(scene):
    """model.pattern = diagonal ∪ element blocks of the terms with a Jacobian; terms without
    one (dead loads) add nothing."""
    model = contract_model(scene)
    index = free_index(model)
    expected = {(i, i) for i in range(model.n)}
    for term in model.terms:
        if term.has_jacobian:
            for element in index[term.dofs]:
                free = element[element >= 0].tolist()
                expected.update((r, c) for r in free for c in free)
    assert pattern_set(model) == expected
    assert model.nnz == len(expected)


@pytest.mark.parametrize("scene", CONTRACT_SCENES)
def test_assembled_model_matches_finite_differences(scene, random_state, fd):
    model = contract_model(scene)
    steps = fd["steps"](model, FD_RELATIVE_STEP)
    rng = np.random.default_rng(7)
    x = random_state(model, rng)
    model = registered(model, x)
    conservative = all(term.conservative for term in model.terms)
    force = model.force(x)
    force_scale = np.max(np.abs(force))
    if conservative:
        force_fd = -fd["gradient"](model.energy, x, steps)
        assert np.max(np.abs(force - force_fd)) < TOLERANCE * force_scale

    jac = model.jacobian(x).toarray()
    jac_fd = fd["jacobian"](model.force, x, steps)
    jac_scale = np.max(np.abs(jac_fd))
    error, block = max(block_errors(model, jac, jac_fd))
    assert error < TOLERANCE, f"relative error {error:.3g} in {block}"
    if conservative:
        assert np.max(np.abs(jac - jac.T)) <= 1e-10 * jac_scale
    # Nothing the finite differences see is missing from the declared pattern.
    pattern = model.pattern.toarray() != 0
    assert not np.any((np.abs(jac_fd) > 1e-9 * jac_scale) & ~pattern)
    # jacobian_data is in the pattern's CSC order.
    np.testing.assert_array_equal(model.pattern_matrix(model.jacobian_data(x)).toarray(), jac)
    # Loads are scaled by the load factor, internal forces are not.
    loads = sum((term_force(model, t, x) for t in model.terms if t.is_load),
                np.zeros(model.n))
    np.testing.assert_allclose(model.force(x, 0.25), force - 0.75 * loads,
                               rtol=0, atol=1e-12 * force_scale)


def undeclared(kind: type[Term]) -> list[str]:
    """What a term class fails to declare of what the layers above the model ask of a term
    instead of its name (rodsim/core/terms/base.py): its figure layer, the advice of its
    constraint penalty, and for a term that joins rods the options naming the other rod."""
    missing = []
    if getattr(kind, "figure_layer", None) not in FIGURE_LAYERS:
        missing.append(f"figure_layer (one of {FIGURE_LAYERS})")
    if bool(kind.constraint_constant) != bool(kind.penalty_advice) or (
            kind.constraint_constant not in kind.penalty_advice):
        missing.append("penalty_advice naming its constraint_constant (and none without one)")
    if kind.joins_rods and not (kind.holds_base and {"rod", "s"} <= {
            p.name for p in kind.parameters}):
        missing.append("joins_rods: holds_base and the options rod and s")
    return missing


@pytest.mark.parametrize("term_name", sorted(registered_terms()))
def test_term_declares_what_the_layers_above_ask(term_name):
    """The figures, the trust estimate, the solvers' retraction and the joined supports read
    these declarations and never a term's name (tests/test_term_seam.py)."""
    kind = registered_terms()[term_name]
    assert not undeclared(kind), f"term {term_name!r} does not declare: {undeclared(kind)}"


def test_a_term_lacking_a_declaration_is_caught():
    joint = registered_terms()["joint"]
    # Subclasses without a ``name`` of their own: not registered.
    assert "figure_layer" in undeclared(type("NoLayer", (RodTerm,), {}))[0]
    assert "penalty_advice" in undeclared(type("NoAdvice", (joint,), {"penalty_advice": ""}))[0]
    assert "joins_rods" in undeclared(type("Loose", (joint,), {"holds_base": False}))[0]
    assert not undeclared(joint)


@pytest.mark.parametrize("scene", CONTRACT_SCENES)
def test_one_sided_terms_are_those_with_a_latent_stiffness(scene):
    """``Term.unilateral`` (the solvers' retraction reads it) is declared by exactly the
    terms whose stiffness a state away from rest may meet (``latent_stiffness``)."""
    for term in contract_model(scene).terms:
        assert type(term).unilateral == (term.latent_stiffness() is not None), (
            f"{scene}: term {term.name!r} declares unilateral = {type(term).unilateral}")
