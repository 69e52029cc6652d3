"""The Jacobian pattern kept across re-registrations (Model._build_pattern): the sorted keys
of the diagonal and of the non-dynamic terms are reused and merged with the dynamic terms'
entries. Checked against the pattern a sort of every entry gives
(rodsim.core.sparsity.csc_pattern) for every shipped scene, at rest and after
re-registrations that move tendon points to other catheter segments."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.core.model import Model
from rodsim.core.scene import scene_paths
from rodsim.core.sparsity import csc_pattern


def _reference(model: Model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(indptr, indices, target of every element entry) from one sort of all entries."""
    n = model.n
    rows, cols = [np.arange(n)], [np.arange(n)]
    for term in model.terms:
        if not term.has_jacobian:
            continue
        k = term.dofs.shape[1]
        free = model._free_of[term.dofs]
        rows.append(np.repeat(free, k, axis=1).ravel())
        cols.append(np.tile(free, (1, k)).ravel())
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    keep = (rows < n) & (cols < n)
    pattern = csc_pattern(rows[keep], cols[keep], n)
    target = np.full(len(rows), pattern.nnz)
    target[keep] = pattern.target
    return pattern.matrix.indptr, pattern.matrix.indices, target[n:]


def _check(model: Model) -> None:
    indptr, indices, target = _reference(model)
    np.testing.assert_array_equal(model.pattern.indptr, indptr)
    np.testing.assert_array_equal(model.pattern.indices, indices)
    np.testing.assert_array_equal(model._jac_targets, target)
    assert model.nnz == len(indices)
    diagonal = model.pattern_rows[model._diagonal_slots]
    np.testing.assert_array_equal(diagonal, np.arange(model.n))
    np.testing.assert_array_equal(model.pattern_cols[model._diagonal_slots], np.arange(model.n))


@pytest.mark.parametrize("name", sorted(scene_paths()))
def test_the_pattern_is_that_of_all_entries_at_rest_and_after_reregistrations(name):
    model = Model(rodsim.load_scene(name))
    _check(model)
    if not model.has_registration:
        return
    rng = np.random.default_rng(3)
    moves = 0
    for scale in (1e-3, 3e-3, 1e-2):
        x = model.x0 + scale * model.length_scale * rng.standard_normal(model.n)
        moved = model.reregistered(x, exact=True)
        if moved is None:
            continue
        assert moved._fixed_pattern is model._fixed_pattern  # the fixed blocks kept
        _check(moved)
        fx, jx = moved.evaluate(x)
        assert np.all(np.isfinite(fx)) and np.all(np.isfinite(jx))
        model = moved
        moves += 1
    assert moves >= 1


@pytest.mark.parametrize("name", sorted(scene_paths()))
def test_the_rest_structure_the_band_order_is_chosen_from_is_the_pattern(name):
    """Model._order_for_band chooses the order of the free coordinates from
    Model._rest_structure (BᵀB of the elements' incidence, built before the index maps)
    instead of a first full pattern build: in the model's own order it is that pattern,
    index for index."""
    model = Model(rodsim.load_scene(name))
    structure = model._rest_structure()
    np.testing.assert_array_equal(structure.indptr, model.pattern.indptr)
    np.testing.assert_array_equal(structure.indices, model.pattern.indices)


@pytest.mark.parametrize("name", ["four-tendons", "table3-catheter1"])
def test_a_reregistered_model_keeps_the_unchanged_terms_calls_with_new_targets(name):
    """Model.with_terms keeps the kernel calls of the terms a re-registration left alone
    (their constants bound once) and gives them the new pattern's targets: its F and ∂F/∂x
    are those of the same registration built without any kept call, number for number; and
    its pattern, merged with the kept blocks of the dynamic terms left alone, is that of all
    entries."""
    model = Model(rodsim.load_scene(name))
    rng = np.random.default_rng(5)
    # The first tendon's points moved, so that the other tendons' registrations stay.
    first = next(term for term in model.terms if term.dynamic)
    points = model._free_of[first._points]
    points = points[points < model.n]
    for scale in (3e-3, 1e-2, 3e-2):
        x = model.x0.copy()
        x[points] += scale * model.length_scale * rng.standard_normal(points.size)
        model.evaluate(x)  # builds the calls a re-registration may keep
        moved = model.reregistered(x, exact=True)
        if moved is None:
            continue
        fresh = Model(rodsim.load_scene(name)).with_terms(moved.terms)
        f, j = moved.evaluate(x)
        f_fresh, j_fresh = fresh.evaluate(x)
        np.testing.assert_array_equal(f, f_fresh)
        np.testing.assert_array_equal(j, j_fresh)
        kept = [new.arguments is old.arguments for new, old in
                zip(moved._kernel_calls, model._kernel_calls, strict=True)]
        assert any(kept) and not all(kept)
        assert all(kept[k] == (moved.terms[k] is model.terms[k])
                   for k in range(len(kept)))
        # The pattern, with the blocks of the dynamic terms left alone kept.
        _check(moved)
        same = [(block is old, block.term is old.term) for block, old in
                zip(moved._dynamic_blocks, model._dynamic_blocks, strict=True)]
        assert all(a == b for a, b in same)
        assert same[0] == (False, False)
        assert len(same) == 1 or any(a for a, _ in same)
        return
    pytest.fail("no registration changed")
