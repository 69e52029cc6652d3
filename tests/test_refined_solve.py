"""Iterative refinement of the large models' Newton solves (rodsim/solvers/linear.py,
``REFINED_SOLVE_SIZE``): the compensated residual (rodsim/core/kernels/_refinement.py) is the
exact residual rounded, and one refinement step with it makes the solution of an
ill-conditioned rod system accurate to working precision, where the band factorisation
alone is not — on table1-50g and on robots of the seeded user family. The references are
independent: exact rational arithmetic, and refinement to convergence with numpy's
extended-precision (long double) residual."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import scipy.sparse as sp
from test_user_robot import family

import rodsim
from rodsim.core.kernels._refinement import compensated_residual
from rodsim.solvers.linear import REFINED_SOLVE_SIZE, LinearSolver


def test_the_compensated_residual_is_the_exact_residual_rounded():
    rng = np.random.default_rng(7)
    n = 40
    matrix = (sp.random(n, n, density=0.3, random_state=3, format="csc")
              + 1e8 * sp.eye(n, format="csc")).tocsc()
    x = rng.standard_normal(n) * np.logspace(0, 10, n)
    b = (matrix @ x) * (1.0 + 1e-12 * rng.standard_normal(n))  # r ≪ |A| |x|: cancellation
    out = np.empty(n)
    compensated_residual(matrix.data, matrix.indptr, matrix.indices, x, b, out)
    dense = matrix.toarray()
    exact = np.array([float(Fraction(b[i]) - sum(Fraction(dense[i, j]) * Fraction(x[j])
                                                 for j in range(n))) for i in range(n)])
    eps = np.finfo(float).eps
    assert np.all(np.abs(out - exact) <= 2 * eps * np.abs(exact))
    plain = b - matrix @ x
    assert np.max(np.abs(plain - exact) / np.abs(exact)) > 1e3 * eps  # what it avoids


@pytest.mark.parametrize("n", [REFINED_SOLVE_SIZE - 1, REFINED_SOLVE_SIZE])
def test_solves_are_refined_from_refined_solve_size_on(n):
    pattern = sp.eye(n, format="csc")
    rows = np.arange(n)
    solver = LinearSolver(pattern, rows, rows, (0, 0), True)
    assert solver.refined == (n >= REFINED_SOLVE_SIZE)
    rhs = np.linspace(1.0, 2.0, n)
    assert np.allclose(solver.solve(-2.0 * np.ones(n), rhs.copy()), -0.5 * rhs, rtol=1e-15)


def _solver(model, refined: bool, symmetric: bool) -> LinearSolver:
    solver = LinearSolver(model.pattern, model.pattern_rows, model.pattern_cols,
                          (model.band.lower, model.band.upper), symmetric)
    solver.refined = refined
    return solver


def _user_robot(index: int) -> rodsim.Scene:
    """Robot ``index`` of tests/test_user_robot.py's seeded family on 2 000 nodes."""
    data = family()[index][0]
    return rodsim.load_scene(data, [f"rods.{rod}.nodes=2000" for rod in data["rods"]])


SCENES = {"table1-50g": lambda: rodsim.load_scene("table1-50g", ["nodes=2000"]),
          "user-robot-0": lambda: _user_robot(0), "user-robot-3": lambda: _user_robot(3)}


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("symmetric", [True, False], ids=["cholesky", "band_lu"])
def test_one_refinement_makes_a_large_rods_newton_step_accurate(scene, symmetric):
    """The first Newton step from rest on 2 000 nodes (14 000 unknowns), table1-50g and two
    robots of the user family. Measured forward errors (relative to the step's largest
    entry), unrefined against refined: table1-50g Cholesky 4.1e-9 / 9.2e-12, LU 6.9e-9 /
    9.0e-12; the user robots 2e-9 … 4e-8 / 3e-13 … 2e-12 (Cholesky); at N = 10 000 on
    table1-50g (Cholesky) 1.6e-6 / 9.9e-12."""
    model = rodsim.build_model(SCENES[scene]())
    data, rhs = model.jacobian_data(model.x0), -model.force(model.x0)
    plain = _solver(model, False, symmetric).solve(data, rhs.copy())
    refined_solver = _solver(model, True, symmetric)
    refined = refined_solver.solve(data, rhs.copy())
    assert refined_solver.counts["cholesky" if symmetric else "band_lu"] == 1
    matrix = model.pattern_matrix(data).astype(np.longdouble)
    reference, solver = plain.copy(), _solver(model, False, symmetric)
    for _ in range(6):
        residual = rhs.astype(np.longdouble) - matrix @ reference.astype(np.longdouble)
        reference = reference + solver.solve(data, residual.astype(float))
    scale = np.max(np.abs(reference))
    refined_error = np.max(np.abs(refined - reference)) / scale
    plain_error = np.max(np.abs(plain - reference)) / scale
    assert refined_error < 1e-10
    assert plain_error > 20 * refined_error
