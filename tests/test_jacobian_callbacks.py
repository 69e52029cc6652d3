"""The Jacobians handed to scikit-sundae are called, and are right.

scikit-sundae 1.1.1 silently replaced a user ``jacfn`` by finite differences when
``sparsity`` was given (docs/design.md §8), so a run that "works" proves nothing about the analytic
Jacobian. Here the CVODE / IDA constructors used by rodsim are wrapped to record the exact
callbacks and options rodsim hands over; the tests then check that SUNDIALS calls the
``jacfn`` during a run, that it agrees with central finite differences of the recorded
``rhsfn`` / ``resfn`` (for IDA: dR/dy + cj·dR/dy′), that nothing non-zero falls outside the
declared pattern, and that the declared band (lband/uband) covers the pattern.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import sksundae.cvode as cvode_module  # rodsim imports the solver classes from here at each
import sksundae.ida as ida_module  # start (lazily), so the recorder replaces them there
from sksundae.cvode import CVODE
from sksundae.ida import IDA

import rodsim
from rodsim.solvers.cvode import Cvode
from rodsim.solvers.ida import Ida

# With jacfn and sparsity both given, scikit-sundae warns that its own finite-difference
# approximation over `sparsity` is not used: that is the point here.
pytestmark = pytest.mark.filterwarnings(
    "ignore:Custom sparse Jacobian approximation:UserWarning")

SCENE = "table1-50g"
NODES = 8
CONFIGS = [(solver, formulation) for solver in ("band", "sparse")
           for formulation in ("inertial", "overdamped")]


class Recorder:
    """Stands in for CVODE/IDA: records the callbacks and options, counts jacfn calls."""

    def __init__(self, solver_class, n_jac_args: int) -> None:
        self.solver_class = solver_class
        self.n_jac_args = n_jac_args
        self.function = None
        self.options: dict = {}
        self.jacfn = None
        self.jac_calls = 0

    def __call__(self, function, **options):
        self.function, self.options, self.jacfn = function, dict(options), options["jacfn"]
        user = options["jacfn"]

        # scikit-sundae checks the callback's arity, so keep the exact signature.
        if self.n_jac_args == 4:
            def counted(t, y, yp, jj):
                self.jac_calls += 1
                return user(t, y, yp, jj)
        else:
            def counted(t, y, yp, res, cj, jj):
                self.jac_calls += 1
                return user(t, y, yp, res, cj, jj)

        options["jacfn"] = counted
        return self.solver_class(function, **options)


def overrides(integrator: str, solver: str, formulation: str) -> list[str]:
    return [f"nodes={NODES}", f"solver.{integrator}.linear_solver={solver!r}",
            f"solver.{integrator}.formulation={formulation!r}"]


def matrix_from_jacfn(recorder: Recorder, call) -> np.ndarray:
    """Run a recorded jacfn into the array layout scikit-sundae uses; return it dense."""
    options = recorder.options
    if options["linsolver"] == "sparse":
        pattern = sp.csc_matrix(options["sparsity"])
        jj = np.zeros(pattern.nnz)
        call(jj)
        return sp.csc_matrix((jj, pattern.indices, pattern.indptr), shape=pattern.shape).toarray()
    size = len(options["atol"])
    jj = np.zeros((size, size))
    call(jj)
    return jj


def check_against_fd(jac: np.ndarray, jac_fd: np.ndarray, pattern: np.ndarray, label: str):
    """Agreement to 1e-6, and no finite-difference non-zero outside the pattern."""
    # Rows and columns mix very different units (forces, velocities, multipliers), so the
    # error is measured relative to each row's and to each column's largest entry: an error
    # in a small block (say the multiplier column 2q) is not hidden by a stiff block.
    error = np.abs(jac - jac_fd)
    for axis, name in ((1, "row"), (0, "column")):
        scale = np.max(np.abs(jac_fd), axis=axis)
        assert np.all(scale > 0), f"{label}: a {name} of the Jacobian is identically zero"
        relative = np.max(error, axis=axis) / scale
        assert np.max(relative) < 1e-6, (
            f"{label}: Jacobian differs from finite differences by {np.max(relative):.3g} "
            f"(relative to {name} {np.argmax(relative)})")
    row_scale = np.max(np.abs(jac_fd), axis=1)
    outside = (np.abs(jac_fd) > 1e-9 * row_scale[:, None]) & ~pattern
    assert not np.any(outside), (f"{label}: {int(outside.sum())} non-zero entries outside the "
                                 f"pattern, e.g. {np.argwhere(outside)[:3].tolist()}")


def check_band(pattern: sp.spmatrix, lband: int, uband: int, label: str) -> None:
    coo = sp.coo_matrix(pattern)
    offsets = coo.row - coo.col
    assert offsets.max() <= lband, f"{label}: pattern reaches {offsets.max()} below, lband {lband}"
    assert -offsets.min() <= uband, (f"{label}: pattern reaches {-offsets.min()} above, "
                                     f"uband {uband}")


def steps_for(y: np.ndarray, exact: np.ndarray | None = None) -> np.ndarray:
    """Central-difference steps: 1e-6 relative for the model coordinates; for the slots in
    which the function is at most quadratic (velocities, multipliers, rates), where central
    differences are exact, steps of the variable's own size keep round-off out."""
    steps = 1e-6 * np.maximum(np.abs(y), 1e-3)
    if exact is not None:
        steps[exact] = np.maximum(np.abs(y[exact]), 1e-3)
    return steps


def fd_columns(function, y: np.ndarray, steps: np.ndarray) -> np.ndarray:
    columns = []
    for i, h in enumerate(steps):
        plus, minus = y.copy(), y.copy()
        plus[i] += h
        minus[i] -= h
        columns.append((function(plus) - function(minus)) / (2 * h))
    return np.array(columns).T


def solve_counting_jacfn_calls(scene, name: str, recorder, solver: str, label: str):
    """Solve with the recording solver class; SUNDIALS called our analytic jacfn, as often
    as rodsim counted."""
    result = rodsim.solve(scene, name)
    assert result.success, result.message
    assert recorder.options["linsolver"] == solver
    assert result.stats["jacobian_evals"] > 0
    assert recorder.jac_calls > 0, f"{label}: SUNDIALS never called the analytic jacfn"
    assert recorder.jac_calls == result.stats["jacobian_evals"]
    return result


@pytest.mark.parametrize(("solver", "formulation"), CONFIGS)
def test_cvode_jacfn_is_called_and_right(solver, formulation, monkeypatch, load,
                                         random_state):
    recorder = Recorder(CVODE, 4)
    monkeypatch.setattr(cvode_module, "CVODE", recorder)
    scene = load(SCENE, *overrides("cvode", solver, formulation))
    label = f"cvode {solver} {formulation}"
    result = solve_counting_jacfn_calls(scene, "cvode", recorder, solver, label)

    # The same equilibrium as the direct solve (the Jacobian is only used for the steps).
    reference = rodsim.solve(scene, "static")
    assert np.max(np.abs(result.positions() - reference.positions())) < 1e-6 * 0.12

    model = rodsim.build_model(scene)
    run = Cvode(Cvode.options_of(scene), 1e-9).init(model)
    system = run.system
    rng = np.random.default_rng(3)
    x = random_state(model, rng)
    y = system.initial_state()
    if formulation == "inertial":
        y[0::2] = x
        y[1::2] = 0.01 * run.dynamics.rate * model.length_scale * rng.standard_normal(model.n)
    else:
        y[:] = x
    t = 0.5 * run.dynamics.ramp.duration  # mid-ramp: loads scaled by 1/2
    load_factor = run.dynamics.ramp(t)
    steps = steps_for(y, np.arange(1, system.size, 2) if formulation == "inertial" else None)
    pattern = system.pattern.toarray() != 0

    # FirstOrderSystem: pattern + jacobian_data against FD of rhs.
    def rhs(state):
        out = np.empty(system.size)
        system.rhs(state, model.force(system.positions_of(state), load_factor), out)
        return out

    jac_fd = fd_columns(rhs, y, steps)
    assembled = sp.csc_matrix(
        (system.jacobian_data(model.jacobian_data(system.positions_of(y), load_factor)),
         system.pattern.indices, system.pattern.indptr), shape=system.pattern.shape).toarray()
    check_against_fd(assembled, jac_fd, pattern, f"{label} FirstOrderSystem")

    # The callbacks handed to scikit-sundae, in scikit-sundae's array layout.
    def recorded_rhs(state):
        out = np.empty(system.size)
        recorder.function(t, state, out)
        return out

    np.testing.assert_allclose(recorded_rhs(y), rhs(y), rtol=0, atol=0)
    jac = matrix_from_jacfn(recorder, lambda jj: recorder.jacfn(t, y, np.zeros_like(y), jj))
    check_against_fd(jac, fd_columns(recorded_rhs, y, steps), pattern, f"{label} jacfn")
    if solver == "band":
        check_band(system.pattern, recorder.options["lband"], recorder.options["uband"], label)
    else:
        recorded = sp.csc_matrix(recorder.options["sparsity"]).toarray() != 0
        np.testing.assert_array_equal(recorded, pattern)
    # The band of a single rod stays narrow (interleaved layout, Eq. 18).
    check_band(system.pattern, *system.band, f"{label} declared band")
    assert max(system.band) < system.size // 2


@pytest.mark.parametrize(("solver", "formulation"), CONFIGS)
def test_ida_jacfn_is_called_and_right(solver, formulation, monkeypatch, load, random_state):
    recorder = Recorder(IDA, 6)
    monkeypatch.setattr(ida_module, "IDA", recorder)
    scene = load(SCENE, *overrides("ida", solver, formulation))
    label = f"ida {solver} {formulation}"
    solve_counting_jacfn_calls(scene, "ida", recorder, solver, label)

    model = rodsim.build_model(scene)
    run = Ida(Ida.options_of(scene), 1e-9).init(model)
    system = run.system
    rng = np.random.default_rng(5)
    x = random_state(model, rng)
    y = system.initial_state()
    y[system.x_slot] = x
    if system.inertial:
        y[system.v_slot] = 0.01 * run.dynamics.rate * model.length_scale * rng.standard_normal(
            model.n)
    y[system.mu_slot] = model.force_scale * model.length_scale * rng.standard_normal(
        len(system.mu_slot))
    yp = 0.01 * run.dynamics.rate * rng.standard_normal(system.size)
    cj = 37.0
    t = 0.5 * run.dynamics.ramp.duration
    load_factor = run.dynamics.ramp(t)
    pattern = system.pattern.toarray() != 0

    exact = np.concatenate([system.mu_slot, system.v_slot if system.inertial else []])
    y_steps, yp_steps = steps_for(y, exact.astype(int)), steps_for(yp, np.arange(system.size))

    def residual(state, rate):
        out = np.empty(system.size)
        system.dae_residual(state, rate, model.force(system.positions_of(state), load_factor), out)
        return out

    jac_fd = (fd_columns(lambda s: residual(s, yp), y, y_steps)
              + cj * fd_columns(lambda r: residual(y, r), yp, yp_steps))
    assembled = sp.csc_matrix(
        (system.jacobian_data(y, yp, cj, model.jacobian_data(system.positions_of(y),
                                                             load_factor)),
         system.pattern.indices, system.pattern.indptr), shape=system.pattern.shape).toarray()
    check_against_fd(assembled, jac_fd, pattern, f"{label} ConstrainedSystem")

    def recorded_residual(state, rate):
        out = np.empty(system.size)
        recorder.function(t, state, rate, out)
        return out

    np.testing.assert_allclose(recorded_residual(y, yp), residual(y, yp), rtol=0, atol=0)
    recorded_fd = (fd_columns(lambda s: recorded_residual(s, yp), y, y_steps)
                   + cj * fd_columns(lambda r: recorded_residual(y, r), yp, yp_steps))
    res = recorded_residual(y, yp)
    jac = matrix_from_jacfn(recorder, lambda jj: recorder.jacfn(t, y, yp, res, cj, jj))
    check_against_fd(jac, recorded_fd, pattern, f"{label} jacfn")
    if solver == "band":
        check_band(system.pattern, recorder.options["lband"], recorder.options["uband"], label)
    else:
        recorded = sp.csc_matrix(recorder.options["sparsity"]).toarray() != 0
        np.testing.assert_array_equal(recorded, pattern)
    check_band(system.pattern, *system.band, f"{label} declared band")
    assert max(system.band) < system.size // 2
