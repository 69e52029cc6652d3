"""The band storage of the Newton linear solves (rodsim/solvers/linear.py): the compiled fill
(rodsim/core/kernels/_band.py, used from ``COMPILED_FILL_SIZE`` unknowns on) writes the same
arrays as the numpy offsets, and the solves through either are the same numbers."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import rodsim
from rodsim.solvers.linear import LinearSolver


def solvers(model) -> tuple[LinearSolver, LinearSolver]:
    """Two solvers of ``model``'s pattern: the numpy fill and the compiled one (forced)."""
    made = []
    for compiled in (False, True):
        solver = LinearSolver(model.pattern, model.pattern_rows, model.pattern_cols,
                              (model.band.lower, model.band.upper), model.conservative)
        solver._compiled_fill = compiled
        made.append(solver)
    return made[0], made[1]


def loaded_state(model) -> np.ndarray:
    """A state off rest: a fraction of the first Newton step from rest (an asymmetric J on
    the paper coupling, a non-trivial one everywhere)."""
    x = model.x0
    data = model.jacobian_data(x)
    step = sp.linalg.spsolve(model.pattern_matrix(data), -model.force(x))
    return x + 0.1 * step


@pytest.mark.parametrize("scene", ["table1-50g", "table3-catheter1"])
def test_the_compiled_band_fill_writes_the_numpy_offsets_array(scene):
    model = rodsim.build_model(rodsim.load_scene(scene))
    numpy_fill, compiled = solvers(model)
    data = model.jacobian_data(loaded_state(model))
    assert np.array_equal(model.pattern.indices, model.pattern_rows)
    forms = [False] + ([True] if model.conservative else [])
    for cholesky in forms:
        expected = numpy_fill._filled(data, cholesky, keep=False)
        # Twice into the kept array: what the first fill left must not leak into the second.
        compiled._filled(2.0 * data, cholesky, keep=True)
        got = compiled._filled(data, cholesky, keep=True)
        assert got.flags.f_contiguous and got.shape == expected.shape
        assert np.array_equal(got, expected)
        assert np.count_nonzero(got) > 0
    # The band arrays are J: the LU form read back as a dense matrix is J itself.
    ab = numpy_fill._filled(data, False, keep=False)
    dense = model.pattern_matrix(data).toarray()
    kl, ku = model.band.lower, model.band.upper
    rows, cols = np.nonzero(dense)
    assert np.array_equal(ab[kl + ku + rows - cols, cols], dense[rows, cols])


@pytest.mark.parametrize("scene", ["table1-50g", "table3-catheter1"])
def test_solves_through_either_fill_are_the_same_numbers(scene):
    model = rodsim.build_model(rodsim.load_scene(scene))
    numpy_fill, compiled = solvers(model)
    x = loaded_state(model)
    data, rhs = model.jacobian_data(x), -model.force(x)
    expected = numpy_fill.solve(data, rhs.copy())
    assert np.array_equal(compiled.solve(data, rhs.copy()), expected)
    assert np.array_equal(compiled.solve(data, rhs.copy()), expected)  # the kept array again
    assert {k: 2 * v for k, v in numpy_fill.counts.items()} == compiled.counts
    dense = model.pattern_matrix(data).toarray()
    assert np.linalg.norm(dense @ expected - rhs) <= 1e-8 * np.linalg.norm(rhs)
    block = np.stack([rhs, 2.0 * rhs], axis=1)
    assert np.array_equal(compiled.factorized(data)(block), numpy_fill.factorized(data)(block))


def test_a_kept_factorisation_solves_as_a_fresh_one():
    """``factorized(keep=True)`` (the SUNDIALS preconditioner's, rodsim/solvers/sundials.py)
    factors in the solver's kept band array: the same solves as a fresh factorisation, and
    a preconditioner factored again for another c solves with the new matrix."""
    from rodsim.solvers.sundials import BandPreconditioner

    model = rodsim.build_model(rodsim.load_scene("table3-catheter1"))
    numpy_fill, compiled = solvers(model)
    x = loaded_state(model)
    data, rhs = model.jacobian_data(x), -model.force(x)
    assert np.array_equal(compiled.factorized(data, keep=True)(rhs),
                          numpy_fill.factorized(data)(rhs))
    identity = np.where(model.pattern_rows == model.pattern_cols, 1.0, 0.0)
    band = (model.band.lower, model.band.upper)
    preconditioner = BandPreconditioner(model.pattern, model.pattern_rows,
                                        model.pattern_cols, band)
    preconditioner.linear._compiled_fill = True
    preconditioner.update(identity, -data)
    out = np.empty(model.n)
    for c in (1e-3, 2e-2):
        preconditioner.factor(c)
        preconditioner.solve(rhs, out)
        expected = numpy_fill.factorized(identity + c * -data)(rhs)
        assert np.array_equal(out, expected)


def test_the_factor_of_the_last_cholesky_solve_is_reused_bit_for_bit():
    """factorized(J) after solve(J, b) of the same J takes the solve's Cholesky factor
    (dpbsv's is dpbtrf's): its solves are a fresh solver's, bit for bit; another J is
    factored anew."""
    model = rodsim.build_model(rodsim.load_scene("table1-50g"))
    solver, _ = solvers(model)
    fresh, _ = solvers(model)
    data = model.jacobian_data(model.x0 + 1e-6)
    rhs = np.random.default_rng(3).standard_normal((model.n, 2))
    solver.solve(data, rhs[:, 0])
    assert solver.counts["cholesky"] == 1
    kept = solver.factorized(data.copy())
    assert kept is solver._scratch.last[1]
    expected = fresh.factorized(data)
    assert type(kept) is type(expected)
    assert np.array_equal(kept(rhs), expected(rhs))
    other = 2.0 * data
    assert solver.factorized(other) is not kept
    assert np.array_equal(solver.factorized(other)(rhs), fresh.factorized(other)(rhs))
