"""Regularised Coulomb friction of the contact term (issue 25 item 2; docs/contact.md,
"Friction"). The finite-difference and kernel checks of the law are in
tests/test_term_contract.py and tests/test_kernels.py (scene ``contract-friction``, states in
slip and in stick); here: friction 0 is the frictionless result bitwise, Coulomb's
saturation on a rod dragged along a plane under a constant normal load (with the
regularisation's own prediction), the anchors as explicit model state, and the path
dependence of an insertion and retraction along the shipped vessel. Run with ``pytest -s``
for the numbers."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from test_term_contract import SMALL_SCENES

import rodsim
from rodsim.app.inverse.track import track
from rodsim.core.model import Model
from rodsim.core.scene import Scene

RADIUS, LENGTH, LOAD, MU, NODES = 1e-3, 0.1, 1.0, 0.3, 21
#: The regularisation length ε = slip_scale · r with the default slip_scale.
EPSILON = 1e-3 * RADIUS


def dragged_rod(mu: float) -> Scene:
    """A straight rod (clamped at its base, along +x) lying on the plane y = 0 under a
    uniform downward load of LOAD N/m: its nodes' spheres rest on the plane."""
    return Scene.from_dict({"name": "dragged-rod", "rods": {"c": {
        "length": LENGTH, "radius": RADIUS, "youngs_modulus": 1e8, "stretch_modulus": 1e8,
        "density": 1000.0, "nodes": NODES, "origin": [0.0, RADIUS, 0.0],
        "terms": ["stretch", "bend_twist", "centerline", "distributed_load"],
        "distributed_load": {"force_per_length": [0.0, -LOAD, 0.0]}}},
        "obstacles": {"floor": {"type": "plane", "rods": ["c"], "point": [0.0, 0.0, 0.0],
                                "normal": [0.0, 1.0, 0.0], "friction": mu}},
        "solver": {"integrator": "static"}})


def test_friction_zero_is_the_frictionless_result_bitwise():
    """friction = 0 (whatever slip_scale) evaluates nothing of the friction law: the same
    model (conservative: Newton keeps its energy line search) and the same equilibrium,
    bit for bit; and a tiny friction is continuous with it."""
    shipped = rodsim.load_scene("tip-on-tissue")
    zero = shipped.with_values({"obstacles.tissue.friction": 0.0,
                                "obstacles.tissue.slip_scale": 0.5})
    tiny = shipped.with_values({"obstacles.tissue.friction": 1e-9})
    assert Model(zero).terms[-1].conservative and Model(dragged_rod(0.0)).conservative
    assert not Model(tiny).terms[-1].conservative and not Model(dragged_rod(MU)).conservative
    reference = rodsim.solve(shipped, "static")
    again = rodsim.solve(zero, "static")
    close = rodsim.solve(tiny, "static")
    assert reference.success and again.success and close.success
    assert np.array_equal(reference.state, again.state)
    length = shipped.data["rods"]["catheter"]["length"]
    moved = float(np.max(np.abs(close.state - reference.state))) / length
    print(f"\ntip-on-tissue, friction 1e-9 against 0: max coordinate change {moved:.2g} L")
    assert moved < 1e-6

    # The term itself, compiled and numpy, at a random state of the contract scene.
    table = copy.deepcopy(SMALL_SCENES["contract-contact"])
    for obstacle in table["obstacles"].values():
        obstacle |= {"friction": 0.0, "slip_scale": 7.0}
    for kernels in ("compiled", "numpy"):
        plain = Model(Scene.from_dict(copy.deepcopy(SMALL_SCENES["contract-contact"])),
                      kernels)
        explicit = Model(Scene.from_dict(copy.deepcopy(table)), kernels)
        x = plain.x0 + 1e-3 * np.random.default_rng(5).standard_normal(plain.n)
        assert np.array_equal(plain.force(x), explicit.force(x))
        assert np.array_equal(plain.jacobian_data(x), explicit.jacobian_data(x))


def test_a_rod_dragged_along_a_plane_sticks_then_slides_at_coulomb():
    """The base of the dragged rod is pulled back (−x) in a track: by a fraction of ε first
    (sticking: the plane's tangential reaction T grows with the pull and stays far below
    μ N), then by 1 mm per step (sliding: every node slips Δ = 1 mm per step, and
    T = μ N Δ/√(Δ² + ε²), Coulomb's μ N to (ε/Δ)²/2 = 5e-7). N, the plane's normal
    reaction, is the load on the free nodes, LOAD (L − l/2) (the clamped base node's half
    segment goes to the clamp), within the bending share the clamp takes."""
    pulls = np.concatenate([[0.0], -EPSILON * np.array([0.05, 0.1, 0.2]),
                            -np.linspace(1e-3, 1e-2, 10)])
    path = track(dragged_rod(MU), {"rods.c.base.insertion": pulls})
    assert path.success, path.message
    normal = np.array([force[:, 1].sum() for force in path.contact])
    tangential = np.array([force[:, 0].sum() for force in path.contact])
    ratio = tangential / (MU * normal)
    segment = LENGTH / (NODES - 1)
    print("\ndragged rod: pull [m], N [N], T / (mu N): " + "; ".join(
        f"{-p:.2g} {n:.5g} {r:.8f}" for p, n, r in zip(pulls, normal, ratio, strict=True)))
    assert np.all(np.abs(normal / (LOAD * (LENGTH - segment / 2)) - 1.0) < 1e-2)
    sticking, sliding = ratio[1:4], ratio[4:]
    assert np.all(np.diff(sticking) > 0) and np.all(sticking > 0)
    assert np.all(sticking < 0.1)
    step = 1e-3
    predicted = step / math.hypot(step, EPSILON)
    assert np.all(np.abs(sliding - predicted) < 1e-8)
    assert np.all(sliding < 1.0)

    frictionless = track(dragged_rod(0.0), {"rods.c.base.insertion": pulls[[0, -1]]})
    assert frictionless.success, frictionless.message
    assert np.all(np.array([force[:, 0].sum() for force in frictionless.contact]) == 0.0)


def test_anchors_are_explicit_model_state():
    """Model.anchored sets the friction anchors from a state (friction then vanishes there:
    no slip), returns the model itself without friction, and a model of other parameter
    values keeps its anchors (Model.with_values, Model.with_scene)."""
    scene = dragged_rod(MU)
    model = Model(scene)
    contact = model.terms[-1]
    np.testing.assert_array_equal(contact.anchor_positions(),
                                  model.full(model.x0)[contact.dofs])
    x = model.x0.copy()
    positions = model.rods["c"].layout.position_index
    moved = model.full(x)
    moved[positions[1:, 0]] += 1e-4  # every free node slid 0.1 mm along +x
    moved[positions[1:, 1]] -= 1e-6  # and pressed into the plane
    x = model.state_of(moved)
    slid = model.terms[-1].element_forces(model.full(x))
    assert np.all(slid[1:, 0] < 0.0)  # friction against the slide
    anchored = model.anchored(x)
    assert anchored is not model and model.terms[-1].anchor_positions() is not None
    np.testing.assert_array_equal(anchored.terms[-1].anchor_positions(),
                                  model.full(x)[contact.dofs])
    at_anchor = anchored.terms[-1].element_forces(model.full(x))
    assert np.all(at_anchor[:, 0] == 0.0) and np.all(at_anchor[1:, 1] > 0.0)
    for other in (anchored.with_values(scene.with_values({"rods.c.base.insertion": -0.01})),
                  anchored.with_scene(scene.with_values({"obstacles.floor.friction": 0.5}))):
        assert other is not None
        np.testing.assert_array_equal(other.terms[-1].anchor_positions(),
                                      anchored.terms[-1].anchor_positions())
    frictionless = Model(dragged_rod(0.0))
    assert frictionless.anchored(x) is frictionless


def insertion_and_retraction(mu: float, integrator: str) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
    """vessel-insertion advanced 0 → 20 mm in 4 mm steps and retracted to 0 the same way:
    (insertions, contact resultant per step (steps, 3) [N], node positions per step)."""
    scene = rodsim.load_scene("vessel-insertion").with_values(
        {"obstacles.vessel.friction": mu})
    there = np.linspace(0.0, 0.02, 6)
    insertions = np.concatenate([there, there[::-1][1:]])
    path = track(scene, {"rods.catheter.base.insertion": insertions}, integrator)
    assert path.success, path.message
    return insertions, np.array(path.contact).sum(axis=1), np.array(path.positions)


@pytest.mark.slow
def test_insertion_then_retraction_is_path_dependent_with_friction_only():
    """Hysteresis: with friction 0.3 the vessel's force on the catheter at the same insertion
    differs going in and coming out — its axial (x) part resists the motion: against the
    insertion going in, against the retraction coming out — while without friction the two
    agree to the solvers' tolerance. Back at insertion 0 the catheter no longer touches the
    vessel, so nothing holds the path and the shape returns (to 1e-10 L).

    ida, and cvode as a second integrator (the same steps to 1e-6 of the largest force):
    not static, whose non-conservative line search (the residual merit, not the energy) does
    not get through this insertion even without friction (docs/contact.md, "Friction")."""
    insertions, rubbing, positions = insertion_and_retraction(0.3, "ida")
    _, again, _ = insertion_and_retraction(0.3, "cvode")
    _, smooth, smooth_positions = insertion_and_retraction(0.0, "ida")
    assert np.max(np.abs(again - rubbing)) < 1e-6 * np.max(np.abs(rubbing))
    last = len(insertions) - 1
    length = 0.1
    rows = []
    for k in range(1, 5):
        rows.append(f"{insertions[k] * 1e3:.0f} mm: in {rubbing[k, 0] * 1e3:.3f}, out "
                    f"{rubbing[last - k, 0] * 1e3:.3f} mN (mu 0: {smooth[k, 0] * 1e3:.3f}, "
                    f"{smooth[last - k, 0] * 1e3:.3f})")
    print("\nvessel insertion and retraction, axial contact resultant: " + "; ".join(rows))
    scale = np.max(np.abs(smooth))
    for k in range(1, 5):
        assert np.max(np.abs(smooth[k] - smooth[last - k])) < 1e-6 * scale
    for k in (3, 4):  # 12 and 16 mm: the tip in the bend
        assert rubbing[k, 0] < -0.5e-3 and rubbing[last - k, 0] > 0.1e-3
        assert np.linalg.norm(rubbing[k] - rubbing[last - k]) > 0.5e-3
        assert rubbing[k, 0] < smooth[k, 0] < rubbing[last - k, 0]
    assert np.max(np.linalg.norm(positions[-1] - positions[0], axis=1)) < 1e-10 * length
    assert np.max(np.linalg.norm(smooth_positions[-1] - positions[-1], axis=1)) < 1e-6 * length


def test_a_tracks_last_step_is_assessed_with_its_own_anchors():
    """The penalty-error estimate of a track's last step (rodsim/app/trust.py) re-solves that
    step: with friction, with the anchors of that step (the equilibrium before it). The
    dragged rod pulled back 2 mm then pushed 1 mm forward: its last step's friction pulls
    −x (against the push); re-solved with the anchors it stays where it is, and the penalty
    estimate is made; a model anchored at rest instead would pull +x and move it."""
    from rodsim.app.trust import assess, last_step_result

    path = track(dragged_rod(MU), {"rods.c.base.insertion": [0.0, -2e-3, -1e-3]})
    assert path.success, path.message
    assert path.contact[-1][:, 0].sum() < 0.0  # the last step's friction resists the push
    last = last_step_result(path)
    assert last is not None
    state = path.last_model.state_of(path.states[-1])  # offsets from the last model's rest
    assert np.max(np.abs(last.state - state)) < 1e-12 * LENGTH
    estimate = assess(last, model=path.last_model)
    assert np.isfinite(estimate.penalty.error) and estimate.penalty.error < 1e-6
    rest_anchors = Model(path.last_model.scene)
    assert np.max(np.abs(rest_anchors.force(state))) > 1e3 * np.max(
        np.abs(path.last_model.force(state)))
