"""The band LU of a physical-time step's Newton matrix (rodsim/solvers/physical/band_lu.py)
against a dense solve, on matrices with the step's structure."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import rodsim
from rodsim.solvers.physical.band_lu import BAND_LIMIT, band_order, factor
from rodsim.solvers.physical.coordinates import PhysicalCoordinates


def _banded_in(order: np.ndarray, width: int, seed: int) -> sp.csr_matrix:
    """A random nonsymmetric matrix, diagonally weighted, whose band in ``order`` is
    ``width`` wide on each side (in natural order it is scattered)."""
    rng = np.random.default_rng(seed)
    m = len(order)
    dense = np.zeros((m, m))
    for k in range(-width, width + 1):
        i = np.arange(max(0, -k), min(m, m - k))
        dense[i, i + k] = rng.standard_normal(len(i))
    dense += 4.0 * np.eye(m)
    place = np.argsort(order)
    return sp.csr_matrix(dense[place][:, place])


@pytest.mark.parametrize("width", [1, 7])
def test_the_band_solve_is_the_dense_solve(width):
    order = np.random.default_rng(1).permutation(60)
    matrix = _banded_in(order, width, seed=width)
    rhs = np.random.default_rng(2).standard_normal(60)
    expected = np.linalg.solve(matrix.toarray(), rhs)
    assert np.allclose(factor(matrix, order)(rhs), expected, rtol=1e-12, atol=1e-12)
    assert np.allclose(factor(matrix, None)(rhs), expected, rtol=1e-12, atol=1e-12)


def test_a_wide_band_goes_to_superlu_with_the_same_answer():
    order = np.arange(3 * BAND_LIMIT)
    matrix = _banded_in(order, BAND_LIMIT, seed=3)
    rhs = np.ones(len(order))
    expected = np.linalg.solve(matrix.toarray(), rhs)
    assert np.allclose(factor(matrix, order)(rhs), expected, rtol=1e-12, atol=1e-12)


def test_a_singular_matrix_is_refused():
    matrix = sp.csr_matrix(np.diag([1.0, 0.0, 2.0]))
    with pytest.raises(RuntimeError):
        factor(matrix, np.arange(3))


def test_a_rods_unknowns_are_narrow_in_band_order():
    """tdcr-two-segment's step unknowns: the rod's coupling (the Jacobian's pattern through
    G) is within a few nodes in band order, against the whole rod in natural order."""
    model = rodsim.build_model(rodsim.load_scene("tdcr-two-segment"))
    c = PhysicalCoordinates.of(model, model.x0)
    order = band_order(c)
    assert sorted(order.tolist()) == list(range(c.size))
    g = c.tangent_map(np.ones((len(c.quaternions), 4, 3)), 1.0, model.n)  # G's structure
    pattern = (abs(g.T) @ abs(model.pattern_matrix(np.ones(model.nnz))) @ abs(g)).tocoo()
    place = np.argsort(order)
    natural = np.max(np.abs(pattern.row - pattern.col))
    banded = np.max(np.abs(place[pattern.row] - place[pattern.col]))
    assert banded < 20 < natural
