"""Supports (rodsim/core/supports.py): an actuated base — insertion along the base axis and
rotation about it — moves and turns the whole rest shape and what is attached to it;
``track`` ramps both and ``reach`` solves for them (docs/model.md, "Supports and anchors")."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

import rodsim
from rodsim.core.analytic import extensible_elastica
from rodsim.core.rod.quaternion import directors
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError

LENGTH = 0.12  # m, table1-50g
STIFF = ["K_P=1e8", "static.max_newton=200"]


def rotation_x(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _solve(scene, values: dict | None = None):
    result = rodsim.solve(scene.with_values(values or {}), "static")
    assert result.success, result.message
    return result


def test_an_inserted_cantilever_is_the_elastica_moved_along_its_axis():
    """A straight cantilever inserted by d under a hanging mass: its tip is the extensible
    elastica's (the continuum reference, rodsim/core/analytic) moved by d along +x, within
    the discretisation error at N = 80 (4e-6 m, tests/test_accuracy.py); and every node is
    the uninserted equilibrium's moved by d, to round-off."""
    scene = rodsim.load_scene("table1-50g", ["nodes=80", *STIFF])
    rod = scene.data["rods"]["catheter"]
    d = 0.037
    inserted = _solve(scene, {"rods.catheter.base.insertion": d})
    at_rest = _solve(scene)
    ei = rod["youngs_modulus"] * math.pi * rod["radius"] ** 4 / 4.0
    ea = rod["stretch_modulus"] * math.pi * rod["radius"] ** 2
    ref = extensible_elastica((0.0, -rod["tip_load"]["mass"] * rod["tip_load"]["gravity"]),
                              ei, ea, rod["length"])
    tip = inserted.tip()
    error = math.hypot(tip[0] - (ref.x[-1] + d), tip[1] - ref.y[-1])
    print(f"\ninserted by {d} m: tip error vs elastica moved by d {error:.3e} m")
    assert error < 1e-5
    assert abs(tip[2]) < 1e-12
    shift = inserted.rods["catheter"].positions - at_rest.rods["catheter"].positions
    assert np.abs(shift - [d, 0.0, 0.0]).max() < 1e-12 * LENGTH
    assert np.abs(inserted.rods["catheter"].quaternions
                  - at_rest.rods["catheter"].quaternions).max() < 1e-12


def test_rotation_about_the_axis_is_the_rotated_solution():
    """A base turned by θ about its axis with a tip load along −y equals the unturned rod
    under the load turned by −θ, turned by θ: positions and directors."""
    scene = rodsim.load_scene("table1-50g", ["nodes=20"])
    theta = 0.7
    turn = rotation_x(theta)
    weight = np.array([0.0, -0.05 * 9.81, 0.0])
    turned = _solve(scene, {"rods.catheter.base.rotation": theta})
    reference = _solve(scene, {"tip_load.mass": 0.0, "tip_load.force": list(turn.T @ weight)})
    ours, theirs = turned.rods["catheter"], reference.rods["catheter"]
    # the reference load is out of the rest d1 plane: its rod bends out of it
    assert abs(reference.tip()[2]) > 0.01 * LENGTH
    assert np.abs(ours.positions - theirs.positions @ turn.T).max() < 1e-12 * LENGTH
    assert np.abs(directors(ours.quaternions)
                  - directors(theirs.quaternions) @ turn.T).max() < 1e-10


@pytest.mark.parametrize("name", ["table3-catheter1", "tendon-conserving"])
def test_the_base_carries_its_tendons(name):
    """Inserting or turning a tendon-driven catheter's base moves its tendons with it (their
    lumen entrance and base frame): every rod of the equilibrium is the unmoved one moved
    (d along +x) or turned (θ about +x), for the distal (paper) and the proximal
    (conserving) actuation."""
    scene = rodsim.load_scene(name)
    at_rest = _solve(scene)
    d, theta = 0.021, -1.1
    inserted = _solve(scene, {"insertion": d})
    turned = _solve(scene, {"rotation": theta})
    for rod in at_rest.rods:
        base = at_rest.rods[rod].positions
        assert np.abs(inserted.rods[rod].positions - base - [d, 0, 0]).max() < 1e-11 * 0.16
        assert np.abs(turned.rods[rod].positions - base @ rotation_x(theta).T).max() < (
            1e-11 * 0.16)
    assert abs(turned.tip("catheter")[2]) > 0.01 * 0.16  # the bending plane turned


def test_sensitivity_to_insertion_is_a_rigid_translation():
    """d(every node)/d(insertion) = +x: the implicit-function sensitivity of an inserted
    base (rodsim/app/inverse/sensitivity.py) for a tendon-bent catheter."""
    scene = rodsim.load_scene("table3-catheter1")
    sens = rodsim.sensitivity(_solve(scene), ["insertion", "rotation"])
    for rod, positions in sens.positions.items():
        np.testing.assert_allclose(positions[0], np.tile([1.0, 0, 0], (len(positions[0]), 1)),
                                   atol=1e-7, err_msg=rod)
    # d(tip)/dθ = e_x × tip (a turn about +x through the origin)
    tip = _solve(scene).tip("catheter")
    np.testing.assert_allclose(sens.tip("catheter")[1], np.cross([1.0, 0, 0], tip),
                               atol=1e-7 * 0.16)


def test_track_ramps_insertion_and_rotation_together():
    """``rodsim track`` along insertion 0 → 20 mm and rotation 0 → 1 rad: every step's tip
    is the unmoved tip turned by θ_k and moved by d_k."""
    scene = rodsim.load_scene("table3-catheter1")
    tip0 = _solve(scene).tip("catheter")
    ins = np.linspace(0.0, 0.02, 6)
    rot = np.linspace(0.0, 1.0, 6)
    path = rodsim.track(scene, {"insertion": ins, "rotation": rot}, "static",
                        estimates=False)
    assert path.success, path.message
    # Each warm start is the last equilibrium carried rigidly with the base (Model.carried):
    # already the next one, so no step is halved and no Newton iteration is needed (without
    # it: 12 halvings and 1051 iterations over these 5 steps).
    assert sum(path.halvings) == 0 and max(path.iterations[1:]) <= 1
    for k in range(6):
        expected = rotation_x(rot[k]) @ tip0 + [ins[k], 0.0, 0.0]
        assert np.abs(path.tips("catheter")[k] - expected).max() < 1e-8 * 0.16, k


def test_reach_solves_for_insertion_and_rotation():
    """``rodsim reach --actuate insertion,rotation`` puts a tendon-bent catheter's tip on a
    target made by inserting by 12 mm and turning by 0.4 rad; the values are recovered."""
    scene = rodsim.load_scene("table3-catheter1")
    tip0 = _solve(scene).tip("catheter")
    target = rotation_x(0.4) @ tip0 + [0.012, 0.0, 0.0]
    found = rodsim.reach(scene, target, ["insertion", "rotation"], rod="catheter")
    assert found.success, found.message
    np.testing.assert_allclose(found.values, [0.012, 0.4], rtol=1e-5)
    assert found.distance < 1e-6


def test_a_tendon_rod_has_no_base_of_its_own():
    """A tendon's base is its lumen's entrance: a [rods.<tendon>.base] table is refused with
    one line naming it."""
    data = copy.deepcopy(rodsim.load_scene("table3-catheter1").data)
    data["rods"]["tendon"]["base"] = {"insertion": 0.01}
    with pytest.raises(SceneError, match=r"^rods\.tendon\.base: a tendon's base") as error:
        Scene.from_dict(data)
    assert "\n" not in str(error.value)


def _pinned(nodes: int, supports: dict, *overrides: str) -> dict:
    data = copy.deepcopy(rodsim.load_scene(
        "table1-50g", [f"nodes={nodes}", *STIFF, "tip_load.mass=0", *overrides]).data)
    data["rods"]["catheter"]["supports"] = supports
    return data


def test_a_prescribed_tip_displacement_bends_the_rod_as_beam_theory_at_second_order():
    """A cantilever whose tip node is held displaced by δ = 1e-4 L sideways: the linear
    beam's y(s) = δ s² (3L − s) / (2L³) (the shape of a tip force; the nonlinearity is
    O(δ²/L²)), at every node, the error falling at second order in N."""
    delta = 1e-4 * LENGTH
    errors = []
    for nodes in (11, 21, 41):
        result = _solve(Scene.from_dict(_pinned(
            nodes, {"tip": {"s": LENGTH, "displacement": [0.0, delta, 0.0]}})))
        s = np.linspace(0.0, LENGTH, nodes)
        beam = delta * s**2 * (3 * LENGTH - s) / (2 * LENGTH**3)
        errors.append(np.abs(result.rods["catheter"].positions[:, 1] - beam).max() / delta)
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    print(f"\nprescribed tip displacement: errors / δ {errors}, orders {orders}")
    assert errors[-1] < 1e-4
    assert np.all(orders > 1.8) and np.all(orders < 2.2)


def test_track_ramps_a_prescribed_displacement():
    """``rodsim track`` ramps a node support's displacement like any numeric value; each
    step is the cold equilibrium."""
    data = _pinned(15, {"mid": {"s": 0.06}})
    scene = Scene.from_dict(data)
    values = [0.0, 0.005, 0.01]
    path = rodsim.track(scene, {"supports.mid.displacement[1]": values}, "static",
                        estimates=False)
    assert path.success, path.message
    for step, value in enumerate(values):
        cold = _solve(scene.with_values({"rods.catheter.supports.mid.displacement":
                                         [0.0, value, 0.0]}))
        assert abs(cold.rods["catheter"].positions[7, 1] - value) < 1e-15
        assert np.abs(path.positions[step] - cold.rods["catheter"].positions).max() < (
            1e-8 * LENGTH)


@pytest.mark.parametrize(("supports", "message"), [
    ({"far": {"s": 0.2}}, r"^rods\.catheter\.supports\.far\.s = 0\.2: beyond the rod"),
    ({"off": {"s": 0.05}}, r"^rods\.catheter\.supports\.off\.s = 0\.05: between two nodes"),
    ({"base": {"s": 0.0}}, r"^rods\.catheter\.supports\.base\.s = 0\.0: the base support"),
    ({"a": {"s": 0.06}, "b": {"s": 0.06}},
     r"^rods\.catheter\.supports\.b\.s = 0\.06: node 7 is already held by"),
    ({"tip": {"s": 0.12, "angle": 1.0}}, r"^rods\.catheter\.supports\.tip\.angle: unknown key"),
    ({"tip": 0.12}, r"^rods\.catheter\.supports: expected tables"),
    ({"tip": {"s": 0.12, "orientation": "yes"}},
     r"^rods\.catheter\.supports\.tip\.orientation = 'yes': wrong type"),
])
def test_bad_supports_are_one_line_scene_errors(supports, message):
    with pytest.raises(SceneError, match=message) as error:
        Scene.from_dict(_pinned(15, supports))
    assert "\n" not in str(error.value)


def test_a_support_where_a_tendon_is_anchored_is_refused():
    """The tendon's tip is held by its termination anchor: a support there too is a
    one-line SceneError saying so."""
    data = copy.deepcopy(rodsim.load_scene("table3-catheter1").data)
    data["rods"]["tendon"]["supports"] = {"tip": {"s": 0.16}}
    with pytest.raises(SceneError, match=r"^rods\.tendon\.supports\.tip: a support on a "
                       r"tendon rod at its termination, where its anchor"):
        Scene.from_dict(data)


def test_the_node_of_a_support_is_not_a_numeric_parameter():
    """Moving s changes which coordinates are fixed: refused as a track or reach key."""
    scene = Scene.from_dict(_pinned(15, {"mid": {"s": 0.06}}))
    with pytest.raises(SceneError, match="changes the discretisation"):
        rodsim.track(scene, {"supports.mid.s": [0.06, 0.07]}, "static")


def test_a_support_that_holds_the_frame_clamps_the_rod_there():
    """A rod held in position and frame at its middle node (``orientation = true``) under
    the tip mass: the distal half is the cantilever of half the length clamped there — the
    same discrete problem (frame elements of l/2 on both sides of the held node), so the
    same equilibrium to the solver's tolerance — and the unloaded proximal half stays at
    rest."""
    held = _solve(Scene.from_dict(_pinned(
        21, {"guide": {"s": LENGTH / 2, "orientation": True}}, "tip_load.mass=0.05")))
    short = _solve(Scene.from_dict(_pinned(
        11, {}, "tip_load.mass=0.05", f"length={LENGTH / 2}")))
    rod, half = held.rods["catheter"], short.rods["catheter"]
    distal = rod.positions[10:] - [LENGTH / 2, 0.0, 0.0]
    print(f"\nheld at L/2: tip {rod.positions[-1]}, short cantilever's {half.positions[-1]}")
    assert np.abs(half.positions[-1, 1]) > 0.01 * LENGTH  # it bends
    assert np.abs(distal - half.positions).max() < 1e-9 * LENGTH
    assert np.abs(rod.quaternions[10:] - half.quaternions).max() < 1e-8
    rest = np.zeros((11, 3))
    rest[:, 0] = np.linspace(0.0, LENGTH / 2, 11)
    assert np.abs(rod.positions[:11] - rest).max() < 1e-12 * LENGTH


def test_a_guided_tip_displacement_bends_the_rod_as_beam_theory_at_second_order():
    """Both ends clamped, the tip node moved sideways by δ = 1e-4 L with its frame held
    (a guided beam): the linear beam's y(s) = δ (3 (s/L)² − 2 (s/L)³) at every node, the
    error falling at second order in N — the frame element at the tip as accurate as the
    base's clamp."""
    delta = 1e-4 * LENGTH
    errors = []
    for nodes in (11, 21, 41):
        result = _solve(Scene.from_dict(_pinned(nodes, {"tip": {
            "s": LENGTH, "displacement": [0.0, delta, 0.0], "orientation": True}})))
        t = np.linspace(0.0, 1.0, nodes)
        beam = delta * (3 * t**2 - 2 * t**3)
        errors.append(np.abs(result.rods["catheter"].positions[:, 1] - beam).max() / delta)
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    print(f"\nguided tip displacement: errors / δ {errors}, orders {orders}")
    assert errors[-1] < 1e-3
    assert np.all(orders > 1.8) and np.all(orders < 2.2)


# --- prescribed displacements applied with the loads (rodsim/solvers/static.py) ----------

def pinned_robot(rng: np.random.Generator, index: int) -> dict:
    """A random user robot held at its base and at one more node, that node moved by 0.5–1.2
    segment lengths in a random direction (often pulling or pushing along the rod: a pin
    moved that far leaves the rest state far from any equilibrium), sometimes holding the
    frame there too, half of them with a tip force; written as docs/scenes.md describes.
    L in [0.05, 0.5] m, r in [0.5, 6] mm, E in [1 MPa, 10 GPa], 12–40 nodes."""
    length = rng.uniform(0.05, 0.5)
    radius = rng.uniform(5e-4, min(6e-3, length / 25))
    young = 10.0 ** rng.uniform(6.0, 10.0)
    nodes = int(rng.integers(12, 41))
    segment = length / (nodes - 1)
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    rod = {"length": length, "radius": radius, "youngs_modulus": young, "density": 1500.0,
           "nodes": nodes, "supports": {"pin": {
               "s": int(rng.integers(2, nodes)) * segment,
               "displacement": (direction * rng.uniform(0.5, 1.2) * segment).tolist(),
               "orientation": bool(rng.uniform() < 0.3)}}}
    if rng.uniform() < 0.5:
        bending = young * math.pi * radius**4 / 4
        rod["terms"] = ["stretch", "bend_twist", "centerline", "tip_load"]
        rod["tip_load"] = {"force": (rng.normal(size=3) * bending / length**2).tolist()}
    return {"name": f"pinned-robot-{index}", "rods": {"catheter": rod},
            "solver": {"max_wall_time": 30.0}}


def test_a_model_with_its_supports_moved_is_the_model_of_the_moved_scene():
    """``Model.with_supports_moved(f)`` (what static's load steps solve) has the force and
    Jacobian of the model built from the scene whose support displacements are scaled by
    f, at random states, on a robot with an inserted and turned base, a pin and a clamp
    moved, and a string tendon; at f = 1 its held nodes are exactly at their places."""
    from rodsim.core.model import Model

    data = _pinned(21, {"pin": {"s": 0.048, "displacement": [0.002, -0.004, 0.003]},
                        "clamp": {"s": 0.09, "displacement": [-0.001, 0.002, 0.005],
                                  "orientation": True}})
    data["rods"]["catheter"]["base"] = {"insertion": 0.01, "rotation": 0.7}
    data["tendons"] = {"pull": {"catheter": "catheter", "coupling": "string",
                                "offset": 0.003, "tendon_string": {"tension": 0.5}}}
    model = Model(Scene.from_dict(data))
    assert len(model.support_displacements) == 2
    rng = np.random.default_rng(7)
    for fraction in (0.0, 0.35, 1.0):
        scaled = copy.deepcopy(data)
        for support in scaled["rods"]["catheter"]["supports"].values():
            support["displacement"] = [fraction * d for d in support["displacement"]]
        built, moved = Model(Scene.from_dict(scaled)), model.with_supports_moved(fraction)
        assert np.array_equal(built.rest_full[model.free], moved.rest_full[model.free])
        assert np.allclose(built.rest_full, moved.rest_full, rtol=0.0, atol=1e-17)
        for _ in range(3):
            x = model.x0 + 1e-3 * rng.standard_normal(model.n)
            force, jacobian = built.force(x), built.jacobian_data(x)
            assert np.allclose(moved.force(x), force, rtol=1e-12,
                               atol=1e-12 * np.abs(force).max())
            assert np.allclose(moved.jacobian_data(x), jacobian, rtol=1e-12,
                               atol=1e-12 * np.abs(jacobian).max())
    assert np.array_equal(model.with_supports_moved(1.0).rest_full, model.rest_full)


def test_static_moves_displaced_supports_with_the_loads_on_a_family_of_pinned_robots():
    """static applies a node support's prescribed displacement in increments with the
    loads. Before, it faded the rest state's imbalance from a state with the pinned node a
    segment away from its neighbours, and failed on 8 of these 16 robots (CVODE solved
    all). Now at most one fails (measured: one, a pin pushed 1.5 cm along a 0.26 m span
    that buckles), with advice naming cvode; each stable equilibrium is CVODE's (within
    1e-6 L) with its pinned node exactly in place, and each one flagged unstable — static
    staying on a branch past a bifurcation, as on a straight column past its Euler load —
    has a stiffness with a negative eigenvalue (dense, independent of the verdict's
    code)."""
    from rodsim.core.model import Model

    rng = np.random.default_rng(20261126)
    stable, failures = 0, []
    for index in range(16):
        robot = pinned_robot(rng, index)
        rod = robot["rods"]["catheter"]
        pin = rod["supports"]["pin"]
        model = Model(rodsim.load_scene(robot))
        result = rodsim.solve(robot, "static", model=model)
        if not result.success:
            assert "cvode" in result.message, result.message
            failures.append(robot["name"])
            continue
        node = round(pin["s"] / (rod["length"] / (rod["nodes"] - 1)))
        assert np.array_equal(result.rods["catheter"].positions[node],
                              np.array([pin["s"], 0.0, 0.0]) + pin["displacement"])
        if result.stability.stable:
            stable += 1
            cvode = rodsim.solve(robot, "cvode")
            assert cvode.success, cvode.message
            gap = np.linalg.norm(result.positions() - cvode.positions(), axis=1).max()
            assert gap <= 1e-6 * rod["length"], (robot["name"], gap / rod["length"])
        else:
            stiffness = -model.pattern_matrix(model.jacobian_data(result.state)).toarray()
            assert np.linalg.eigvalsh(0.5 * (stiffness + stiffness.T))[0] < 0.0
    assert len(failures) <= 1, failures
    assert stable >= 12


@pytest.mark.parametrize("name", ["table3-catheter1", "four-tendons"])
def test_static_moves_a_displaced_support_of_a_tendon_catheter(name):
    """The catheter of a rod-tendon scene pinned at mid-length, the pin moved by one segment
    sideways: static failed (at load fraction 0.28 and 0.25); now it converges to CVODE's
    equilibrium while the tendon's registration follows the moving catheter."""
    data = copy.deepcopy(rodsim.load_scene(name).data)
    catheter = next(n for n in data["rods"] if n not in data["tendons"])
    rod = data["rods"][catheter]
    segment = rod["length"] / (rod["nodes"] - 1)
    rod["supports"] = {"pin": {"s": rod["nodes"] // 2 * segment,
                               "displacement": [0.0, segment, 0.3 * segment]}}
    static, cvode = rodsim.solve(data, "static"), rodsim.solve(data, "cvode")
    assert static.success, static.message
    assert cvode.success, cvode.message
    assert static.stability.stable
    gap = np.linalg.norm(static.positions() - cvode.positions(), axis=1).max()
    assert gap <= 1e-6 * rod["length"]


def slender_pushed() -> dict:
    """A slender rod (L/r = 376, E = 4.6 GPa, 38 nodes, no load) whose middle node is pushed
    5.7 mm toward the base (and 0.4 mm sideways): the span buckles, and the plane it buckles
    in is held only by the small sideways part, a soft mode."""
    length, nodes = 0.23048496371667976, 38
    return {"name": "slender-pushed", "rods": {"catheter": {
        "length": length, "radius": 6.13e-4, "youngs_modulus": 4.64e9, "density": 1500.0,
        "nodes": nodes, "supports": {"pin": {
            "s": 19 * length / (nodes - 1), "displacement": [-0.0057, 5.5e-6, -0.000385]}}}}}


def test_a_rod_moved_by_its_supports_alone_has_their_force_scale():
    """F_ref of a scene whose supports move it (Rod.support_reaction_scale): a pin pushed
    along the rod meets its span's buckling scale 2.05 π² E I / s², one moved across it a
    cantilever's 3 E I δ / s³, never less than the unloaded scene's E I / L². It was E I /
    L² alone: slender-pushed's residual floor 1.08e-3 of it was refused by every integrator
    as 'no equilibrium can be told apart from the rest state' (now 1.4e-5)."""
    from rodsim.core.model import Model

    robot = slender_pushed()
    rod = robot["rods"]["catheter"]
    bending = rod["youngs_modulus"] * math.pi * rod["radius"] ** 4 / 4
    span = rod["supports"]["pin"]["s"]
    model = Model(rodsim.load_scene(robot))
    across = math.hypot(5.5e-6, 0.000385)
    expected = 2.05 * math.pi**2 * bending / span**2 + 3 * bending * across / span**3
    assert model.force_scale == pytest.approx(expected, rel=1e-12)
    assert model.residual_floor < 2e-5
    rod["supports"]["pin"]["displacement"] = [0.0, 0.02, 0.0]
    assert Model(rodsim.load_scene(robot)).force_scale == pytest.approx(
        3 * bending * 0.02 / span**3, rel=1e-12)
    rod["supports"]["pin"]["displacement"] = [0.0, 1e-9, 0.0]  # tiny: E I / L² stays
    assert Model(rodsim.load_scene(robot)).force_scale == pytest.approx(
        bending / rod["length"] ** 2, rel=1e-12)


def test_a_soft_mode_does_not_pass_a_state_far_from_equilibrium():
    """On slender-pushed IDA converges (its Newton correction, by a dense solve here, is
    below 1e-5 L: measured 5.1e-7 L at 27422c4 and 5.7e-6 L on the offset state, both at a
    force residual of 1.6e-7 under the tolerance 1.47e-5, which along the soft mode allows
    far more) and CVODE stops 2.5e-3 L away, its force residual 1.44e-5 just under the
    tolerance 1.47e-5. The correction residual divides that distance by the load's
    linearised displacement, which the soft mode makes 7 700 L: it read 3e-7 and passed
    CVODE's state as a success. Counted at most as L (solvers/base.py, capped_reach), the
    distance fails it, with a message saying so."""
    from rodsim.core.model import Model

    robot = slender_pushed()
    model = Model(rodsim.load_scene(robot))
    length = robot["rods"]["catheter"]["length"]
    ida = rodsim.solve(robot, "ida", model=model)
    assert ida.success, ida.message
    jacobian = model.pattern_matrix(model.jacobian_data(ida.state)).toarray()
    correction = np.linalg.solve(jacobian, model.force(ida.state))
    assert np.abs(correction[~model.is_quaternion]).max() < 1e-5 * length
    cvode = rodsim.solve(robot, "cvode", model=model)
    assert not cvode.success
    assert "not an equilibrium" in cvode.message and "correction residual" in cvode.message
    jacobian = model.pattern_matrix(model.jacobian_data(cvode.state)).toarray()
    correction = np.linalg.solve(jacobian, model.force(cvode.state))
    assert np.abs(correction[~model.is_quaternion]).max() > 1e-3 * length


def test_ida_failing_on_a_moved_support_names_static_first():
    """IDA applies a support's displacement at once (its load ramp ramps loads only) and on
    some pinned robots fails at t = 0; its advice then names static, which moves supports
    with its loads and solves the robot, instead of a longer load ramp, which cannot help."""
    robot = pinned_robot(np.random.default_rng(20261126), 0)
    ida = rodsim.solve(robot, "ida")
    assert not ida.success
    assert "try the static integrator (it moves displaced supports" in ida.message
    assert "load_ramp" not in ida.message
    assert rodsim.solve(robot, "static").success
