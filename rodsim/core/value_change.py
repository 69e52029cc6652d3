"""The change of a model's force when only some scene values change, from the terms they
change alone (no model is built): what a sensitivity's difference of F in a parameter needs
(rodsim/app/inverse/sensitivity.py).

``Model.with_values`` builds the model of a scene that differs from a model's own only in
the options of some terms (a load, a tendon force, a penalty): it rebuilds those terms and
copies the rest, then recomputes the model's scales and, on the compiled path, its kernel
groups (a string tendon's group stacks every tendon's constants: 0.2 ms on
tdcr-two-segment). F(x) of that model minus F(x) of this one is the sum of the rebuilt
terms' forces minus their old ones: ``force_change`` evaluates those terms alone, each by
its own kernel (or its numpy reference off the compiled path), with this model's
continuation scales, which ``with_values`` keeps. The same numbers as the difference of the
two models' F to round-off (a sum in another order; tests/test_value_change.py).

``unit_forces``: where a term's force is its value times its force at value 1
(``Term.linear_unit``), the derivative in that value is the unit's force itself — no
second model, no difference.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rodsim.core.model import Model
    from rodsim.core.scene import Scene
    from rodsim.core.terms import Term

__all__ = ["force_change", "unit_forces"]


def force_change(model: Model, scene: Scene, x: np.ndarray,
                 made: tuple[list[Term], list[int]] | None = None) -> np.ndarray | None:
    """F(x) of ``model.with_values(scene)`` minus F(x) of ``model`` (free coordinates, at
    full load), from the terms whose options differ; None where ``with_values`` would fall
    back to ``with_scene`` (a base moved, a rod's own value: build that model). ``made``:
    ``model.terms_with_values(scene)``, if the caller has it."""
    made = made if made is not None else model.terms_with_values(scene)
    if made is None:
        return None
    terms, changed = made
    out = np.zeros(model.n + 1)
    if not changed:
        return out[:-1]
    full = model.full(x)
    offsets = model.offsets(x)
    compiled = model._compiled()
    if compiled and model._kernel_calls is None:
        model._kernel_calls = model._build_kernel_calls()
    for index in changed:
        old = model.terms[index]
        scale = model._scale(index, old, 1.0)
        if scale == 0.0:
            continue
        state = offsets if old.offsets else full
        if compiled:
            _add_compiled_force(model, index, terms[index], state, scale, out)
            _add_compiled_force(model, index, old, state, -scale, out)
            continue
        target = model._free_of[old.dofs.ravel()]
        difference = (terms[index].element_forces(state) - old.element_forces(state)).ravel()
        out += np.bincount(target, weights=scale * difference, minlength=model.n + 1)
    return out[:-1]


def unit_forces(model: Model, option: str, indices: list[int], x: np.ndarray
                ) -> np.ndarray | None:
    """∂F/∂c at ``x`` (free coordinates, at full load) for the terms ``indices`` of
    ``model`` whose force is c times their unit's (``Term.linear_unit``, c the value of
    their option ``option``, ``Term.linear_in``): the sum of the units' forces, each with
    its term's continuation scale, by the units' kernels (or their numpy reference off the
    compiled path). Exact but for the round-off of one evaluation, where a difference of F
    in c divides F's round-off by the step. None where a term is not so."""
    units = []
    for index in indices:
        term = model.terms[index]
        linear = term.linear_unit() if term.linear_in(option) else None
        if linear is None:
            return None
        units.append((index, linear[2]()))
    out = np.zeros(model.n + 1)
    full = model.full(x)
    offsets = model.offsets(x)
    compiled = model._compiled()
    if compiled and model._kernel_calls is None:
        model._kernel_calls = model._build_kernel_calls()
    for index, unit in units:
        scale = model._scale(index, model.terms[index], 1.0)
        if scale == 0.0:
            continue  # a term scaled away at full load: no force, no derivative
        state = offsets if unit.offsets else full
        if compiled:
            _add_compiled_force(model, index, unit, state, scale, out)
            continue
        target = model._free_of[unit.dofs.ravel()]
        out += np.bincount(target, weights=scale * unit.element_forces(state).ravel(),
                           minlength=model.n + 1)
    return out[:-1]


def _add_compiled_force(model: Model, index: int, term: Term, state: np.ndarray,
                        scale: float, out: np.ndarray) -> None:
    """``out`` (free coordinates and the dump slot) += ``scale`` times the force of
    ``term``, a term of the kind and elements of ``model``'s term ``index``, by that term's
    compiled kernel."""
    assert model._kernel_calls is not None
    call = model._kernel_calls[index]
    one = call if term is call.term else call.with_term(term)
    one.kernel.evaluate(state, *one.arguments, scale, True, out, one.force_target, False,
                        np.zeros(1), one.jacobian_target)
