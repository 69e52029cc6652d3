"""Force from shape (issue 25, item 5): a contact force recovered by `rodsim.fit` from the
catheter's shape alone, against the force the contact term applied. The shape comes from the
shipped ``tip-on-tissue`` scene solved with its plane; the fit model has no plane and an
unknown tip force started at 0 (`rodsim bench force-from-shape` measures the docs/inverse.md
table over noise levels)."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.app.inverse.fit import Points
from rodsim_bench.force_from_shape import PARAMS, force_model, measured_shape


@pytest.fixture(scope="module")
def shape():
    table, points, s, truth = measured_shape()
    return force_model(table), points, s, truth


def test_exact_shape_gives_the_contact_force(shape):
    """Exact points: the plane's force on the tip to 1e-6 of its size (measured 1.1e-9 N
    along the plane, 1.9e-10 N normal to it, |F| = 30.4 mN), from a start at 0 N."""
    scene, points, s, truth = shape
    assert truth[1] < -0.02 and abs(truth[0]) < 1e-12  # frictionless: normal to the plane
    fit = rodsim.fit(scene, Points(points, s), PARAMS)
    np.testing.assert_allclose(fit.values, truth[:2], rtol=0, atol=1e-6 * abs(truth[1]))
    assert fit.result.success and fit.residual_rms < 1e-8


def test_noisy_shape_gives_the_force_within_calibrated_standard_errors(shape):
    """0.05 mm noise (5e-4 L) in x and y, 6 seeded draws: the normal component within
    3 standard errors every time and to 0.5 % of the force; the normalised errors' spread
    neither far below nor far above 1 (measured over 8 draws: RMS errors 0.67 mN along the
    plane, 0.025 mN normal to it; spread 0.98 and 0.93)."""
    scene, points, s, truth = shape
    rng = np.random.default_rng(7)
    normalised = []
    for _ in range(6):
        noisy = points + 5e-5 * rng.standard_normal(points.shape) * [1.0, 1.0, 0.0]
        fit = rodsim.fit(scene, Points(noisy, s), PARAMS)
        error = fit.values - truth[:2]
        assert np.all(np.abs(error) < 3.0 * fit.errors + 1e-12)
        assert abs(error[1]) < 5e-3 * abs(truth[1])
        normalised.append(error / fit.errors)
    spread = np.std(normalised, axis=0)
    assert np.all((spread > 0.3) & (spread < 2.0)), spread
