"""CVODE and IDA with ``linear_solver = "band_gmres"`` (GMRES preconditioned by rodsim's band
LU of the same Newton matrix, rodsim/solvers/sundials.py ``BandPreconditioner``; what "auto"
uses above BAND_LIMIT unknowns) reach the equilibrium ``static`` reaches, as the direct band
solver does; and the preconditioner is the exact inverse of the matrix it is given."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.solvers.sundials import BAND_LIMIT, BandPreconditioner


@pytest.mark.parametrize("integrator", ["cvode", "ida"])
@pytest.mark.parametrize("formulation", ["overdamped", "inertial"])
def test_band_gmres_reaches_the_static_equilibrium(integrator, formulation):
    overrides = ["nodes=60"]
    static = rodsim.solve("table1-50g", "static", overrides=overrides)
    result = rodsim.solve("table1-50g", integrator, overrides=[
        *overrides, f"solver.{integrator}.linear_solver=band_gmres",
        f"solver.{integrator}.formulation={formulation}"])
    assert result.success, result.message
    assert np.max(np.abs(result.positions() - static.positions())) < 1e-8 * 0.12


def test_auto_uses_band_gmres_above_the_band_limit():
    model = rodsim.app.api.build_model(rodsim.load_scene("table1-50g", ["nodes=10"]))
    from rodsim.solvers.cvode import Cvode

    runner = Cvode(Cvode.options_of(model.scene), 1e-9)
    assert runner.linear_solver(BAND_LIMIT) == "band"
    assert runner.linear_solver(BAND_LIMIT + 1) == "band_gmres"


def test_the_preconditioner_solves_its_matrix_and_multiplies_by_it():
    model = rodsim.app.api.build_model(rodsim.load_scene("table1-50g", ["nodes=30"]))
    rng = np.random.default_rng(7)
    constant = model.jacobian_data(model.x0)
    per_c = rng.standard_normal(model.nnz) * (model.pattern_rows == model.pattern_cols)
    newton = BandPreconditioner(model.pattern, model.pattern_rows, model.pattern_cols,
                                (model.band.lower, model.band.upper))
    newton.update(constant, per_c)
    newton.factor(0.3)
    dense = model.pattern_matrix(constant + 0.3 * per_c).toarray()
    rhs = rng.standard_normal(model.n)
    solution = np.empty(model.n)
    newton.solve(rhs, solution)
    assert np.allclose(dense @ solution, rhs, rtol=0, atol=1e-9 * np.abs(rhs).max())
    product = np.empty(model.n)
    newton.product(rhs, product, 0.3)
    assert np.allclose(product, dense @ rhs)
