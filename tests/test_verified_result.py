"""No wrong success: a result must pass the common stopping test on the full-penalty model,
evaluated afresh at the returned state, whatever the integrator's own test said (issue 24).

The integrator's own test is made to lie (its ``residual`` says 0 and ``advance`` returns a
state far from equilibrium with success): the template must turn that into a failure with
advice. And a real run's state, moved off its equilibrium afterwards, is refused the same way.
"""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.solvers import registered_integrators
from rodsim.solvers.base import Outcome

SCENE = "table1-50g"
BASE = ("nodes=10", "max_wall_time=60")


def lying(integrator: str, monkeypatch: pytest.MonkeyPatch, offset: float) -> None:
    """Make ``integrator`` report success at the rest state bent by ``offset`` (a fraction of
    L along x on every free position), with its own residual test saying 0."""
    cls = registered_integrators()[integrator]

    def advance(self, run):
        x = run.start.copy()
        moved = np.flatnonzero(~run.model.is_quaternion)[0::3]
        x[moved] += offset * run.model.length_scale
        return Outcome(x, True, "converged")

    monkeypatch.setattr(cls, "advance", advance)
    monkeypatch.setattr(cls, "residual_at", lambda self, run, x: 0.0)


@pytest.mark.parametrize("integrator", ["static", "paper", "cvode", "ida"])
def test_a_state_far_from_equilibrium_is_never_a_success(integrator, monkeypatch):
    lying(integrator, monkeypatch, 0.014)  # IDA's wrong success at N = 40 000 was 1.4 % L
    result = rodsim.solve(SCENE, integrator, overrides=BASE)
    assert not result.success
    assert "not an equilibrium" in result.message
    assert "try " in result.message  # advice
    assert result.residual > result.stats["effective_tolerance"]


def test_an_imbalance_spread_over_the_nodes_fails_the_correction_test():
    """What IDA hit at N = 40 000: every node's force below the tolerance, the rod still off
    its equilibrium. The state is the exact equilibrium of the scene with an extra self-weight
    of about 1 % of the tip load (density lowered so) spread over N = 2000 nodes: on the scene
    without it, each node's force residual is that weight / N, ~5e-6 of F_ref, while the
    correction residual should read the distance between the two equilibria over the tip
    load's displacement (both from static solves, independent of the function)."""
    from rodsim.solvers.base import correction_residual

    overrides = ["rods.catheter.nodes=2000"]
    weighed = [*overrides, "rods.catheter.terms=['stretch','bend_twist','centerline',"
               "'tip_load','gravity']", "rods.catheter.density=36.8"]
    plain = rodsim.solve(SCENE, "static", overrides=overrides)
    perturbed = rodsim.solve(SCENE, "static", overrides=weighed)
    assert plain.success and perturbed.success
    model = rodsim.app.api.build_model(rodsim.load_scene(SCENE, overrides))
    x = perturbed.state
    force = model.force(x)
    assert model.force_residual(force) < 1e-5  # the force test alone would pass at N = 40 000
    distance = np.max(np.abs(perturbed.positions() - plain.positions()))
    reach = np.max(np.abs(plain.positions() - model.positions(model.x0, "catheter")))
    value = correction_residual(model, x, force)
    assert 1e-3 < value
    assert 0.3 * distance / reach < value < 3.0 * distance / reach


@pytest.mark.parametrize("integrator", ["static", "cvode", "ida"])
def test_the_check_is_on_the_full_penalty_model(integrator, monkeypatch):
    """A state at equilibrium with the penalties lowered (what static's and the finishes'
    continuations pass through) is not an equilibrium of the full model."""
    cls = registered_integrators()[integrator]
    scene = ("table1-50g", [*BASE, "rods.catheter.centerline.K_P=1e8"])

    def advance(self, run):
        model = run.model.with_term_scales(
            {k: 1e-4 for k, term in enumerate(run.model.terms) if term.penalty})
        run.model = model  # the run's own test now looks at the lowered model
        from rodsim.solvers.base import Integrator

        converged, x, _ = Integrator.newton_equilibrium(self, run, run.start, 1.0, 200,
                                                        "test")
        assert converged
        return Outcome(x, True, "converged")

    monkeypatch.setattr(cls, "advance", advance)
    if integrator == "ida":  # its own test reads the IDA state, which this run has none of
        monkeypatch.setattr(cls, "residual_at",
                            lambda self, run, x: run.model.force_residual(run.model.force(x)))
    result = rodsim.solve(scene[0], integrator, overrides=scene[1])
    assert not result.success
    assert "not an equilibrium" in result.message


@pytest.mark.parametrize("integrator", ["static", "paper", "cvode", "ida"])
def test_honest_runs_still_succeed(integrator):
    result = rodsim.solve(SCENE, integrator, overrides=BASE)
    assert result.success, result.message


@pytest.mark.slow
@pytest.mark.nightly
def test_ida_at_n_40000_is_right_or_a_failure():
    """The real case (issue 24): IDA on table1-50g at N = 40 000 reported success 1.3 % L
    from static's equilibrium. Now it must be within 1e-6 L of it or fail (nightly:
    RODSIM_NIGHTLY=1; the lying-integrator tests above hold the same check in every run).
    Since its finish steps through the frames on large models it succeeds (measured:
    19 steps, ~20 s, 1.7e-9 L)."""
    overrides = ["rods.catheter.nodes=40000", "solver.max_wall_time=900"]
    static = rodsim.solve(SCENE, "static", overrides=overrides)
    assert static.success, static.message
    result = rodsim.solve(SCENE, "ida", overrides=overrides)
    if result.success:
        distance = np.max(np.abs(result.positions() - static.positions())) / 0.12
        assert distance < 1e-6, f"IDA succeeded {distance:.3g} L from static"
    else:
        assert "not an equilibrium" in result.message or "stalled" in result.message


# Issue 23 item 6: "IDA and static differ by 4.5e-6 L on a folded rod while both report
# success". Folded rods (the tip pulled back past the clamp, x < 0) on today's code: the
# reach reproduction's cold re-solve (forces -6.21, 3.29, -0.93 N at N = 10, measured 2.8e-11 L
# apart) and a 20 N pull back at N = 100 (4.8e-10 L). Both integrators succeed, both
# equilibria are stable, and they are one equilibrium: apart by far less than the tolerance
# allows (about alpha x tolerance x L, docs/model.md), checked by a second integrator.
FOLDED = [("nodes=10", "tip_load.force=[-6.21,3.29,-0.93]"),
          ("nodes=100", "tip_load.mass=0", "tip_load.force=[-20,2,0]")]


@pytest.mark.parametrize("overrides", FOLDED)
def test_static_and_ida_agree_on_a_folded_rod(overrides):
    scene = rodsim.load_scene(SCENE, [*overrides, "max_wall_time=60"])
    results = {name: rodsim.solve(scene, name) for name in ("static", "ida")}
    for name, result in results.items():
        assert result.success, (name, result.message)
        assert result.stability is not None and result.stability.stable, name
    static, ida = (results[name].positions("catheter") for name in ("static", "ida"))
    assert static[-1, 0] < 0  # folded back past the clamp
    length = scene.rods["catheter"].length
    assert np.abs(static - ida).max() / length < 1e-8


@pytest.mark.slow
@pytest.mark.nightly
def test_every_integrator_succeeds_at_n_40000():
    """Issue 24's aim: static, CVODE, IDA and paper on table1-50g at N = 40 000 all succeed
    on one equilibrium within 1e-6 L (about 40 s in all, so nightly). Measured: CVODE and
    IDA within 1.7e-9 L of static, paper 2.8e-8 L (docs/benchmark-history.md, "Large N"); before
    the large-model paths (rodsim/solvers/base.py, LARGE_MODEL_SIZE) only static
    succeeded."""
    scene = rodsim.load_scene(SCENE, ["rods.catheter.nodes=40000", "solver.max_wall_time=300"])
    model = rodsim.build_model(scene)
    static = rodsim.solve(scene, "static", model=model)
    assert static.success, static.message
    for integrator, within in (("cvode", 1e-8), ("ida", 1e-8), ("paper", 1e-6)):
        result = rodsim.solve(scene, integrator, model=model)
        assert result.success, (integrator, result.message)
        distance = np.max(np.linalg.norm(result.positions() - static.positions(), axis=-1))
        assert distance / 0.12 < within, (integrator, distance / 0.12)
