"""Model.evaluate remembers its last evaluation: the same numbers, no stale ones."""

from __future__ import annotations

import numpy as np

import rodsim
from rodsim.core.model import Model


def _counting(model: Model) -> list[tuple[bool, bool]]:
    calls: list[tuple[bool, bool]] = []
    evaluate = model._evaluate

    def counted(x, load, force, jacobian):
        calls.append((force, jacobian))
        return evaluate(x, load, force, jacobian)

    model._evaluate = counted
    return calls


def test_the_same_state_is_evaluated_once_with_the_same_numbers():
    model = Model(rodsim.load_scene("tdcr-two-segment"))
    fresh = Model(rodsim.load_scene("tdcr-two-segment"))
    calls = _counting(model)
    x = model.x0 + 1e-4 * np.random.default_rng(2).normal(size=model.n)
    f = model.force(x)
    j = model.jacobian_data(x)
    assert calls == [(True, False), (False, True)]
    again_f, again_j = model.force(x.copy()), model.jacobian_data(x)
    assert len(calls) == 2  # both remembered
    assert np.array_equal(again_f, f) and np.array_equal(again_j, j)
    assert np.array_equal(f, fresh.force(x)) and np.array_equal(j, fresh.jacobian_data(x))
    again_f[:] = 0.0  # a copy: the caller may write into it
    assert np.array_equal(model.force(x), f)


def test_another_state_load_or_model_is_evaluated_afresh():
    scene = rodsim.load_scene("tdcr-two-segment")
    model = Model(scene)
    calls = _counting(model)
    x = model.x0 + 1e-4 * np.random.default_rng(4).normal(size=model.n)
    f = model.force(x)
    y = x.copy()
    y[5] += 1e-6
    assert not np.array_equal(model.force(y), f)
    half = model.force(y, 0.5)
    assert len(calls) == 3
    assert not np.array_equal(half, model.force(y))
    # A derived model (a copy with other penalty scales) does not see this one's memo.
    del model._evaluate  # (the counting wrapper would be copied with it)
    lowered = model.with_term_scales({2: 0.5})
    assert lowered._memo == []
    assert np.array_equal(lowered.force(y), Model(scene).with_term_scales({2: 0.5}).force(y))
    assert not np.array_equal(lowered.force(y), model.force(y))


def test_the_state_before_a_rejected_trial_is_still_remembered():
    """Two states are remembered: F at x, a trial y (a line search's, rejected), then x's
    checks: no evaluation at x again."""
    model = Model(rodsim.load_scene("tdcr-two-segment"))
    calls = _counting(model)
    x = model.x0 + 1e-4 * np.random.default_rng(6).normal(size=model.n)
    f = model.force(x)
    model.force(x + 1e-5)
    assert np.array_equal(model.force(x), f)
    assert len(calls) == 2


def test_loads_at_load_fraction_zero_are_skipped_with_the_same_numbers():
    """F(x, 0) (the correction residual's load-free force) skips the loads' kernels (scale
    0): the same numbers as the numpy path, which evaluates them times 0."""
    scene = rodsim.load_scene("tdcr-two-segment")
    compiled, reference = Model(scene), Model(scene, kernels="numpy")
    x = compiled.x0 + 1e-4 * np.random.default_rng(9).normal(size=compiled.n)
    unloaded = compiled.force(x, 0.0)
    assert np.allclose(unloaded, reference.force(x, 0.0), rtol=0.0,
                       atol=1e-12 * np.abs(unloaded).max())
    assert not np.allclose(unloaded, compiled.force(x, 1.0), rtol=0.0,
                           atol=1e-6 * np.abs(unloaded).max())


def test_a_large_jacobian_reuses_only_an_array_no_one_holds(monkeypatch):
    """From REUSE_ENTRIES on, a Jacobian is accumulated into the last one's array once no
    one refers to it (rodsim/core/model_evaluation.py, _jacobian_zeros): a held Jacobian is never
    written over, and a reused array holds exactly the Jacobian (zeroed first)."""
    import rodsim.core.model_evaluation as model_module

    model = Model(rodsim.load_scene("table1-50g", ["nodes=40"]))
    rng = np.random.default_rng(5)
    states = [model.x0 + 1e-3 * rng.normal(size=model.n) for _ in range(3)]
    expected = [model._evaluate(x, 1.0, False, True)[1] for x in states]  # fresh arrays
    monkeypatch.setattr(model_module, "REUSE_ENTRIES", 10)

    def address(a: np.ndarray) -> int:
        return a.__array_interface__["data"][0]

    held = model._evaluate(states[0], 1.0, False, True)[1]
    other = model._evaluate(states[1], 1.0, False, True)[1]
    assert not np.shares_memory(held, other)  # ``held`` is in use: a fresh array
    assert np.array_equal(held, expected[0]) and np.array_equal(other, expected[1])
    where = address(other)
    del other  # dropped: the next evaluation writes into its array
    again = model._evaluate(states[2], 1.0, False, True)[1]
    assert address(again) == where
    assert np.array_equal(again, expected[2])
    assert np.array_equal(held, expected[0])


def test_f_and_j_asked_where_f_is_remembered_evaluate_j_alone():
    """F remembered, F and J asked together (a continuation step's start, whose F the
    predictor's check made): J alone is evaluated, and both are the numbers a fresh model
    gives in one pass."""
    model = Model(rodsim.load_scene("tdcr-two-segment"))
    fresh = Model(rodsim.load_scene("tdcr-two-segment"))
    calls = _counting(model)
    x = model.x0 + 1e-4 * np.random.default_rng(3).normal(size=model.n)
    f = model.force(x)
    both_f, both_j = model.evaluate(x)
    assert calls == [(True, False), (False, True)]
    one_f, one_j = fresh.evaluate(x)
    assert np.array_equal(both_f, f) and np.array_equal(both_f, one_f)
    assert np.array_equal(both_j, one_j)
    assert np.array_equal(model.jacobian_data(x), one_j) and len(calls) == 2
