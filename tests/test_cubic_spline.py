"""rodsim.core.cubic_spline against scipy.interpolate.CubicSpline (not-a-knot), bit for bit:
the same numbers on random samples, uneven spacings, several columns, points at the knots,
between them and beyond both ends, and on a shipped scene's shape as the discretisation
estimate interpolates it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from rodsim.core.cubic_spline import cubic_spline


@pytest.mark.parametrize("n", [2, 3, 4, 5, 9, 41, 200])
@pytest.mark.parametrize("columns", [(), (3,), (4,)])
@pytest.mark.parametrize("seed", range(5))
def test_the_spline_is_scipys_bit_for_bit(n, columns, seed):
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.uniform(0.01, 1.0, n)) * rng.uniform(1e-3, 10.0)
    y = rng.normal(size=(n, *columns)) * rng.uniform(1e-3, 1e3)
    points = np.concatenate([x, rng.uniform(x[0] - 0.2 * (x[-1] - x[0]),
                                            x[-1] + 0.2 * (x[-1] - x[0]), 300),
                             [x[0], x[-1], np.nextafter(x[-1], 0.0)]])
    expected = CubicSpline(x, y)(points)
    got = cubic_spline(x, y)(points)
    assert got.shape == expected.shape
    np.testing.assert_array_equal(got.view(np.int64), expected.view(np.int64))


def test_a_rod_shape_resampled_as_the_discretisation_estimate_does():
    """Positions (n, 3) at the nodes' arc lengths, evaluated at another node count's."""
    import rodsim

    result = rodsim.solve(rodsim.load_scene("tdcr-two-segment"))
    for shape in result.rods.values():
        coarse = np.linspace(shape.s[0], shape.s[-1], max(4, len(shape.s) // 2 + 1))
        for x, y, at in ((shape.s, shape.positions, coarse),
                         (shape.segment_s, np.asarray(shape.quaternions), coarse)):
            np.testing.assert_array_equal(cubic_spline(x, y)(at), CubicSpline(x, y)(at))


def test_bad_samples_are_refused():
    with pytest.raises(ValueError):
        cubic_spline(np.array([0.0, 1.0, 1.0, 2.0]), np.zeros(4))
    with pytest.raises(ValueError):
        cubic_spline(np.arange(4.0), np.array([0.0, np.nan, 1.0, 2.0]))
