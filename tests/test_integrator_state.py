"""The integrator contract (rodsim/solvers/base.py, rodsim/solvers/run_state.py): an
integrator holds configuration only, a run's state is a value that a run returns and that
starts another (a warm start), and track, fit and reach solve their equilibria with any
registered integrator through that contract (rodsim/app/inverse/continuation.py)."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.app.inverse.fit import Points, fit
from rodsim.core.schema import SceneError
from rodsim.solvers import DEFAULT_INTEGRATOR, integrator_named, registered_integrators
from rodsim.solvers.run_state import RunState

#: Every integrator track, fit and reach are run with: each registered one (an integrator
#: added later too) but scipy, the benchmarks' baseline.
INTEGRATORS = [name for name in sorted(registered_integrators()) if name != "scipy"]
SMALL = ["nodes=10"]
LENGTH = 0.12  # table1's catheter [m]
#: How close a pseudo-dynamic run's equilibrium is to static's on these scenes (its residual
#: test stops at the tolerance; tests/test_integrators.py measures them closer).
CLOSE = 1e-6 * LENGTH


def _cold(scene, integrator: str = DEFAULT_INTEGRATOR):
    result = rodsim.solve(scene, integrator)
    assert result.success, result.message
    return result


@pytest.mark.parametrize("name", sorted(registered_integrators()))
def test_an_integrator_holds_configuration_only(name):
    scene = rodsim.load_scene("table1-50g", SMALL)
    integrator = integrator_named(name).for_scene(scene)
    before = dict(vars(integrator))
    result, state = integrator.run(integrator.init(rodsim.build_model(scene)))
    assert result.success, result.message
    # A run wrote nothing on the integrator: the model in use, counters, history and the
    # last force live on the returned state.
    assert vars(integrator).keys() == before.keys() == {"options", "tolerance",
                                                        "max_wall_time", "_progress"}
    assert all(vars(integrator)[k] is before[k] for k in before)
    assert isinstance(state, RunState) and state.counts["force_evals"] > 0
    assert result.stats["force_evals"] == state.counts["force_evals"]


@pytest.mark.parametrize("name", INTEGRATORS)
def test_a_returned_state_warm_starts_a_run_on_a_nearby_model(name):
    """restart: the equilibrium a run returned starts a continuation step on a nearby
    model; it reaches the cold equilibrium of that model with fewer force evaluations, and
    leaves the first run's state (its counters) as they were. (``static``'s continuation
    step takes linear Newton steps, x + Δx: it is compared with a cold solve through the
    same kind of steps, ``retraction = "lengths"`` — measured 11 against 20 evaluations;
    the default "frames" makes the cold solve itself take 7 here.)"""
    scene = rodsim.load_scene("table1-50g", SMALL)
    near = scene.with_values({"rods.catheter.tip_load.mass": 0.06})
    integrator = integrator_named(name).for_scene(scene)
    first, state = integrator.run(integrator.init(rodsim.build_model(scene)))
    assert first.success, first.message
    counted = dict(state.counts)
    model = state.model.with_values(near)
    warm, warm_state = integrator.run(integrator.restart(state, model))
    assert warm.success, warm.message
    assert warm_state is not state and state.counts == counted
    cold = _cold(near.with_overrides(["solver.static.retraction=lengths"]), name)
    assert warm.stats["force_evals"] < cold.stats["force_evals"]
    reference = _cold(near)
    assert np.abs(warm.positions() - reference.positions()).max() < CLOSE


@pytest.mark.parametrize("name", INTEGRATORS)
def test_track_runs_with_every_integrator(name):
    scene = rodsim.load_scene("table1-50g", SMALL)
    masses = [0.03, 0.045, 0.06]
    path = rodsim.track(scene, {"tip_load.mass": masses}, name, estimates=False)
    assert path.success, path.message
    assert path.integrator == name and len(path.iterations) == 3
    assert all(iterations > 0 for iterations in path.iterations)
    for step, mass in enumerate(masses):
        cold = _cold(scene.with_values({"rods.catheter.tip_load.mass": mass}))
        assert np.abs(path.positions[step] - cold.positions()).max() < CLOSE


@pytest.mark.parametrize("name", INTEGRATORS)
def test_fit_runs_with_every_integrator(name):
    scene = rodsim.load_scene("table1-50g", SMALL)
    truth = _cold(scene.with_overrides(["youngs_modulus=5e6"]))
    found = fit(scene, Points(truth.positions("catheter")[1:], None), ["youngs_modulus"],
                integrator=name)
    assert found.result.integrator == name
    # Exact data: the modulus back to the equilibria's tolerance.
    assert found.values[0] == pytest.approx(5e6, rel=1e-4)


@pytest.mark.parametrize("name", INTEGRATORS)
def test_reach_runs_with_every_integrator(name):
    scene = rodsim.load_scene("table1-50g", SMALL)
    target = _cold(scene.with_overrides(["origin=[0.0, 0.01, 0.0]"])).tip()
    found = rodsim.reach(scene, target, ["origin[1]"], integrator=name)
    assert found.success, found.message
    assert found.result.integrator == name
    assert found.values[0] == pytest.approx(0.01, abs=1e-6)


def test_an_unknown_integrator_is_one_scene_error():
    scene = rodsim.load_scene("table1-50g", SMALL)
    with pytest.raises(SceneError, match="integrator 'nope': unknown; allowed: "):
        rodsim.reach(scene, [0.1, 0.0, 0.0], ["origin[1]"], integrator="nope")


@pytest.mark.parametrize(("command", "name"), [("fit", "cvode"), ("reach", "ida"),
                                               ("track", "paper"), ("fit", None)])
def test_the_cli_solves_track_fit_and_reach_with_the_integrator_named(command, name,
                                                                      tmp_path, cli):
    """``--integrator`` on track, fit and reach reaches the continuation; without it they use
    the registry's default, not the scene's own (table1-50g declares cvode)."""
    import xarray as xr

    scene = rodsim.load_scene("table1-50g", SMALL)
    truth = _cold(scene.with_overrides(["youngs_modulus=5e6", "origin=[0.0, 0.01, 0.0]"]))
    data = tmp_path / "shape.csv"
    np.savetxt(data, truth.positions("catheter")[1:], delimiter=",", header="x,y,z",
               comments="")
    arguments = {"fit": ["--data", str(data), "--param", "youngs_modulus",
                         "--set", "origin=[0.0, 0.01, 0.0]"],
                 "reach": ["--tip", ",".join(f"{v:.12g}" for v in truth.tip()),
                           "--actuate", "origin[1]", "--set", "youngs_modulus=5e6"],
                 "track": ["--ramp", "tip_load.mass=0.05:0.06:3"]}[command]
    output = tmp_path / f"{command}.nc"
    chosen = [] if name is None else ["--integrator", name]
    code = cli([command, "table1-50g", *arguments, *chosen, "--set", *SMALL,
                "-o", str(output)])
    assert code == 0
    with xr.open_dataset(output) as ds:
        assert ds.attrs["integrator"] == (name or DEFAULT_INTEGRATOR)


def test_a_results_options_are_what_asdict_gives_for_every_integrator():
    """``options_dict`` (what a Result records) against ``dataclasses.asdict`` on each
    registered integrator's options as a scene sets them: the same keys and values."""
    import dataclasses

    from rodsim.solvers.base import options_dict

    scene = rodsim.load_scene("tdcr-two-segment")
    for name, kind in registered_integrators().items():
        options = kind.options_of(scene)
        assert options_dict(options) == dataclasses.asdict(options), name
