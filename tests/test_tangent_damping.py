"""The damping on the physical velocities built by scipy's kernels directly
(rodsim/solvers/physical/tangent_damping.py) is scipy's own ``(g.T @ D @ g).tocsr()``,
array for array and bit for bit, on damped rods at moving states: what keeps the physical
steps' trajectories unchanged by it (docs/dynamics.md, "What a step costs")."""

from __future__ import annotations

import numpy as np
import pytest

from rodsim.core.damping import Damping
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.solvers.physical.coordinates import PhysicalCoordinates, physical_state
from rodsim.solvers.physical.tangent_damping import TangentDamping

STEEL = {"length": 0.4, "radius": 1.2e-3, "youngs_modulus": 207e9, "density": 8000.0,
         "poisson_ratio": 0.3, "nodes": 9, "terms": ["stretch", "bend_twist", "centerline"]}
DAMPINGS = [{"retardation_time": 2e-4},
            {"retardation_time_bending": 2e-4, "retardation_time_shear": 1e-5},
            {"drag": 0.5},
            {"retardation_time": 1e-3, "drag": 2.0}]


@pytest.mark.parametrize("damping", DAMPINGS)
def test_tangent_damping_is_scipys_product_bit_for_bit(damping):
    """Straight (quaternion components exactly zero: entries that scipy's sums and products
    drop) and at seeded random states (every entry present)."""
    model = Model(Scene.from_dict({"name": "wire", "rods": {"wire": {**STEEL,
                                                                    "damping": damping}}}))
    rest = physical_state(model, np.zeros(model.n))
    coordinates = PhysicalCoordinates.of(model, rest)
    d = Damping(model)
    tangent = TangentDamping(d)
    rng = np.random.default_rng(14)
    for trial in range(4):
        x = rest.copy()
        if trial:
            x = x + 1e-3 * rng.standard_normal(model.n)
            q = x[coordinates.quaternions]
            x[coordinates.quaternions] = q / np.linalg.norm(q, axis=1)[:, None]
        g = coordinates.g_matrix(x, model.n)
        expected = (g.T @ d.matrix(x) @ g).tocsr()
        built = tangent.matrix(x, coordinates.g_arrays(x, model.n), coordinates.size)
        assert built.shape == expected.shape
        assert np.array_equal(built.indptr, expected.indptr)
        assert np.array_equal(built.indices, expected.indices)
        assert np.array_equal(built.data, expected.data)
        assert np.array_equal(np.signbit(built.data), np.signbit(expected.data))
        assert built.nnz > 0
