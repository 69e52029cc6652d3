"""The run contract (issue 33 item 0): when a run stops (rodsim/solvers/stops.py) and what it
records (rodsim/solvers/recorder.py) are values on the run; a run to a time records the
state at requested times from dense output (rodsim/solvers/trajectory.py).

The trajectories of CVODE and IDA stopped at a time are checked against an independent
reference: the same pseudo-dynamics, c M ẋ = F(x, λ(t)), written out here from the model's
force and Jacobian and integrated by scipy's Radau at a tolerance 100× tighter.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import rodsim
from rodsim.app.api import build_model, load_scene
from rodsim.core.model import Model
from rodsim.solvers import registered_integrators
from rodsim.solvers.pseudo_dynamics import PseudoDynamics
from rodsim.solvers.recorder import SaveAt
from rodsim.solvers.stops import Equilibrium, Until

TIGHT = ["solver.cvode.rtol=1e-9", "solver.cvode.atol=1e-11",
         "solver.ida.rtol=1e-9", "solver.ida.atol=1e-11"]


def robot(seed: int) -> dict:
    """A user's cantilever, written from docs/scenes.md: a steel or nitinol wire under mN,
    or a soft polymer catheter under N, with a tip force in a random direction."""
    rng = np.random.default_rng(seed)
    kind = ["steel", "nitinol", "polymer"][seed % 3]
    modulus, radius, density, load = {
        "steel": (200e9, 2.5e-4, 7850.0, 5e-3), "nitinol": (60e9, 3e-4, 6450.0, 2e-2),
        "polymer": (5e6, 2e-3, 1100.0, 0.5)}[kind]
    direction = np.array([0.3, -1.0, 0.3]) * rng.uniform(0.5, 1.0, size=3)  # mostly down,
    force = load * direction / np.linalg.norm(direction)  # across the rod (along x)
    return {"name": f"user-{kind}-{seed}",
            "rods": {"wire": {"length": float(rng.uniform(0.05, 0.3)), "radius": radius,
                              "youngs_modulus": modulus, "density": density, "nodes": 9,
                              "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
                              "tip_load": {"force": force.tolist()}}},
            "solver": {"integrator": "cvode"}}


def reference(model: Model, dynamics: PseudoDynamics, times: np.ndarray) -> np.ndarray:
    """The overdamped pseudo-dynamics c M ẋ = F(x, λ(t)) from rest, by scipy's Radau at
    rtol 1e-11: the states at ``times``, (T, n)."""
    damping = dynamics.rate * dynamics.masses

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        return model.force(x, dynamics.ramp(t)) / damping

    def jacobian(t: float, x: np.ndarray):
        return model.jacobian(x, dynamics.ramp(t)).multiply(1.0 / damping[:, None]).tocsc()

    scale = np.where(model.is_quaternion, 1.0, model.length_scale)
    solution = solve_ivp(rhs, (0.0, times[-1]), model.x0, method="Radau", jac=jacobian,
                         t_eval=times, rtol=1e-11, atol=1e-13 * scale)
    assert solution.status == 0, solution.message
    return solution.y.T


def run_until(scene, integrator: str, stop: Until, save: SaveAt | None = None):
    model = build_model(scene)
    solver = registered_integrators()[integrator].for_scene(scene)
    result, _ = solver.run(solver.init(model, stop=stop, save=save))
    return model, solver, result


def span(scene, integrator: str) -> tuple[Model, PseudoDynamics, float]:
    """The scene's model, its pseudo-dynamics and an end time: the load ramp and three
    first-mode periods (the rod still moving)."""
    model = build_model(scene)
    options = registered_integrators()[integrator].options_of(scene)
    dynamics = PseudoDynamics.of(model, options, False)
    return model, dynamics, dynamics.ramp.duration + 3.0 * dynamics.period


@pytest.mark.parametrize("integrator", ["cvode", "ida"])
@pytest.mark.parametrize("case", ["table1-20g", 0, 1, 2])
def test_a_run_to_a_time_follows_the_independent_reference(integrator, case):
    """The states at 20 output times agree with scipy's Radau on the same equations within
    1e-7 L, for the shipped table1-20g and a steel, a nitinol and a polymer robot. Measured:
    at most 1.7e-8 L (CVODE) and 7.2e-9 L (IDA) while the tips move 5e-4 to 0.8 L; taking
    each step's end instead of the interpolant at the output times gave 8e-6 to 1.2e-3 L."""
    scene = (load_scene("table1-20g", overrides=["rods.catheter.nodes=12", *TIGHT])
             if case == "table1-20g" else load_scene(robot(case), overrides=TIGHT))
    model, dynamics, t_end = span(scene, integrator)
    times = np.linspace(0.0, t_end, 21)[1:]
    _, _, result = run_until(scene, integrator, Until(t_end, tuple(times)))
    assert result.success, result.message
    assert "reached t" in result.message
    trajectory = result.trajectory
    assert trajectory is not None
    np.testing.assert_array_equal(trajectory.times, times)
    expected = reference(model, dynamics, times)
    scale = np.where(model.is_quaternion, 1.0, model.length_scale)
    error = np.max(np.abs(trajectory.states - expected) / scale)
    rest = model.positions(model.x0, next(iter(model.rods)))
    moved = np.max(np.abs(trajectory.tip()[-1] - rest[-1]))
    assert moved > 1e-4 * model.length_scale  # moved 1000x the bound: not a vacuous check
    assert error < 1e-7, error
    # The last output is the state the run ended in, and the rods' shapes are its own.
    np.testing.assert_array_equal(trajectory.states[-1], result.state)
    np.testing.assert_array_equal(trajectory.positions()[-1], result.positions())
    assert trajectory.positions().shape == (20, *result.positions().shape)


@pytest.mark.parametrize("integrator", ["cvode", "ida"])
def test_output_times_do_not_force_steps(integrator):
    """Many output times or one: the same steps and the same final state, bit for bit (the
    outputs are interpolated from the steps that span them)."""
    scene = load_scene("tdcr-two-segment")
    _, _, t_end = span(scene, integrator)
    _, _, one = run_until(scene, integrator, Until(t_end))
    _, _, many = run_until(scene, integrator, Until(t_end, tuple(np.linspace(0, t_end, 57))))
    assert one.success and many.success, (one.message, many.message)
    assert many.stats["steps"] == one.stats["steps"]
    np.testing.assert_array_equal(many.state, one.state)
    assert len(many.trajectory) == 57 and len(one.trajectory) == 1
    assert many.trajectory.times[0] == 0.0
    np.testing.assert_allclose(many.trajectory.states[0], build_model(scene).x0, rtol=0,
                               atol=1e-12)  # interpolated at t = 0: the rest state


def test_a_run_to_a_long_time_comes_to_rest_at_the_equilibrium():
    """Stopped at a time long after the pseudo-dynamics settle, CVODE's state is static's
    equilibrium (within the time stepping's tolerance), though no equilibrium test ran."""
    scene = load_scene("table1-50g", overrides=["rods.catheter.nodes=12", *TIGHT])
    _, dynamics, _ = span(scene, "cvode")
    _, _, result = run_until(scene, "cvode", Until(dynamics.ramp.duration
                                                    + 200.0 * dynamics.period))
    static = rodsim.solve(scene, "static")
    assert result.success and static.success
    assert result.stability is None  # a state at a time is not assessed as an equilibrium
    assert np.max(np.abs(result.tip() - static.tip())) < 1e-6 * 0.12


def test_a_run_to_a_time_through_tendon_re_registrations():
    """table3-catheter1 (the paper's tendon coupling, whose tendon points change parent as
    the catheter bends, §4.1): CVODE and IDA, each restarting its solver at every
    re-registration, agree with each other along the way (measured 1 and 3 periods after
    the ramp: tips 0.26 and 0.056 L from the equilibrium, 5e-8 and 2.7e-7 L apart) and end
    at static's equilibrium (30 periods: 7e-11 L and 2.4e-9 L)."""
    scene = load_scene("table3-catheter1", overrides=TIGHT)
    model, dynamics, _ = span(scene, "cvode")
    times = tuple(dynamics.ramp.duration + k * dynamics.period for k in (1.0, 3.0, 30.0))
    runs = {name: run_until(scene, name, Until(times[-1], times))[2] for name in ("cvode", "ida")}
    static = rodsim.solve(scene, "static")
    assert static.success, static.message
    for name, result in runs.items():
        assert result.success, result.message
        assert result.stats["reinits"] > 0, name  # the restarts were exercised
        assert np.max(np.abs(result.tip() - static.tip())) < 1e-7 * model.length_scale, name
    cvode, ida = (runs[name].trajectory.tip() for name in ("cvode", "ida"))
    assert np.max(np.abs(cvode[1] - static.tip())) > 1e-2 * model.length_scale  # moving
    assert np.max(np.abs(cvode - ida)) < 2e-6 * model.length_scale


def test_steps_recorded_as_a_trajectory_match_the_history():
    """SaveAt(states=True) on the paper's time stepping: one state per step, at the
    history's times, the last one the equilibrium."""
    scene = load_scene("table1-100g")
    model = build_model(scene)
    solver = registered_integrators()["paper"].for_scene(scene)
    result, _ = solver.run(solver.init(model, save=SaveAt(states=True)))
    assert result.success, result.message
    trajectory = result.trajectory
    assert trajectory is not None and len(trajectory) == len(result.history["time"]) > 1
    np.testing.assert_array_equal(trajectory.times, result.history["time"])
    np.testing.assert_array_equal(trajectory.tip()[:, :],
                                  np.array(result.history["tip"]))
    np.testing.assert_array_equal(trajectory.positions()[-1], result.positions())
    assert trajectory.time_units == "s"


def test_the_default_run_records_no_trajectory():
    assert rodsim.solve("table1-20g", "cvode").trajectory is None


# ----------------------------------------------------------------- refusals, one line each
@pytest.fixture(scope="module")
def small():
    scene = load_scene("table1-20g", overrides=["rods.catheter.nodes=8"])
    return scene, build_model(scene)


def integrator(scene, name: str):
    return registered_integrators()[name].for_scene(scene)


@pytest.mark.parametrize("name", ["static", "paper", "scipy"])
def test_an_integrator_refuses_a_stop_it_cannot_honour(small, name):
    scene, model = small
    with pytest.raises(ValueError, match=f"{name} integrator cannot stop by Until"):
        integrator(scene, name).init(model, stop=Until(1.0))


def test_output_times_need_a_stop_at_a_time(small):
    scene, model = small
    with pytest.raises(ValueError, match="output times"):
        integrator(scene, "cvode").init(model, stop=Equilibrium(), save=SaveAt(times=(1.0,)))
    with pytest.raises(ValueError, match="output times"):
        integrator(scene, "static").init(model, save=SaveAt(times=(1.0,)))


@pytest.mark.parametrize("arguments, match", [
    ((0.0,), "t_end must be a finite time > 0"),
    ((-1.0,), "t_end must be a finite time > 0"),
    ((float("nan"),), "t_end must be a finite time > 0"),
    ((1.0, (0.5, 0.5)), "must increase strictly"),
    ((1.0, (0.6, 0.2)), "must increase strictly"),
    ((1.0, (0.5, 2.0)), "after t_end"),
    ((1.0, (-0.1, 0.5)), "finite and ≥ 0"),
])
def test_a_bad_stop_is_a_one_line_error(arguments, match):
    with pytest.raises(ValueError, match=match) as caught:
        Until(*arguments)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("name", ["static", "cvode", "ida", "paper"])
def test_a_force_passed_as_a_state_is_refused_in_one_line(small, name):
    """Issue 38: a force where a state was expected divided by zero in a kernel, and the
    ZeroDivisionError escaped Integrator.run. Now the run refuses it before any work, and
    so it does a full-coordinate vector or a state with NaN. The free coordinates are
    offsets from the rest state, so the force keeps the rest quaternions; its position
    entries stretch the tip segment 11.5 times its rest length."""
    scene, model = small
    solver = integrator(scene, name)
    for wrong, match in ((model.force(model.x0), "stretched"),
                         (model.full(model.x0), "free coordinates"),
                         (np.full(model.n, np.nan), "non-finite")):
        with pytest.raises(ValueError, match=match) as caught:
            solver.solve(model, wrong)
        assert "\n" not in str(caught.value)


@pytest.mark.parametrize("name", ["static", "paper"])
def test_a_vector_passed_as_a_run_is_refused_in_one_line(small, name):
    """Integrator.run takes the state init makes; a force or a coordinate vector in its
    place is a one-line TypeError naming what to call instead (an AttributeError from
    deep in the run before)."""
    scene, model = small
    solver = integrator(scene, name)
    for wrong in (model.force(model.x0), model.x0):
        with pytest.raises(TypeError, match="init") as caught:
            solver.run(wrong)
        assert "\n" not in str(caught.value)


def test_rodsim_solve_refuses_a_force_as_its_start_in_one_line(small):
    """The public entry point passes the same check on: rodsim.solve with a force as its
    initial_state is a one-line ValueError, not a failed run nor an escaping
    ZeroDivisionError."""
    scene, model = small
    with pytest.raises(ValueError, match="stretched") as caught:
        rodsim.solve(scene, "static", model=model, initial_state=model.force(model.x0))
    assert "\n" not in str(caught.value)


def test_a_division_by_zero_inside_a_run_is_a_failed_result(small, monkeypatch):
    """A state that leaves the model's domain mid-run (a kernel dividing by zero) ends the
    run as a failure with a message, as every failure does, instead of escaping it."""
    scene, model = small
    calls = {"n": 0}
    force = Model.force

    def failing(self, x, load=1.0):
        calls["n"] += 1
        if calls["n"] == 4:  # once, as at a state outside the domain
            raise ZeroDivisionError("division by zero")
        return force(self, x, load)

    monkeypatch.setattr(Model, "force", failing)
    result = integrator(scene, "static").solve(model)
    assert not result.success
    assert "division by zero" in result.message and "static integrator failed" in result.message
