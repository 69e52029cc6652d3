"""Contact with rigid obstacles (issue 25): bad input, no cost without obstacles, a tip on a
frictionless plane against the elastica (a reference derived here, not from rodsim), and every
integrator reaching the same contact equilibrium on the shipped ``tip-on-tissue`` scene. The
finite-difference and kernel checks of the term are in tests/test_term_contract.py and
tests/test_kernels.py (scene ``contract-contact``). Run with ``pytest -s`` for the tables."""

from __future__ import annotations

import functools
import math
import os

import numpy as np
import pytest
from scipy.optimize import brentq

import rodsim
from rodsim.app.inverse.track import Track
from rodsim.core.analytic import extensible_elastica
from rodsim.core.model import Model
from rodsim.core.scene import Scene

LENGTH, RADIUS, MODULUS = 0.12, 0.006, 5.9e6
EI = MODULUS * math.pi * RADIUS**4 / 4.0
#: The elastica reference is for an (almost) inextensible, unshearable rod.
EA = 1e4 * MODULUS * math.pi * RADIUS**2

BASE_SCENE = """
name = "contact-errors"
[rods.catheter]
length = 0.1
radius = 0.001
youngs_modulus = 1e7
stretch_modulus = 1e7
density = 1000.0
nodes = 11
[obstacles.wall]
rods = ["catheter"]
"""

ERROR_CASES = [
    ("csv-one-point", 'type = "tube"\ncenterline = "csv"\nfile = "one.csv"\n',
     "0,0,0,0.01\n", "at least 2 points"),
    ("csv-nan", 'type = "tube"\ncenterline = "csv"\nfile = "nan.csv"\n',
     "x,y,z,radius\n-0.01,0,0,0.01\n0.05,nan,0,0.01\n0.12,0,0,0.01\n", "NaN"),
    ("csv-zero-radius", 'type = "tube"\ncenterline = "csv"\nfile = "zero.csv"\n',
     "-0.01,0,0,0.01\n0.05,0,0,0\n0.12,0,0,0.01\n", "radius 0.0"),
    ("csv-too-few-values", 'type = "tube"\ncenterline = "csv"\nfile = "short.csv"\n',
     "-0.01,0,0,0.01\n0.05,0,0\n", "line 2"),
    ("csv-missing", 'type = "tube"\ncenterline = "csv"\nfile = "missing.csv"\n', None,
     "no such file"),
    ("thicker-than-vessel", 'type = "tube"\ncenterline = "straight"\nradius = 0.0008\n'
     'start = [-0.01, 0, 0]\nlength = 0.2\n', None, "thicker than the vessel"),
    ("starts-outside", 'type = "tube"\ncenterline = "arc"\nradius = 0.004\n'
     'start = [-0.01, 0.005, 0]\nbend_radius = 0.2\n', None,
     "starts outside the vessel: its base (s = 0) at (0, 0, 0) m is 0.00124 m beyond"),
    ("analytic-zero-radius", 'type = "tube"\ncenterline = "straight"\n', None,
     "radius"),
    ("too-tight-bend", 'type = "tube"\ncenterline = "arc"\nradius = 0.01\n'
     'bend_radius = 0.01\n', None, "bends tighter than its radius"),
    ("unknown-type", 'type = "cylinder"\n', None, "unknown obstacle type"),
    ("unknown-rod", 'type = "plane"\npoint = [0, -0.01, 0]\nnormal = [0, 1, 0]\n'
     'rods = ["other"]\n', None, "no rod 'other'"),
    ("zero-normal", 'type = "plane"\npoint = [0, -0.01, 0]\nnormal = [0, 0, 0]\n', None,
     "zero vector"),
    ("capsule-coincident-ends", 'type = "capsule"\nstart = [0.05, -0.01, 0]\n'
     'end = [0.05, -0.01, 0]\nradius = 0.005\n', None, "the segment's ends coincide"),
    ("capsule-holds-the-base", 'type = "capsule"\nstart = [0, 0, -0.01]\n'
     'end = [0, 0, 0.01]\nradius = 0.005\n', None, "holds its base"),
]


@pytest.mark.parametrize(("table", "csv", "phrase"), [c[1:] for c in ERROR_CASES],
                         ids=[c[0] for c in ERROR_CASES])
def test_bad_obstacle_exits_2_with_one_line(table, csv, phrase, tmp_path, capsys, cli):
    text = BASE_SCENE + table
    if 'rods = ["other"]' in table:
        text = text.replace('rods = ["catheter"]\n', "")
    scene = tmp_path / "scene.toml"
    scene.write_text(text, encoding="utf-8")
    if csv is not None:
        name = table.split('file = "')[1].split('"')[0]
        (tmp_path / name).write_text(csv, encoding="utf-8")
    code = cli(["run", str(scene), "--integrator", "static", "-o", str(tmp_path / "r.nc")])
    captured = capsys.readouterr()
    stderr = captured.err.strip()
    assert code == 2, f"exit code {code}; stderr: {stderr!r}"
    assert "\n" not in stderr and "Traceback" not in stderr, stderr
    assert "obstacles.wall" in stderr, stderr
    assert phrase in stderr, f"{phrase!r} not in {stderr!r}"
    assert not (tmp_path / "r.nc").exists()


@pytest.mark.parametrize("special", ["fifo", "/dev/zero", "/dev/urandom"])
def test_a_centerline_that_is_no_regular_file_is_refused_without_reading_it(special, tmp_path,
                                                                           capsys, cli):
    """A FIFO would wait for a writer and a device never ends: both hung ``run`` (and made
    ``plot`` grow to 6 GB); they are refused before they are opened."""
    if special == "fifo":
        special = str(tmp_path / "vessel.csv")
        os.mkfifo(special)
    scene = tmp_path / "scene.toml"
    scene.write_text(BASE_SCENE + f'type = "tube"\ncenterline = "csv"\nfile = "{special}"\n',
                     encoding="utf-8")
    code = cli(["run", str(scene), "--integrator", "static", "-o", str(tmp_path / "r.nc")])
    stderr = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in stderr, stderr
    assert "not a regular file" in stderr, stderr


def test_a_centerline_csv_with_a_byte_order_mark_is_read(tmp_path):
    """Spreadsheets write UTF-8 with a byte-order mark; it was refused as a bad first line."""
    text = "-0.01,0,0,0.004\n0.05,0.001,0,0.004\n0.12,0,0,0.004\n"  # no header line
    points = []
    for name, encoding in (("plain", "utf-8"), ("marked", "utf-8-sig")):
        (tmp_path / f"{name}.csv").write_text(text, encoding=encoding)
        scene = tmp_path / f"{name}.toml"
        scene.write_text(BASE_SCENE + f'type = "tube"\ncenterline = "csv"\nfile = "{name}.csv"\n',
                         encoding="utf-8")
        points.append(rodsim.load_scene(scene).data["obstacles"]["wall"]["points"])
    assert (tmp_path / "marked.csv").read_bytes().startswith(b"\xef\xbb\xbf")
    assert points[0] == points[1] and len(points[0]) == 12


def test_scene_without_obstacles_builds_no_contact():
    """No ``obstacles`` key is added to a resolved scene and no contact term is built: the
    shipped scenes' numbers (tests/test_scene_reference.py) and cost are untouched."""
    scene = rodsim.load_scene("table1-50g")
    assert "obstacles" not in scene.data
    assert all(term.name != "contact" for term in Model(scene).terms)


def plane_scene(nodes: int) -> dict:
    """A cantilever (rest along +x) whose straight tip would cross a plane inclined at 30°."""
    return {"name": "tip-on-plane", "rods": {"c": {
        "length": LENGTH, "radius": RADIUS, "youngs_modulus": MODULUS,
        "stretch_modulus": 1e4 * MODULUS, "density": 1000.0, "nodes": nodes,
        "terms": ["stretch", "bend_twist", "centerline"], "centerline": {"K_P": 1e6}}},
        "obstacles": {"tissue": {"type": "plane", "rods": ["c"],
                                 "point": [*PLANE_POINT, 0.0], "normal": [*PLANE_NORMAL, 0.0]}},
        "solver": {"integrator": "static"}}


PLANE_NORMAL = np.array([-math.cos(math.radians(30)), -math.sin(math.radians(30))])
PLANE_POINT = np.array([0.9 * LENGTH, 0.0])


def tip_on_plane_reference() -> tuple[float, np.ndarray]:
    """(contact force λ [N], tip (x, y) [m]) of the rigid, frictionless contact: the tip force
    of a frictionless plane is λ n (n its unit normal: a dead load in direction), so the
    cantilever is the extensible elastica under λ n (rodsim.core.analytic.extensible_elastica,
    shooting to ~1e-12), and λ is the root of n · (r(L) − p₀) = r (the tip node's sphere of
    the rod's radius r touches the plane)."""

    def tip(force: float) -> np.ndarray:
        shape = extensible_elastica(force * PLANE_NORMAL, EI, EA, LENGTH, s=np.array([LENGTH]))
        return np.array([shape.x[-1], shape.y[-1]])

    force = brentq(lambda f: PLANE_NORMAL @ (tip(f) - PLANE_POINT) - RADIUS, 1e-9,
                   5 * EI / LENGTH**2, xtol=1e-16, rtol=1e-15)
    return force, tip(force)


NODES = (10, 20, 40, 80)


def test_tip_on_inclined_plane_matches_the_elastica():
    """Tip position second order in 1/N (the penalty's compliance, √(2 δ λ / k) ∝ N^-1.5, is
    below 1e-6 L at these N); the contact force (the nodal contact forces summed) within
    1e-3 of λ at N = 80 and normal to the plane."""
    force, exact = tip_on_plane_reference()
    errors, force_errors = [], []
    for nodes in NODES:
        scene = Scene.from_dict(plane_scene(nodes))
        result = rodsim.solve(scene, "static", overrides=["static.max_newton=200"])
        assert result.success, result.message
        tip = result.tip()
        errors.append(float(np.hypot(*(tip[:2] - exact)) / LENGTH))
        model = Model(scene)
        contact = next(t for t in model.terms if t.name == "contact")
        total = contact.nodal_forces(model.full(result.state)).sum(axis=0)
        force_errors.append(float(np.linalg.norm(total[:2] - force * PLANE_NORMAL) / force))
    order = -np.polyfit(np.log([n - 1 for n in NODES]), np.log(errors), 1)[0]
    print(f"\ntip on a 30° plane, λ L²/EI = {force * LENGTH**2 / EI:.4f}: |tip − elastica| / L"
          f" at N = {NODES}: {', '.join(f'{e:.3g}' for e in errors)}; order {order:.2f}; "
          f"|force − λ n| / λ: {', '.join(f'{e:.2g}' for e in force_errors)}")
    assert order > 1.8
    assert errors[-1] < 5e-6
    assert force_errors[-1] < 1e-3


def test_every_integrator_reaches_the_same_contact_equilibrium():
    """static, cvode, ida and paper on the shipped tip-on-tissue scene: every node within
    1e-6 L of static's, and the tip on the plane (its sphere touching, y = 1.7 mm − r, up to
    the penalty's penetration √(2 δ f / k) ≈ 1.1e-6 L here)."""
    scene = rodsim.load_scene("tip-on-tissue")
    length = scene.data["rods"]["catheter"]["length"]
    radius = scene.data["rods"]["catheter"]["radius"]
    shapes = {}
    for integrator in ("static", "cvode", "ida", "paper"):
        result = rodsim.solve(scene, integrator)
        assert result.success, f"{integrator}: {result.message}"
        shapes[integrator] = result.rods["catheter"].positions
    gaps = {name: float(np.max(np.linalg.norm(p - shapes["static"], axis=1)) / length)
            for name, p in shapes.items()}
    print(f"\ntip-on-tissue: max node distance to static / L: {gaps}")
    assert max(gaps.values()) < 1e-6
    assert abs(shapes["static"][-1, 1] - (0.0017 - radius)) < 2e-6 * length


def test_pseudo_masses_cap_a_touching_node_as_every_other_coordinate():
    """Mass scaling caps each coordinate's own frequency at ``mass_scaling`` × ω₁; a contact
    node's stiffness once it touches is its rest stiffness plus k (the rest state, out of
    contact, shows none of k), so its pseudo-mass must hold that cap with k counted, on the
    shipped plane scene and on the tests' inclined plane, and a model without obstacles
    keeps the masses it had (no latent stiffness at all)."""
    from rodsim.solvers.pseudo_dynamics import first_mode_frequency, pseudo_masses

    cap = 1e3
    for scene in (rodsim.load_scene("tip-on-tissue"), rodsim.load_scene(plane_scene(40))):
        model = Model(scene)
        contact = next(t for t in model.terms if t.name == "contact")
        masses = pseudo_masses(model, cap)
        inverse = np.full(model.full_size, -1)
        inverse[model.free] = np.arange(model.n)
        touching = inverse[contact.dofs.ravel()]
        touching = touching[touching >= 0]
        frequency = np.sqrt((model.rest_stiffness[touching] + contact.stiffness)
                            / masses[touching])
        assert np.all(frequency <= cap * first_mode_frequency(model) * (1.0 + 1e-12))
    plain = Model(rodsim.load_scene("table1-50g"))
    assert not np.any(plain.latent_stiffness())


def test_a_scene_with_obstacles_runs_ida_unless_it_names_an_integrator():
    """``solver.integrator`` unset: ida with obstacles (docs/contact.md, "Which integrator"),
    the registry's default (static) without; a scene that names one keeps it, and so does an
    override."""
    scene = plane_scene(20)
    del scene["solver"]
    assert rodsim.load_scene(scene).solver.integrator == "ida"
    assert rodsim.load_scene(scene, ["solver.integrator=cvode"]).solver.integrator == "cvode"
    named = plane_scene(20) | {"solver": {"integrator": "cvode"}}
    assert rodsim.load_scene(named).solver.integrator == "cvode"
    without = plane_scene(20)
    del without["solver"], without["obstacles"]
    assert rodsim.load_scene(without).solver.integrator == "static"


@pytest.mark.parametrize("moment", [0.001, 0.003])
def test_static_presses_a_tip_onto_tissue_with_its_default_newton_budget(moment):
    """tip-on-tissue with another tip moment and ``static.max_newton`` at its default (30):
    each load step starts from the secant through the last two equilibria (a model with
    contact, rodsim/solvers/static.py ``secant_predicted``) and the solve converges to IDA's
    equilibrium. Started from the last equilibrium instead, every load step after the tip
    touched the plane ran out of its 30 iterations and the run failed."""
    scene = rodsim.load_scene("tip-on-tissue", [
        f"rods.catheter.point_loads.loads.0.moment=[0.0, {moment}, 0.0]",
        "rods.catheter.nodes=21", "solver.static.max_newton=30"])
    static = rodsim.solve(scene, "static")
    assert static.success, static.message
    reference = rodsim.solve(scene, "ida")
    assert reference.success, reference.message
    distance = np.max(np.linalg.norm(static.rods["catheter"].positions
                                     - reference.rods["catheter"].positions, axis=1))
    assert distance < 1e-6 * scene.data["rods"]["catheter"]["length"]


def contact_robot(rng: np.random.Generator, index: int) -> tuple[dict, np.ndarray, float]:
    """A random user-like catheter bent by one tendon onto an obstacle in its way, written as
    docs/scenes.md and docs/contact.md tell a user to: L in [0.05, 0.3] m, r in [0.5, 3] mm
    (L/r ≥ 20), E in [1 MPa, 1 GPa], 15–40 nodes; the tendon at a random angle, offset
    0.3–0.8 r, pulled to bend the free catheter by 0.5–1.5 rad (the constant-curvature
    arc); a plane (even index) or a sphere of radius 0.2–1 L (odd) whose surface lies across
    the tip's path at 30–80 % of the free tip's deflection. No ``solver.integrator``: the
    scene's default. Returns (scene, the bending direction, the obstacle's surface point
    nearest the base's axis [m] as a distance along it)."""
    length = rng.uniform(0.05, 0.3)
    radius = rng.uniform(5e-4, min(3e-3, length / 20))
    young = 10.0 ** rng.uniform(6.0, 9.0)
    bending = young * math.pi * radius**4 / 4
    angle = rng.uniform(0.0, 2 * math.pi)
    offset = rng.uniform(0.3, 0.8) * radius
    theta = rng.uniform(0.5, 1.5)
    direction = np.array([0.0, math.cos(angle), math.sin(angle)])
    surface = rng.uniform(0.3, 0.8) * length * (1 - math.cos(theta)) / theta + radius
    if index % 2 == 0:
        obstacle = {"type": "plane", "point": (surface * direction).tolist(),
                    "normal": (-direction).tolist()}
    else:
        sphere = rng.uniform(0.2, 1.0) * length
        tip_x = length * math.sin(theta) / theta
        obstacle = {"type": "sphere", "radius": sphere, "center": (
            (surface + sphere) * direction + np.array([tip_x, 0.0, 0.0])).tolist()}
    scene = {"name": f"contact-robot-{index}",
             "rods": {"catheter": {"length": length, "radius": radius, "youngs_modulus": young,
                                   "density": rng.uniform(1000.0, 2000.0),
                                   "nodes": int(rng.integers(15, 41))}},
             "tendons": {"pull": {"catheter": "catheter", "offset": offset,
                                  "direction": [math.cos(angle), math.sin(angle)],
                                  "tendon_actuation": {"force": theta * bending
                                                       / (offset * length)}}},
             "obstacles": {"wall": {"rods": ["catheter"]} | obstacle},
             "solver": {"max_wall_time": 30.0}}
    return scene, direction, surface


@pytest.mark.parametrize("count", [6, pytest.param(12, marks=pytest.mark.slow)])
def test_a_family_of_catheters_pressed_onto_obstacles_is_solved_by_the_defaults(count):
    """Twelve seeded robots of contact_robot (the first six every time, robot 3 among them;
    all twelve with the slow tests): the default integrator (ida, a scene with
    obstacles) and static both converge with their default settings; the default's
    equilibrium is stable, the catheter rests on the obstacle (the deepest node's sphere
    inside by less than 1e-4 L: the penalty's compliance, at most ~2e-6 L measured; none
    deeper) and the obstacle pushes it back along the pull's reverse. Static agrees to
    1e-6 L wherever it reports a stable equilibrium; it may stop on an unstable one
    (Newton converges to the nearest equilibrium): robot 3 here balances its tip on the
    sphere's crest, which static reports, correctly, as unstable, while the
    pseudo-dynamics slide off to one side and rest on the sphere with a node short of the
    tip. Measured on three other seeds (30 robots, ten of them on planes only): all
    converge, and static agrees with ida within 3.6e-10 L on every one."""
    rng = np.random.default_rng(20261126)
    unstable = []
    for index in range(count):
        raw, direction, surface = contact_robot(rng, index)
        scene = rodsim.load_scene(raw)
        assert scene.solver.integrator == "ida"
        length, radius = raw["rods"]["catheter"]["length"], raw["rods"]["catheter"]["radius"]
        default = rodsim.solve(scene)
        static = rodsim.solve(scene, "static")
        assert default.success and default.stability.stable, (raw["name"], default.message)
        assert static.success, (raw["name"], static.message)
        shapes = [r.rods["catheter"].positions for r in (default, static)]
        apart = np.max(np.linalg.norm(shapes[0] - shapes[1], axis=1))
        if static.stability.stable:
            assert apart <= 1e-6 * length
        else:  # the pseudo-dynamics left the unstable equilibrium static stopped on
            assert apart > 1e-3 * length, raw["name"]
            unstable.append(index)
        nodes = default.rods["catheter"].positions
        table = raw["obstacles"]["wall"]
        if table["type"] == "plane":
            gaps = surface - nodes @ direction - radius
        else:
            gaps = np.linalg.norm(nodes - np.array(table["center"]), axis=1) - table["radius"] \
                - radius
        assert -1e-4 * length < gaps.min() <= 0.0, (raw["name"], gaps.min() / length)
        model = Model(scene)
        contact = next(term for term in model.terms if term.name == "contact")
        push = contact.nodal_forces(model.full(default.state)).sum(axis=0)
        assert float(push @ direction) < 0.0, raw["name"]
    assert len(unstable) <= 1, unstable  # measured: one crest in twelve


def catheter_in_a_bend() -> dict:
    """A straight catheter (L = 0.12 m, r = 1 mm, E = 50 MPa) whose rest state runs through
    the outer wall of the arc vessel it lies in (lumen 3 mm, bend radius 0.4 m): at rest the
    wall already pushes it, with no load at all."""
    return {"name": "catheter-in-a-bend",
            "rods": {"catheter": {"length": 0.12, "radius": 0.001, "youngs_modulus": 5e7,
                                  "density": 1100.0, "nodes": 31,
                                  "terms": ["stretch", "bend_twist", "centerline"]}},
            "obstacles": {"vessel": {"type": "tube", "rods": ["catheter"], "centerline": "arc",
                                     "radius": 0.003, "start": [-0.01, 0.0, 0.0],
                                     "direction": [1.0, 0.0, 0.0],
                                     "bend_toward": [0.0, 1.0, 0.0], "bend_radius": 0.4,
                                     "angle": 0.5}}}


@pytest.mark.parametrize("name", ["catheter-in-a-bend", "plane-40"])
def test_static_solves_a_rod_that_starts_inside_an_obstacle(name):
    """A rod whose rest state lies partly inside an obstacle (the bend above; the inclined
    plane cantilever at N = 40, whose straight tip starts 16 mm through its plane): static
    at its default settings fades the rest state's imbalance out along its load
    continuation (rodsim/solvers/static.py ``rest_imbalance``) and reaches ida's equilibrium.
    Without the fade it failed at the first load step on both."""
    raw = catheter_in_a_bend() if name == "catheter-in-a-bend" else plane_scene(40)
    raw["solver"] = {"integrator": "static"}
    scene = rodsim.load_scene(raw)
    rod = next(iter(raw["rods"]))
    static = rodsim.solve(scene, "static")
    assert static.success and static.stability.stable, static.message
    reference = rodsim.solve(scene, "ida")
    assert reference.success, reference.message
    distance = np.max(np.linalg.norm(static.rods[rod].positions
                                     - reference.rods[rod].positions, axis=1))
    assert distance < 1e-6 * raw["rods"][rod]["length"]


def test_a_failed_static_solve_on_contact_advises_ida():
    """static's advice names the integrator of the scene's kind: ida with obstacles
    (docs/contact.md, "Which integrator"), cvode without (a solve made to fail: one Newton
    iteration a step, no step below half the load)."""
    starved = ["solver.static.max_newton=1", "solver.static.min_load_step=0.5"]
    for name, other in (("tip-on-tissue", "ida"), ("table1-50g", "cvode")):
        result = rodsim.solve(rodsim.load_scene(name, starved), "static")
        assert not result.success
        assert f"pseudo-dynamic integrator ({other})" in result.message, result.message


def test_cvode_reaches_a_frictional_contact_equilibrium():
    """A rod pressed on a plane with friction μ = 0.3 (tests/test_friction.py's drag scene
    before any drag): CVODE, the default integrator, reaches static's equilibrium. With the
    contact nodes' pseudo-masses set by their rest stiffness alone, CVODE failed here at step
    11 (corrector convergence)."""
    from test_friction import dragged_rod

    scene = dragged_rod(0.3)
    reference = rodsim.solve(scene, "static")
    result = rodsim.solve(scene, "cvode")
    assert reference.success and result.success, result.message
    length = scene.data["rods"]["c"]["length"]
    distance = np.max(np.linalg.norm(result.rods["c"].positions
                                     - reference.rods["c"].positions, axis=1)) / length
    assert distance < 1e-6


def test_insertion_along_a_curved_vessel_is_warm_started_and_path_independent():
    """``track`` advances the shipped vessel-insertion catheter 60 mm through the csv vessel's
    bend (61 steps): every step converges, the nodes stay inside the wall up to the penalty's
    compliance, and the last step equals that of a track in 16 steps to 1e-6 L (frictionless
    contact: no path dependence). Prints how far segment midpoints (which node-based contact
    does not see) reach past the wall. (A solve from rest at the full insertion is not a
    check: the straight rest shape then lies far outside the bend and the rod can settle
    outside the vessel — docs/contact.md.)"""
    from rodsim.app.inverse.track import track

    scene = rodsim.load_scene("vessel-insertion")
    radius = scene.data["rods"]["catheter"]["radius"]
    length = scene.data["rods"]["catheter"]["length"]
    path = track(scene, {"rods.catheter.base.insertion": np.linspace(0.0, 0.06, 61)})
    assert path.success, path.message
    contact = next(t for t in path.model.terms if t.name == "contact")
    nodes = max(float(np.max(contact.penetration(full))) for full in path.states)
    midpoints = 0.0
    for positions in path.positions:
        middle = 0.5 * (positions[1:] + positions[:-1])
        midpoints = max(midpoints, float(np.max(radius - contact.obstacle.gap(middle)[0])))
    coarse = track(scene, {"rods.catheter.base.insertion": np.linspace(0.0, 0.06, 16)})
    assert coarse.success, coarse.message
    gap = float(np.max(np.linalg.norm(path.positions[-1] - coarse.positions[-1], axis=1))
                ) / length
    print(f"\nvessel insertion, 61 steps: deepest node {nodes / radius:.2g} r, deepest segment "
          f"midpoint {midpoints / radius:.2g} r past the wall; last step vs 16 steps {gap:.2g} L")
    assert nodes < 1e-2 * radius
    assert gap < 1e-6


@pytest.mark.slow  # a command-line run that draws its figure: 2-4 s of CPU
def test_archive_holds_contact_forces_and_the_figure_draws_them(tmp_path):
    """A run archive of a scene with obstacles holds the contact force per node (N) and their
    resultant, passes the archive contract and round-trips through netCDF; a scene without
    obstacles has neither variable. The contact figure is written from the archive alone."""
    from rodsim.app.figures.contact import contact_figure
    from rodsim.io.archive import read_dataset, write_dataset
    from rodsim.io.archive_schema import check_archive
    from rodsim.io.run_dataset import run_dataset

    result = rodsim.solve("tip-on-tissue", "static")
    ds = run_dataset(result)
    check_archive(ds)
    force = ds["contact_force"].values
    assert ds["contact_force"].attrs["units"] == "N"
    np.testing.assert_allclose(ds["contact_resultant"].values, force.sum(axis=0), rtol=1e-15)
    # the plane's normal is -y: the tissue pushes the tip down, nothing else touches
    assert force[-1, 1] < 0 and np.all(force[:-2] == 0.0)
    path = tmp_path / "run.nc"
    write_dataset(ds, path)
    back = read_dataset(path)
    np.testing.assert_array_equal(back["contact_force"].values, force)
    figure = contact_figure(back, tmp_path / "contact.png")
    assert figure.stat().st_size > 10_000
    plain = run_dataset(rodsim.solve("table1-50g", "static"))
    assert "contact_force" not in plain and "contact_resultant" not in plain


def test_tendon_bent_tip_on_a_plane_matches_the_rucker_webster_reference():
    """Reference (c): the benchmark backbone of tests/test_string_tendon.py bent by one string
    tendon (1 N at 10 mm) presses its tip on a frictionless plane above it (at 60 % of the
    free tip's rise). The plane's force is λ n, n = −y fixed, so the Rucker–Webster shooting
    (rodsim/core/analytic/tendon_bvp.py) under the tip force λ_N n, λ_N the contact force
    rodsim finds at N, must put the tip on the plane (its sphere touching) and where rodsim
    does: both distances fall at second order. (Finding λ by root search on the reference
    instead takes minutes; done once by hand: λ = 0.030186 N, rodsim's force within 7.9e-5 of
    it at N = 81.)"""
    from test_string_tendon import LENGTH as BACKBONE
    from test_string_tendon import RADIUS as WIRE
    from test_string_tendon import backbone, string

    from rodsim.core.analytic.tendon_bvp import scene_reference

    tendon = {"a": string((1, 0), 1.0)}
    plane_y = 0.6 * 0.0195772845 + WIRE  # 60 % of the free tip's y (reference) + r
    on_plane, to_rodsim = [], []
    nodes = (21, 41, 81)
    for count in nodes:
        scene = backbone(count, tendon) | {"obstacles": {"tissue": {
            "type": "plane", "rods": ["backbone"], "point": [0.0, plane_y, 0.0],
            "normal": [0.0, -1.0, 0.0]}}}
        result = rodsim.solve(scene, "static", overrides=["static.max_newton=200"])
        assert result.success, result.message
        model = Model(Scene.from_dict(scene))
        contact = next(t for t in model.terms if t.name == "contact")
        force = contact.nodal_forces(model.full(result.state)).sum(axis=0)
        assert abs(force[0]) + abs(force[2]) <= 1e-12 * abs(force[1])
        tip = scene_reference(Scene.from_dict(backbone(5, tendon, tuple(force)))).tip
        on_plane.append(abs(plane_y - tip[1] - WIRE) / BACKBONE)
        to_rodsim.append(float(np.linalg.norm(tip - result.tip())) / BACKBONE)
    orders = [-np.polyfit(np.log([n - 1 for n in nodes]), np.log(e), 1)[0]
              for e in (on_plane, to_rodsim)]
    print(f"\ntendon-bent tip on a plane, N = {nodes}: reference tip under rodsim's force, "
          f"off the plane / L {', '.join(f'{e:.2g}' for e in on_plane)} (order "
          f"{orders[0]:.2f}), from rodsim's tip / L {', '.join(f'{e:.2g}' for e in to_rodsim)}"
          f" (order {orders[1]:.2f})")
    assert min(orders) > 1.8
    assert max(on_plane[-1], to_rodsim[-1]) < 1e-5


def test_a_csv_vessel_is_read_into_the_scene_and_an_override_of_its_file_rereads(tmp_path):
    """The resolved scene holds the csv's points (archives and reruns need no file); setting
    another file reads it and replaces the old points."""
    scene = rodsim.load_scene("vessel-insertion")
    table = scene.data["obstacles"]["vessel"]
    assert table["file"] == "" and len(table["points"]) == 4 * 33
    again = Scene.from_json(scene.to_json())
    assert again.data["obstacles"]["vessel"]["points"] == table["points"]
    other = tmp_path / "wide.csv"
    other.write_text("-0.2,0,0,0.004\n0.3,0,0,0.004\n", encoding="utf-8")
    wide = scene.with_overrides([f'obstacles.vessel.file="{other}"'])
    assert wide.data["obstacles"]["vessel"]["points"] == [-0.2, 0.0, 0.0, 0.004,
                                                           0.3, 0.0, 0.0, 0.004]


def arc_vessel_scene(origin: float, nodes: int, length: float) -> dict:
    """A rod along +x whose base is ``-origin`` behind a semicircular vessel (bend radius
    40 mm, lumen 4 mm): the vessel continues straight behind its start and past its end."""
    return {
        "name": "far-walk",
        "rods": {"catheter": {"length": length, "radius": 0.0003, "youngs_modulus": 6e10,
                              "density": 6500.0, "nodes": nodes, "clamp": "frame",
                              "origin": [origin, 0.0, 0.0],
                              "terms": ["stretch", "bend_twist", "centerline"]}},
        "obstacles": {"vessel": {"type": "tube", "rods": ["catheter"], "centerline": "arc",
                                 "radius": 0.004, "start": [0.0, 0.0, 0.0],
                                 "direction": [1.0, 0.0, 0.0], "bend_toward": [0.0, 1.0, 0.0],
                                 "bend_radius": 0.04, "angle": math.pi}},
    }


def test_nearest_point_walk_reaches_nodes_far_along_the_vessel():
    """The walk from the nearest knot (first node) or the previous node's parameter must reach
    a node any distance away: far behind the vessel's start on its straight extension, across
    most of the bend, far past its end. Each point is more than 40 knot intervals from the
    last (the walk's old step cap): the gaps are checked against the exact geometry of the
    semicircle and its two straight extensions, and the compiled kernel against numpy."""
    bend, lumen = 0.04, 0.004
    scene = Scene.from_dict(arc_vessel_scene(-0.12, 4, 0.3))  # base 0.12 m behind the start
    points = np.array([
        [-0.12, 0.001, 0.0],                                          # entry extension
        [(bend + 0.003) * math.sin(2.0), bend - (bend + 0.003) * math.cos(2.0), 0.0],  # bend
        [(bend - 0.0035) * math.sin(2.9), bend - (bend - 0.0035) * math.cos(2.9), 0.0],
        [-0.1, 2.0 * bend + 0.0039, 0.0],                             # exit extension
    ])
    exact = lumen - np.array([0.001, 0.003, 0.0035, 0.0039])
    numpy_model, compiled = Model(scene, "numpy"), Model(scene, "compiled")
    contact = next(term for term in numpy_model.terms if term.name == "contact")
    np.testing.assert_allclose(contact.obstacle.gap(points)[0], exact, rtol=0, atol=1e-9)
    # The same state through both paths: three nodes in the onset or beyond, one outside.
    full = numpy_model.full(numpy_model.x0)
    full[numpy_model.rods["catheter"].layout.position_index] = points + [
        [0, 0, 0], [0, 0.0008, 0], [0, 0, 0], [0, 0.0003, 0]]
    x = numpy_model.state_of(full)
    assert np.any(contact.nodal_forces(full) != 0.0)
    np.testing.assert_allclose(compiled.force(x), numpy_model.force(x), rtol=0,
                               atol=1e-12 * np.max(np.abs(numpy_model.force(x))))


def torus_scene(nodes: int, insertion: float = 0.0) -> Scene:
    """A stiff wire (r = 0.3 mm, E = 60 GPa, L = 0.16 m) behind a frictionless semicircular
    vessel (bend radius R = 40 mm, lumen a = 0.4 mm), its base advanced by ``insertion``."""
    raw = arc_vessel_scene(-TORUS_LENGTH, nodes, TORUS_LENGTH)
    raw["obstacles"]["vessel"]["radius"] = TORUS_LUMEN
    return Scene.from_dict(raw).with_values({"rods.catheter.base.insertion": insertion})


@functools.cache
def torus_track(nodes: int, steps: int) -> Track:
    """The wire of ``torus_scene`` advanced 0.12 m from a straight entry into the bend,
    its tip free inside it, in ``steps`` equilibria (tracked once per process: two tests
    read the one at 41 nodes, neither changes it)."""
    track = rodsim.track(torus_scene(nodes),
                         {"rods.catheter.base.insertion": np.linspace(0.0, 0.12, steps)},
                         estimates=False)
    assert track.success, track.message
    return track


def torus_contact(model: Model, full: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The node positions, the contact force on every node and the segment length of the
    full state ``full`` of ``model``."""
    rod = model.rods["catheter"]
    contact = next(term for term in model.terms if term.name == "contact")
    return (full[rod.layout.position_index], contact.nodal_forces(full),
            TORUS_LENGTH / (len(rod.geometry.node_s) - 1))


def torus_insertion(nodes: int, steps: int) -> tuple[np.ndarray, np.ndarray, float]:
    """The wire of ``torus_track`` at the end of its insertion: the node positions, the
    contact force on every node and the segment length."""
    track = torus_track(nodes, steps)
    return torus_contact(track.model, track.states[-1])


def torus_halved(track: Track) -> tuple[np.ndarray, np.ndarray, float]:
    """``torus_insertion``'s result at twice the segments, solved from ``track``'s last
    equilibrium with every segment halved (the new node at the old segment's midpoint, both
    halves with its quaternion): one continuation step of ``static`` at the same insertion.
    The vessel is frictionless, so the equilibrium is that of the insertion, whatever the
    path to it (41 nodes tracked in 31, 61 or 121 steps and 81 nodes tracked in 61 or 241
    give the same penetration to 7 digits, and so does this step from the tracked 41)."""
    from rodsim.app.inverse.continuation import Continuation

    coarse = track.model.rods["catheter"]
    positions = track.states[-1][coarse.layout.position_index]
    quaternions = track.states[-1][coarse.layout.quaternion_index]
    nodes = 2 * len(positions) - 1
    scene = torus_scene(nodes, 0.12)
    model = Model(scene)
    rod = model.rods["catheter"]
    full = model.rest_full.copy()
    full[rod.layout.position_index[0::2]] = positions
    full[rod.layout.position_index[1::2]] = 0.5 * (positions[:-1] + positions[1:])
    full[rod.layout.quaternion_index] = np.repeat(quaternions, 2, axis=0)
    step = Continuation(model, model.state_of(full), "static")
    outcome = step.solve(scene)
    assert outcome.success, outcome.message
    return torus_contact(step.model, step.model.full(step.x))


TORUS_BEND, TORUS_LUMEN, TORUS_WIRE, TORUS_LENGTH = 0.04, 0.0004, 0.0003, 0.16


def torus_reference() -> tuple[float, float, float]:
    """Away from its ends a rod pushed into a frictionless bend lies on the outer wall, a
    circle of radius ρ = R + a − r (κ = 1/ρ). Derived here (docs/contact.md): with m = EIκ b
    uniform, m' + t × n = 0 gives n = N t; n' + f = 0 with a normal wall force f = −p ν gives
    N' = 0 and p = −Nκ. Moving the zone outward by dρ at fixed rod length keeps its length S
    and changes its bending energy EI S/(2ρ²) by −EI S/ρ³ dρ, which the wall's work p S dρ
    balances: p = EIκ³, N = −EIκ² (compression), so the axial strain is −EIκ²/EA.
    Returns κ, p [N/m] and the strain."""
    kappa = 1.0 / (TORUS_BEND + TORUS_LUMEN - TORUS_WIRE)
    ei = 6e10 * math.pi * TORUS_WIRE**4 / 4.0
    ea = 6e10 * math.pi * TORUS_WIRE**2
    return kappa, ei * kappa**3, -ei * kappa**2 / ea


def torus_middle(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angle of every node around the bend's axis (0 at the bend's start) and its distance
    from that axis."""
    d = positions - np.array([0.0, TORUS_BEND, 0.0])
    return np.unwrap(np.arctan2(d[:, 0], -d[:, 1])), np.hypot(d[:, 0], d[:, 1])


def test_rod_pushed_into_a_bend_lies_on_the_outer_wall_with_line_force_ei_kappa_cubed():
    kappa, line_force, strain = torus_reference()
    positions, forces, segment = torus_insertion(41, 61)
    theta, radius = torus_middle(positions)
    middle = int(np.argmin(np.abs(theta - 1.5)))  # the tip stops near theta = 3
    measured = np.linalg.norm(forces, axis=1) / segment
    assert abs(measured[middle] / line_force - 1.0) < 1e-4  # 3.0e-5 measured
    stretch = np.linalg.norm(positions[middle + 1] - positions[middle]) / segment - 1.0
    assert abs(stretch / strain - 1.0) < 1e-4  # 1.6e-5 measured: the rod's extensibility
    # A uniform zone of at least 0.5 rad, on the wall (within the penalty's penetration).
    zone = np.abs(measured / line_force - 1.0) < 3e-3
    assert np.ptp(theta[zone]) > 0.5
    assert np.all(np.abs(radius[zone] - 1.0 / kappa) < 1e-7)
    # Before the zone (the entry) and after it (the free tip) the rod leaves the outer wall.
    assert np.max(1.0 / kappa - radius[theta < 0.5]) > 1e-5
    assert np.max(1.0 / kappa - radius[theta > 2.5]) > 1e-5


def test_bend_contact_penetration_falls_as_n_squared():
    """The wall holds the uniform zone with a node force p l against a stiffness
    k = 1e3 EI/l³ in the onset: penetration √(2δ p l/k) ∝ l². Measured 4.9e-8 and 1.2e-8 m at
    N = 41 and 81 (order 2.00); the line force stays within 3e-5 of EIκ³. N = 41 is tracked
    along the insertion, N = 81 solved from its last state with the segments halved
    (``torus_halved``; tracked along the insertion as well, N = 81 needed 1 477
    continuation solves, 352 of them failed and halved, for the same state to 4e-13 m)."""
    kappa, line_force, _ = torus_reference()
    track = torus_track(41, 61)
    depth = []
    for positions, forces, segment in (torus_contact(track.model, track.states[-1]),
                                       torus_halved(track)):
        theta, radius = torus_middle(positions)
        middle = int(np.argmin(np.abs(theta - 1.5)))
        depth.append(radius[middle] - 1.0 / kappa)
        assert abs(np.linalg.norm(forces[middle]) / segment / line_force - 1.0) < 1e-4
    assert depth[0] > 0.0 and depth[1] > 0.0
    assert math.log2(depth[0] / depth[1]) == pytest.approx(2.0, abs=0.1)


def test_a_track_archive_holds_the_contact_forces_of_every_step(tmp_path):
    """Issue 25 item 4: the insertion's archive holds the contact force on every node at
    every step and their resultant; the last step's forces are those of a run archive of
    the last step's scene re-solved from the track's last state (the same equilibrium), the
    first step (tip at the bend's start, no wall touched) has none; the figure draws them."""
    from rodsim.app.figures import plot_dataset
    from rodsim.io.run_dataset import run_dataset

    scene = rodsim.load_scene("vessel-insertion")
    insertion = np.linspace(0.0, 0.06, 16)
    path = rodsim.track(scene, {"rods.catheter.base.insertion": insertion}, estimates=False)
    assert path.success, path.message
    ds = path.to_xarray()
    assert ds["contact_force"].dims == ("step", "node", "axis")
    assert ds["contact_force"].attrs["units"] == "N"
    np.testing.assert_allclose(ds["contact_resultant"].values,
                               ds["contact_force"].values.sum(axis=1), rtol=0, atol=1e-15)
    assert not np.any(ds["contact_force"].values[0])
    last = scene.with_values({"rods.catheter.base.insertion": float(insertion[-1])})
    start = rodsim.build_model(last).state_of(path.states[-1])  # offsets from its own rest
    again = rodsim.solve(last, "static", initial_state=start)
    assert again.success, again.message
    expected = run_dataset(again)["contact_force"].values
    assert np.max(np.linalg.norm(expected, axis=1)) > 1e-3  # the bend pushes back (mN)
    np.testing.assert_allclose(ds["contact_force"].values[-1], expected, rtol=0,
                               atol=1e-6 * np.max(np.abs(expected)))
    (figure,) = plot_dataset(ds, tmp_path / "insertion", ["png"])
    assert figure.stat().st_size > 10_000
    # The archive contract checks the variables' dimensions when they are there.
    from rodsim.io.archive_schema import ArchiveSchemaError, check_archive

    check_archive(ds)
    with pytest.raises(ArchiveSchemaError, match="contact_resultant"):
        check_archive(ds.drop_vars("contact_resultant"))


def buckling_scene(factor: float, lateral: float = 0.0) -> Scene:
    """A wire (r = 0.5 mm, E = 2 GPa, L = 0.1 m) clamped in a straight vessel of lumen
    1.5 mm, pushed back along its axis by ``factor`` times its Euler load π²EI/(4L²), with a
    lateral tip force ``lateral`` times that load."""
    ei = 2e9 * math.pi * 0.0005**4 / 4.0
    euler = math.pi**2 * ei / (4.0 * 0.1**2)
    return Scene.from_dict({
        "name": "buckling-in-a-vessel",
        "rods": {"wire": {"length": 0.1, "radius": 0.0005, "youngs_modulus": 2e9,
                          "density": 1000.0, "nodes": 41, "clamp": "frame",
                          "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
                          "tip_load": {"force": [-factor * euler, lateral * euler, 0.0]}}},
        "obstacles": {"vessel": {"type": "tube", "rods": ["wire"], "centerline": "straight",
                                 "radius": 0.0015, "start": [-0.01, 0.0, 0.0],
                                 "direction": [1.0, 0.0, 0.0], "length": 0.2}}})


def test_a_rod_buckling_inside_a_vessel_is_reported_unstable_where_it_is():
    """Issue 25's aim: the straight wire inside the vessel is stable below its Euler load and
    unstable above it (Newton from the straight rest state stays on the straight branch; the
    contact adds no stiffness where nothing touches); nudged sideways by a small lateral
    force it buckles onto the wall (the tip 1 mm off the axis: lumen − r) and is stable
    there. Measured: smallest eigenvalue −2.4e-4 (N/m-scaled) at twice the Euler load."""
    below = rodsim.solve(buckling_scene(0.5), "static")
    assert below.success and below.stability.stable
    straight = rodsim.solve(buckling_scene(2.0), "static")
    assert straight.success, straight.message
    assert abs(straight.tip()[1]) < 1e-12  # still straight
    assert not straight.stability.stable and straight.stability.min_eigenvalue < 0.0
    on_wall = rodsim.solve(buckling_scene(2.0, lateral=1e-3), "static")
    assert on_wall.success, on_wall.message
    assert on_wall.tip()[1] == pytest.approx(0.001, abs=2e-6)  # on the wall
    assert on_wall.stability.stable
