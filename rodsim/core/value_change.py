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
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rodsim.core.model import Model
    from rodsim.core.scene import Scene
    from rodsim.core.terms import Term

__all__ = ["force_change"]


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
            assert model._kernel_calls is not None
            call = model._kernel_calls[index]
            for one, sign in ((call.with_term(terms[index]), 1.0), (call, -1.0)):
                one.kernel.evaluate(state, *one.arguments, sign * scale, True, out,
                                    one.force_target, False, np.zeros(1),
                                    one.jacobian_target)
            continue
        target = model._free_of[old.dofs.ravel()]
        difference = (terms[index].element_forces(state) - old.element_forces(state)).ravel()
        out += np.bincount(target, weights=scale * difference, minlength=model.n + 1)
    return out[:-1]
