"""The compiled frames retraction (``turn`` of rodsim/core/kernels/_retraction.py) against its
numpy reference (:func:`rodsim.core.rod.retraction.turn_segments` in
:meth:`rodsim.core.model.Model.turned_step` with ``kernels = "numpy"``)."""

from __future__ import annotations

import numpy as np
import pytest
from counts import at_most

import rodsim
from rodsim.core.model import Model

#: Scenes with fixed nodes (a clamp, an inserted base), several rods and an endpoint coupling
#: (table3-catheter1, four-tendons), string tendons (tdcr-two-segment, catheter-pull-ring).
SCENES = ["tdcr-two-segment", "catheter-pull-ring", "table3-catheter1", "four-tendons",
          "table1-50g", "vessel-insertion"]


@pytest.mark.parametrize("scene", SCENES)
def test_compiled_frames_retraction_matches_the_numpy_reference(scene):
    """Large random steps (segments turned by tenths of a radian), so that the retraction
    differs from x + dx by far more than round-off: the two must agree to round-off."""
    loaded = rodsim.load_scene(scene)
    compiled, reference = Model(loaded, kernels="compiled"), Model(loaded, kernels="numpy")
    rng = np.random.default_rng(11)
    x = compiled.x0 + 1e-3 * rng.normal(size=compiled.n)
    dx = 0.1 * rng.normal(size=compiled.n)
    fast, slow = compiled.turned_step(x, dx), reference.turned_step(x, dx)
    assert np.abs(slow - (x + dx)).max() > 1e-4  # the retraction does something here
    scale = np.abs(slow).max()
    assert np.abs(fast - slow).max() <= 1e-13 * scale
    small = 1e-6 * dx
    assert np.abs(compiled.turned_step(x, small) - (x + small)).max() < 1e-3 * np.abs(small).max()


@pytest.mark.parametrize("scene", ["tdcr-two-segment", "catheter-pull-ring"])
def test_fused_frames_step_is_the_offset_retraction_bit_for_bit(scene):
    """The compiled ``turned_step`` (one kernel, ``turn_offsets``) against the offset
    retraction it replaced (``_retracted`` around the compiled ``turn``): the same bytes,
    for steps from round-off size (where x + dx is kept) to tenths of a radian, and for a
    step with a NaN or an infinity."""
    model = Model(rodsim.load_scene(scene), kernels="compiled")
    rng = np.random.default_rng(7)
    for trial in range(60):
        x = rng.normal(scale=10.0 ** rng.uniform(-8, -2), size=model.n)
        dx = rng.normal(scale=10.0 ** rng.uniform(-14, -1), size=model.n)
        if trial == 1:
            dx[3] = np.nan
        if trial == 2:
            dx[5] = np.inf
        with np.errstate(invalid="ignore"):
            expected = model._retracted(model._turned_absolute, x, dx)
            assert model.turned_step(x, dx).tobytes() == expected.tobytes(), trial


def test_static_solve_with_compiled_frames_matches_the_numpy_path():
    """A whole static solve of tdcr-two-segment with the frames retraction: the compiled
    kernels (the retraction among them) and the numpy references reach the same equilibrium
    within the residual floor (1.2e-9 L)."""
    scene = rodsim.load_scene("tdcr-two-segment", ["solver.static.retraction=frames"])
    compiled = rodsim.solve(scene, "static")
    numpy_path = rodsim.solve(scene.with_overrides(["kernels=numpy"]), "static")
    assert compiled.success and numpy_path.success
    assert np.abs(compiled.positions() - numpy_path.positions()).max() < 5e-9 * 0.4


@pytest.mark.parametrize(("scene", "expected"), [
    ("tdcr-two-segment", "frames"), ("catheter-pull-ring", "frames"),
    ("catheter-helical", "frames"), ("table1-50g", "frames"), ("table1-100g", "frames"),
    ("table3-catheter1", "lengths"), ("four-tendons", "lengths"),
    ("tendon-conserving", "lengths"), ("vessel-insertion", "lengths"),
    ("tip-on-tissue", "lengths")])
def test_the_default_retraction_follows_the_model(scene, expected):
    """``retraction = "auto"`` (the default): "lengths" where a tendon is a rod (the paper's
    couplings, measured no faster with "frames") or a rod meets an obstacle (contact: see
    tests/test_contact.py's tip on a plane, where "frames" failed), "frames" otherwise; a
    named one is kept."""
    from rodsim.solvers.base import retraction_of
    from rodsim.solvers.static import Static

    loaded = rodsim.load_scene(scene)
    model = Model(loaded)
    assert Static.options_of(loaded).retraction == "auto"
    assert retraction_of(model, "auto") == expected
    assert retraction_of(model, "lengths") == "lengths"
    assert retraction_of(model, "frames") == "frames"


def test_the_default_static_solve_of_tdcr_takes_the_frames_path():
    """Without hand tuning, tdcr-two-segment's static solve is the frames one: the same
    iterations and the same equilibrium as with ``retraction = "frames"`` named."""
    scene = rodsim.load_scene("tdcr-two-segment")
    default = rodsim.solve(scene, "static")
    named = rodsim.solve(scene.with_overrides(["solver.static.retraction=frames"]), "static")
    assert default.stats["newton_iters"] == named.stats["newton_iters"] <= at_most(6)
    assert np.array_equal(default.positions(), named.positions())


def test_cvode_finishes_tdcr_through_the_frames_retraction():
    """CVODE's Newton finish on a model with string tendons steps through the frames: on
    tdcr-two-segment with one tendon pulled (a long unloaded distal segment that turns) the
    first finish succeeds (measured: after 12 steps; with the lengths retraction it failed
    three times and CVODE took 209 steps), on static's equilibrium within the residual
    floor (1.2e-9 L)."""
    scene = rodsim.load_scene("tdcr-two-segment", [
        *(f"{t}.tendon_string.tension=0" for t in ("s1b", "s1c", "s2a", "s2b", "s2c")),
        "tip_load.force=[0, 0, 0]", "s1a.tendon_string.tension=3"])
    cvode, static = rodsim.solve(scene, "cvode"), rodsim.solve(scene, "static")
    assert cvode.success and static.success
    assert cvode.stats["finish_attempts"] == 1 and cvode.stats["steps"] <= at_most(12)
    assert np.abs(cvode.positions() - static.positions()).max() < 5e-9 * 0.4


def test_cvode_finishes_a_large_model_through_the_frames_retraction():
    """Above LARGE_MODEL_SIZE free coordinates CVODE's finish steps through the frames on
    any model (rodsim/solvers/sundials.py): on table1-50g at N = 1 000 (6 993 unknowns) it
    takes 5-6 Newton iterations (measured; through Model.step it took 15, and at N = 20 000
    four finishes failed and CVODE took 1787 steps), on static's equilibrium within 1.4e-9 L
    (measured; its tolerance is the residual floor, 2.9e-7)."""
    from rodsim.solvers.base import LARGE_MODEL_SIZE

    scene = rodsim.load_scene("table1-50g", ["rods.catheter.nodes=1000"])
    model = rodsim.build_model(scene)
    assert model.n > LARGE_MODEL_SIZE
    cvode = rodsim.solve(scene, "cvode", model=model)
    static = rodsim.solve(scene, "static", model=model)
    assert cvode.success and static.success
    assert cvode.stats["finish_attempts"] == 1
    assert cvode.stats["finish_newton_iters"] <= at_most(6)
    assert np.abs(cvode.positions() - static.positions()).max() < 5e-9 * 0.12


def test_ida_finishes_a_large_model_through_the_frames_retraction():
    """Above LARGE_MODEL_SIZE free coordinates IDA's constrained Newton finish moves the
    model coordinates through the frames (rodsim/solvers/ida.py): on table1-50g at
    N = 1 000 the first finish succeeds after 17 steps (measured; with x + Δx three finishes
    and 85 steps), on static's equilibrium (3.8e-14 L measured)."""
    scene = rodsim.load_scene("table1-50g", ["rods.catheter.nodes=1000"])
    model = rodsim.build_model(scene)
    ida = rodsim.solve(scene, "ida", model=model)
    static = rodsim.solve(scene, "static", model=model)
    assert ida.success and static.success
    assert ida.stats["finish_attempts"] == 1 and ida.stats["steps"] <= at_most(17)
    assert np.abs(ida.positions() - static.positions()).max() < 5e-9 * 0.12


def test_paper_steps_a_large_model_from_the_last_state_through_the_frames():
    """Above LARGE_MODEL_SIZE the paper integrator's step solves start from the last state,
    step through the frames and stop on the correction too (rodsim/solvers/paper_euler.py):
    on table1-50g at N = 1 000, 8 steps and 22 Newton iterations (measured; 47 before),
    2.8e-8 L from static's equilibrium (8.9e-7 L before). At N = 20 000 the run used to
    fail at its second step."""
    scene = rodsim.load_scene("table1-50g", ["rods.catheter.nodes=1000"])
    model = rodsim.build_model(scene)
    paper = rodsim.solve(scene, "paper", model=model)
    static = rodsim.solve(scene, "static", model=model)
    assert paper.success and static.success
    assert paper.stats["newton_iters"] <= at_most(22)
    distance = np.linalg.norm(paper.positions() - static.positions(), axis=-1).max()
    assert distance < 2e-7 * 0.12


def test_a_finish_on_a_large_model_may_take_more_newton_iterations():
    """The finish's iteration budget (rodsim/solvers/pseudo_dynamics.py,
    LARGE_FINISH_ITERATIONS): the option on a shipped-size model, at least 60 above
    LARGE_MODEL_SIZE (table1-50g at N = 100 000 needed 34 from CVODE's first switch)."""
    from rodsim.solvers import integrator_named
    from rodsim.solvers.pseudo_dynamics import LARGE_FINISH_ITERATIONS

    small = rodsim.build_model("table1-50g")
    large = rodsim.build_model(rodsim.load_scene("table1-50g", ["rods.catheter.nodes=1000"]))
    for name in ("cvode", "ida"):
        cls = integrator_named(name)
        integrator = cls.for_scene(rodsim.load_scene("table1-50g"))
        assert integrator.finish_iterations(small) == integrator.options.newton_iterations == 20
        assert integrator.finish_iterations(large) == LARGE_FINISH_ITERATIONS >= 60


def test_cvode_finishes_a_barely_moved_large_model_from_rest(monkeypatch):
    """Above LARGE_MODEL_SIZE, CVODE's Newton finish from a state that moved less than
    FINISH_FROM_REST L from rest (a boundary layer at the tip, where the max-norm residual
    already passes the switch) starts at the rest state (rodsim/solvers/cvode.py): on
    table1-50g at N = 4 000 the switch comes with the tip moved ~1e-5 L, the finish starts
    at rest and lands on static's equilibrium. On a small model it starts where CVODE is."""
    from rodsim.solvers.base import LARGE_MODEL_SIZE
    from rodsim.solvers.cvode import Cvode

    starts: list[tuple[np.ndarray, np.ndarray]] = []
    finish_start = Cvode.finish_start

    def recorded(self, run, y):
        start = finish_start(self, run, y)
        starts.append((start, run.model.x0))
        return start

    monkeypatch.setattr(Cvode, "finish_start", recorded)
    for nodes, large in ((4000, True), (40, False)):
        scene = rodsim.load_scene("table1-50g", [f"rods.catheter.nodes={nodes}"])
        model = rodsim.build_model(scene)
        assert (model.n > LARGE_MODEL_SIZE) == large
        starts.clear()
        cvode = rodsim.solve(scene, "cvode", model=model)
        static = rodsim.solve(scene, "static", model=model)
        assert cvode.success and static.success
        assert len(starts) == cvode.stats["finish_attempts"] == 1
        start, rest = starts[0]
        assert np.array_equal(start, rest) == large
        assert np.abs(cvode.positions() - static.positions()).max() < 5e-9 * 0.12


def test_cvode_finishes_from_rest_at_its_first_attempt_only(monkeypatch):
    """A finish from rest that fails (forced here) is not repeated: CVODE integrates on and
    its next finish starts where CVODE is (rodsim/solvers/cvode.py, finish_start), however
    little it has moved (every state counts as barely moved here)."""
    import rodsim.solvers.cvode as cvode_module
    from rodsim.solvers.cvode import Cvode

    monkeypatch.setattr(cvode_module, "FINISH_FROM_REST", 10.0)

    starts: list[bool] = []
    finish_start, finish_newton = Cvode.finish_start, Cvode.finish_newton

    def recorded(self, run, y):
        start = finish_start(self, run, y)
        starts.append(bool(np.array_equal(start, run.model.x0)))
        return start

    def first_fails(self, run, state):
        if len(starts) == 1:
            return False, state, 0
        return finish_newton(self, run, state)

    monkeypatch.setattr(Cvode, "finish_start", recorded)
    monkeypatch.setattr(Cvode, "finish_newton", first_fails)
    scene = rodsim.load_scene("table1-50g", ["rods.catheter.nodes=4000"])
    cvode = rodsim.solve(scene, "cvode")
    assert cvode.success, cvode.message
    assert cvode.stats["finish_attempts"] == len(starts) >= 2
    assert starts[0] and not any(starts[1:])
