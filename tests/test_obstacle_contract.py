"""Every registered obstacle type keeps the obstacle contract (issue 38 item 1): it solves
through its own compiled kernel (the contact force is the penalty law of its penetration,
the kernel agrees with the numpy reference, the Jacobian is exact against finite
differences), it is drawn by the run figure and the 3-D view, and its scene round-trips
through a run archive and ``rerun``. A type added the documented way (docs/architecture.md,
"How to add an obstacle type") is walked here with no edit of this file: each type's
``example`` table is its test scene.
"""

from __future__ import annotations

import functools

import matplotlib.pyplot as plt
import numpy as np
import pytest

import rodsim
from rodsim.core.contact_penalty import penalty
from rodsim.core.kernels import load_kernel
from rodsim.core.obstacles import DEPTH_LIMIT, registered_obstacles
from rodsim.core.terms.contact import Contact

TYPES = sorted(registered_obstacles())
RADIUS = 0.001


def scene(kind: str, friction: float = 0.0) -> dict:
    """A cantilever along +x (0.1 m, 1 mm thick) whose tip load bends it 21 mm toward -y
    without the obstacle: each type's example table stops it."""
    table = {"type": kind, "rods": ["catheter"], **registered_obstacles()[kind].example}
    if friction:
        table["friction"] = friction
    return {"name": f"contract-{kind}", "rods": {"catheter": {
        "length": 0.1, "radius": RADIUS, "nodes": 21, "youngs_modulus": 2e8,
        "density": 1100.0, "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
        "tip_load": {"mass": 0.0, "force": [0.0, -0.01, 0.0]}}},
        "obstacles": {"obstacle": table}, "solver": {"kernels": "compiled"}}


@functools.cache
def solved(kind: str):
    """The solved example and its model."""
    result = rodsim.solve(scene(kind), "static")
    assert result.success, f"{kind}: {result.message}"
    return result, rodsim.build_model(result.scene)


def contact_of(model) -> tuple[int, Contact]:
    (found,) = [(i, t) for i, t in enumerate(model.terms) if isinstance(t, Contact)]
    return found


def kernel_outputs(term: Contact, full: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The compiled kernel's node forces (N, 3), diagonal blocks (N, 3, 3) and energy."""
    kernel = load_kernel(term)
    arguments = kernel.bind(term.kernel_arguments())
    nodes = term.dofs.shape[0]
    force = np.zeros(3 * nodes + 1)
    jacobian = np.zeros(9 * nodes + 1)
    force_target = np.arange(3 * nodes).reshape(nodes, 3)
    jacobian_target = np.arange(9 * nodes).reshape(nodes, 3, 3)
    kernel.evaluate(full, *arguments, 1.0, True, force, force_target, True, jacobian,
                    jacobian_target)
    energy = kernel.energy(full, *arguments) if term.conservative else float("nan")
    return force[:-1].reshape(nodes, 3), jacobian[:-1].reshape(nodes, 3, 3), energy


@pytest.mark.parametrize("kind", TYPES)
def test_the_contact_term_runs_its_obstacle_types_own_kernel(kind):
    cls = registered_obstacles()[kind]
    assert cls.example, f"{kind}: no example table"
    model = rodsim.build_model(scene(kind))
    _, term = contact_of(model)
    assert term.kernel == cls.kernel == f"contact_{kind}"
    assert load_kernel(term).module == cls.kernel
    assert set(cls(  # the kernel takes the type's constants and the term's, nothing else
        "o", term.obstacle.table).kernel_arguments()) <= set(load_kernel(term).constants)


@pytest.mark.parametrize("kind", TYPES)
def test_the_contact_force_is_the_law_of_the_penetration(kind):
    result, model = solved(kind)
    index, term = contact_of(model)
    full = model.full(result.state)
    points = full[term.dofs]
    phi, grad, _ = term.obstacle.gap(points)
    depth = RADIUS - phi
    touching = depth > 0.0
    assert touching.any(), f"{kind}: the example does not stop the rod"
    assert depth.max() < DEPTH_LIMIT * RADIUS  # a rigid contact, as the law's scales intend
    force = model.element_forces(index, full)  # the compiled path
    expected = term.stiffness * penalty(depth, term.smoothing)[1][:, None] * grad
    np.testing.assert_allclose(force, expected, rtol=1e-10, atol=1e-14 * np.abs(force).max())
    assert np.all(np.linalg.norm(force[~touching], axis=1) == 0.0)
    assert np.all(np.einsum("ni,ni->n", force, grad)[touching] > 0.0)  # pushes out


@pytest.mark.parametrize("friction", [0.0, 0.3])
@pytest.mark.parametrize("kind", TYPES)
def test_the_kernel_is_the_reference_and_its_jacobian_exact(kind, friction):
    result, solved_model = solved(kind)
    model = rodsim.build_model(scene(kind, friction))
    _, term = contact_of(model)
    full = solved_model.full(result.state)  # the same layout with friction
    rng = np.random.default_rng(TYPES.index(kind))
    full[term.dofs] += rng.normal(scale=2e-7, size=term.dofs.shape)  # off special points
    # the touching nodes pushed 30 µm deeper, past the onset: there ψ′ ∇²φ is ~1 % of the
    # Jacobian (at the equilibrium, in the onset, ~1e-5)
    phi, grad, _ = term.obstacle.gap(full[term.dofs])
    deeper = (RADIUS - phi > 0.0)[:, None] * 3e-5 * grad
    full[term.dofs] -= deeper
    if friction:
        term = term.anchored(full[term.dofs] + rng.normal(scale=1e-6, size=term.dofs.shape))
    force, blocks, energy = kernel_outputs(term, full)
    assert np.abs(force).max() > 0.0
    scale = np.abs(blocks).max()
    np.testing.assert_allclose(force, term.element_forces(full), rtol=1e-9,
                               atol=1e-12 * np.abs(force).max())
    np.testing.assert_allclose(blocks, term.element_jacobians(full), rtol=1e-9,
                               atol=1e-12 * scale)
    if not friction:
        assert energy == pytest.approx(term.energy(full), rel=1e-12)
    # central differences of the kernel's own force, node by node (a node's force depends
    # on its own position only)
    h = 1e-10  # the friction stiffens over the slip ε = 1 µm: (h/ε)² truncation
    for node in np.flatnonzero(np.abs(force).sum(axis=1) > 0.0):
        for b in range(3):
            plus, minus = full.copy(), full.copy()
            plus[term.dofs[node, b]] += h
            minus[term.dofs[node, b]] -= h
            column = (kernel_outputs(term, plus)[0][node]
                      - kernel_outputs(term, minus)[0][node]) / (2 * h)
            np.testing.assert_allclose(blocks[node, :, b], column, rtol=0,
                                       atol=1e-7 * scale, err_msg=f"{kind} node {node}")


@pytest.mark.parametrize("kind", TYPES)
def test_the_gaps_derivatives_are_exact(kind):
    """∇φ and ∇²φ of the numpy reference against central differences of φ and ∇φ at
    points scattered around the example's surface."""
    obstacle = contact_of(rodsim.build_model(scene(kind)))[1].obstacle
    rng = np.random.default_rng(7)
    points = rng.uniform([0.0, -0.03, -0.03], [0.1, 0.01, 0.03], size=(40, 3))
    _, grad, hess = obstacle.gap(points)
    h = 1e-7
    for b in range(3):
        step = np.zeros(3)
        step[b] = h
        phi_p, grad_p, _ = obstacle.gap(points + step)
        phi_m, grad_m, _ = obstacle.gap(points - step)
        np.testing.assert_allclose(grad[:, b], (phi_p - phi_m) / (2 * h), rtol=0, atol=1e-6)
        np.testing.assert_allclose(hess[:, :, b], (grad_p - grad_m) / (2 * h), rtol=1e-4,
                                   atol=1e-4)


@pytest.mark.parametrize("kind", TYPES)
def test_a_half_space_declares_itself(kind):
    """``free_half_space`` (the scene's check of facing walls reads it, not the type) is the
    gap's own half-space, φ = n · (p − p₀) with |n| = 1; and a type whose gap is affine
    around its example (∇φ constant, ∇²φ = 0: a half-space) declares it."""
    obstacle = contact_of(rodsim.build_model(scene(kind)))[1].obstacle
    rng = np.random.default_rng(7)
    points = rng.uniform([0.0, -0.03, -0.03], [0.1, 0.01, 0.03], size=(40, 3))
    phi, grad, hess = obstacle.gap(points)
    half = obstacle.free_half_space()
    if half is None:
        affine = not np.any(hess) and np.allclose(grad, grad[0], rtol=0, atol=1e-12)
        assert not affine, f"{kind}: a half-space that does not declare free_half_space"
        return
    normal, point = half
    assert normal.shape == (3,) and point.shape == (3,)
    assert abs(np.linalg.norm(normal) - 1.0) < 1e-15
    np.testing.assert_allclose(phi, (points - point) @ normal, rtol=0, atol=1e-15)
    np.testing.assert_allclose(grad, np.tile(normal, (len(points), 1)), rtol=0, atol=0)


def test_the_obstacle_registry_names_no_type():
    """The registry's checks ask an obstacle what it declares (``encloses``,
    ``narrowest``, ``free_half_space``), never its ``type``."""
    import inspect

    import rodsim.core.obstacles as registry

    source = inspect.getsource(registry)
    named = [kind for kind in TYPES if f'"{kind}"' in source or f"'{kind}'" in source]
    assert not named, f"rodsim/core/obstacles/__init__.py names the types {named}"


@pytest.mark.parametrize("kind", TYPES)
def test_it_is_drawn_by_the_run_figure_and_the_3d_view(kind):
    from rodsim.app.figures import draw_figure, style
    from rodsim.io.run_dataset import run_dataset

    ds = run_dataset(solved(kind)[0])
    with style():
        figure = draw_figure(ds)
        try:
            drawn = [a for a in figure.findobj() if a.get_gid() == "obstacle:obstacle"]
            assert drawn and any(len(s) for a in drawn for s in a.get_segments()), kind
        finally:
            plt.close(figure)
    pytest.importorskip("plotly", reason="plotly is the optional extra rodsim[view3d]")
    from rodsim.app.figures.view3d import view_figure

    traces = [t for t in view_figure(ds).data if t.name == f"{kind} obstacle"]
    assert traces, f"{kind}: not in the 3-D view"
    assert np.isfinite(np.asarray(traces[0].x, dtype=float)).sum() > 3


@pytest.mark.parametrize("kind", TYPES)
def test_it_round_trips_through_the_archive_and_rerun(kind, tmp_path):
    from rodsim.app.api import rerun
    from rodsim.io.archive import read_dataset, write_dataset
    from rodsim.io.run_dataset import run_dataset

    result = solved(kind)[0]
    stored = read_dataset(write_dataset(run_dataset(result), tmp_path / "run.nc"))
    again, difference = rerun(stored)
    assert again.success, again.message
    assert again.scene.data["obstacles"] == result.scene.data["obstacles"]
    assert difference < 1e-12
