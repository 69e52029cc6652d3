"""The implicit midpoint step's Newton matrix (rodsim/solvers/physical/midpoint.py) against
central differences of the step's own residual, on seeded users' rods (steel and nitinol
wires, a soft polymer catheter) bent by a tip load and moving; and the compiled blocks of
its derivative (rodsim/solvers/physical/midpoint_kernels.py) against the numpy
expressions they replaced, written out here as the reference."""

from __future__ import annotations

import numpy as np
import pytest
from user_robots import KINDS, user_rod

import rodsim
from rodsim.core.damping import Damping
from rodsim.core.model import Model
from rodsim.core.rod.quaternion import B
from rodsim.solvers.physical import midpoint
from rodsim.solvers.physical.coordinates import (
    PhysicalCoordinates,
    physical_state,
    velocity_rows,
)
from rodsim.solvers.physical.fixed_step import Motion
from rodsim.solvers.physical.midpoint_kernels import cayley_derivative, derivative_blocks


def _bent_rod(seed: int) -> tuple[Model, np.ndarray]:
    """A user's rod of kind KINDS[seed % 3] (N = 6) at the equilibrium under a tip load of
    about a tenth of the force that bends it by its length, off any axis."""
    rng = np.random.default_rng(seed)
    rod = user_rod(rng, KINDS[seed % len(KINDS)])
    radius = rod["radius"]
    stiffness = rod["youngs_modulus"] * np.pi * radius**4 / 4.0
    load = 0.3 * stiffness / rod["length"] ** 2 * rng.uniform(0.5, 1.0)
    scene = {"name": "bent", "rods": {"rod": {
        **rod, "nodes": 6, "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
        "tip_load": {"force": [0.0, -load, 0.4 * load], "mass": 0.0}}}}
    result = rodsim.solve(scene)
    assert result.success, result.message
    model = Model(result.scene)
    return model, physical_state(model, result.state)


@pytest.mark.parametrize("seed", range(6))
def test_newton_matrix_is_the_residuals_derivative(monkeypatch, seed):
    """On a bent rod moving at random (node speeds of 1e-3 of its length a step, body
    rates of 0.05 rad a step) and away from the predictor, the matrix agrees with central
    differences of the residual to 1e-8 of its largest entry (measured 3e-11 to 8e-11:
    the differences' own error on the stiff rows). Central differences are independent of
    the matrix's assembly: the geometric blocks, the Cayley derivative and the plan."""
    model, x = _bent_rod(seed)
    coordinates = PhysicalCoordinates.of(model, x)
    p, s = len(coordinates.positions), len(coordinates.quaternions)
    rng = np.random.default_rng(100 + seed)
    length = float(model.length_scale)
    h = 1e-3
    checked = []

    def check(evaluate, r1, w, h_, length_scale, tolerance, kept=None, order=None):
        r1 = r1 + 1e-4 * length * rng.standard_normal(p)
        w = w + (0.02 / h_) * rng.standard_normal((s, 3))
        matrix = evaluate(r1, w, True)[1].toarray()
        z = np.concatenate([r1, w.ravel()])
        scale = np.concatenate([np.full(p, 1e-7 * length), np.full(3 * s, 1e-7 / h_)])
        differences = np.zeros_like(matrix)
        for j in range(len(z)):
            step = np.zeros(len(z))
            step[j] = scale[j]
            plus = evaluate((z + step)[:p], (z + step)[p:].reshape(-1, 3), False)[0]
            minus = evaluate((z - step)[:p], (z - step)[p:].reshape(-1, 3), False)[0]
            differences[:, j] = (plus - minus) / (2.0 * scale[j])
        checked.append(np.max(np.abs(matrix - differences)) / np.max(np.abs(matrix)))
        return r1, w, 1

    monkeypatch.setattr(midpoint, "solve_step", check)
    stepper = midpoint.MidpointStep(coordinates, Damping(model), length)
    start = Motion(x, (1e-3 * length / h) * rng.standard_normal(p),
                   (0.05 / h) * rng.standard_normal((s, 3)))
    stepper.step(model, start, h)
    assert checked and checked[0] < 1e-8, checked


def _reference_blocks(f_q, unit, norm, rows, dq1, node):
    """The numpy expressions of MidpointStep._averaged before round 21."""
    pull = np.add.reduce(unit * f_q, axis=1)
    across = f_q - unit * pull[:, None]
    project = (np.eye(4)[None] - unit[:, :, None] * unit[:, None, :]) / norm[:, None, None]
    g_blocks = 0.5 * project @ np.transpose(rows, (0, 2, 1))
    p_blocks = project @ (node * dq1)
    turned = np.einsum("kba,sb->ska", B, across) / norm[:, None, None]
    along = np.einsum("ska,sa->sk", rows, unit)
    moment = np.einsum("ska,sa->sk", rows, across)
    through_q = (-(along[:, :, None] * f_q[:, None, :] + pull[:, None, None] * rows)
                 @ (project * norm[:, None, None])
                 - moment[:, :, None] * unit[:, None, :]) / norm[:, None, None] ** 2
    geometric = 0.5 * (np.einsum("ska,sal->skl", turned, 0.5 * dq1)
                       + np.einsum("ska,sal->skl", through_q, node * dq1))
    return g_blocks, p_blocks, geometric


def _reference_cayley(qm, wm, h):
    """∂q₁/∂ω_m as numpy wrote it before round 21: (I − hΩ/4)⁻¹ (h/2) Aᵀ in closed form."""
    a = 0.25 * h
    omega = np.einsum("sk,kab->sab", wm, B)
    rows = 0.5 * h * np.transpose(velocity_rows(qm), (0, 2, 1))
    return (rows + a * (omega @ rows)) / (1.0 + a * a * np.sum(wm * wm, axis=1))[:, None,
                                                                                    None]


@pytest.mark.parametrize("seed", range(4))
def test_compiled_blocks_are_the_numpy_expressions(seed):
    """The kernels on random segments (unnormalised midpoint quaternions, rates up to
    1e4 rad/s, forces up to 1e3) give the numpy expressions' blocks to 1e-13 of their
    largest entry: the same products, summed in another order. A separate inversion of
    I − hΩ/4 checks the closed form of the Cayley derivative."""
    rng = np.random.default_rng(seed)
    segments, h, node = 7, 10.0 ** rng.uniform(-6, -2), rng.uniform(0.1, 0.9)
    qm = rng.standard_normal((segments, 4))
    qm *= rng.uniform(0.9, 1.0, segments)[:, None] / np.linalg.norm(qm, axis=1)[:, None]
    wm = 10.0 ** rng.uniform(0, 4) * rng.standard_normal((segments, 3))
    rows = velocity_rows(qm)
    dq1 = np.empty((segments, 4, 3))
    cayley_derivative(np.ascontiguousarray(rows), wm, h, dq1)
    expected = _reference_cayley(qm, wm, h)
    assert np.max(np.abs(dq1 - expected)) <= 1e-13 * np.max(np.abs(expected))
    for k in range(segments):  # (I − hΩ/4)⁻¹ (h/2) Aᵀ, solved rather than in closed form
        omega = np.einsum("k,kab->ab", wm[k], B)
        solved = np.linalg.solve(np.eye(4) - 0.25 * h * omega, 0.5 * h * rows[k].T)
        assert np.allclose(dq1[k], solved, rtol=1e-11, atol=1e-14 * np.abs(solved).max())
    unit = qm / np.linalg.norm(qm, axis=1)[:, None]
    norm = rng.uniform(0.95, 1.05, segments)
    quaternions = np.arange(4 * segments).reshape(segments, 4)
    f = 1e3 * rng.standard_normal(4 * segments)
    blocks = [np.empty((segments, 4, 3)), np.empty((segments, 4, 3)),
              np.empty((segments, 3, 3))]
    derivative_blocks(f, quaternions, unit, norm, np.ascontiguousarray(rows), dq1, node,
                      *blocks)
    for got, want in zip(blocks, _reference_blocks(f[quaternions], unit, norm, rows, dq1,
                                                   node), strict=True):
        assert np.max(np.abs(got - want)) <= 1e-13 * np.max(np.abs(want))
