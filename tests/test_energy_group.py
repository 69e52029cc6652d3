"""The energies of a catheter's string tendons in one call (``energy_group``,
rodsim/core/kernels/tendon_string_energy.py) against the same tendons' own ``energy``
kernels called one by one and added in term order (bit for bit: the static line search's
merit must not move), against the numpy path (to round-off), with a slack tendon, a load
fraction and a penalty scaled down; and a group with friction (no energy) still refused."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.core.kernel_group import KernelGroup
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from tests.test_kernel_group import three_tendons


def one_call_each(model: Model, x: np.ndarray, load: float) -> float:
    """Σ scale × energy over the terms in order, each tendon by its own kernel call."""
    full, offsets = model.full(x), model.offsets(x)
    total = 0.0
    for index, term in enumerate(model.terms):
        call = model._kernel_calls[index]
        state = offsets if term.offsets else full
        value = (call.energy(state, *call.arguments) if call.energy is not None
                 else term.energy(state))
        total += model._scale(index, term, load) * value
    return total


@pytest.mark.parametrize("overrides", [[], ["tendons.s1b.tendon_string.tension=0.0"]])
def test_the_group_energy_is_the_sum_of_one_call_per_tendon(overrides, random_state):
    scene = rodsim.load_scene("tdcr-two-segment", overrides)
    model = Model(scene, "compiled")
    numpy = Model(scene, "numpy")
    model.energy(model.x0)
    units = model._energy_units()
    assert sum(isinstance(unit, KernelGroup) for unit in units) == 1  # the six tendons
    rng = np.random.default_rng(14)
    scaled = model.with_term_scales({2: 0.01})  # the centerline penalty lowered
    for _ in range(4):
        x = random_state(model, rng)
        for load in (1.0, 0.4):
            assert model.energy(x, load) == one_call_each(model, x, load)
            assert scaled.energy(x, load) == one_call_each(scaled, x, load)
            assert model.energy(x, load) == pytest.approx(numpy.energy(x, load), rel=1e-12)


def test_a_group_with_friction_has_no_energy():
    model = Model(Scene.from_dict(three_tendons((3.0, 2.0, 4.0))), "compiled")
    assert not any(isinstance(unit, KernelGroup) for unit in model._energy_units())
    with pytest.raises(ValueError, match="not conservative"):
        model.energy(model.x0)
