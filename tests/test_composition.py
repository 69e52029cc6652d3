"""The fourth-order composition of midpoint steps (integrator "midpoint4",
rodsim/solvers/physical/composition.py) against an independent reference: the midpoint rule
at 400 and 800 steps a period, Richardson-extrapolated (its h² term removed). Scenes as in
tests/test_simulate.py."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_simulate import RELEASE, STEEL, first_frequency, modal, vibration_energy, wire
from test_tendon_friction import catheter

import rodsim
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.solvers.physical.composition import SUZUKI


def test_fractions_make_a_symmetric_fourth_order_composition():
    """Σγ = 1 (consistent), Σγ³ = 0 (the h³ term cancels), palindromic (symmetric)."""
    assert math.isclose(sum(SUZUKI), 1.0, rel_tol=0, abs_tol=1e-15)
    assert abs(sum(g**3 for g in SUZUKI)) < 1e-15
    assert SUZUKI == SUZUKI[::-1]


def _first_mode(integrator: str, steps: int, period: float) -> float:
    """The first mode's coordinate half a period into a smooth release (the 0.1 N tip
    force ramped to zero over a period, as test_time_error_falls_at_second_order)."""
    run = rodsim.simulate(wire(11), 0.5 * period, step=period / steps,
                          output_dt=0.5 * period, initial=RELEASE, integrator=integrator,
                          program={"tip_load.force[1]": ([0.0, period], [-0.1, 0.0])})
    assert run.success, run.message
    return float(modal(run)[-1])


@pytest.mark.slow
def test_time_error_falls_at_fourth_order():
    """The first mode's coordinate at h = T/10 and T/20 (50 and 100 midpoint solves a
    period) against the midpoint rule's Richardson extrapolation from T/400 and T/800: the
    error falls as h⁴ or faster (measured 1.34e-7 and 7.7e-9 of a 6.3e-4 amplitude: order
    4.1), and at T/10 it is below a fifth of the midpoint rule's at T/40, which solves 40
    midpoint steps a period (measured 1.26e-6: 9.4×)."""
    period = 2.0 * math.pi / first_frequency(STEEL)
    coarse, fine = (_first_mode("midpoint", steps, period) for steps in (400, 800))
    reference = (4.0 * fine - coarse) / 3.0
    errors = [abs(_first_mode("midpoint4", steps, period) - reference) for steps in (10, 20)]
    assert math.log2(errors[0] / errors[1]) > 3.5, errors
    midpoint = abs(_first_mode("midpoint", 40, period) - reference)
    assert errors[0] < 0.2 * midpoint, (errors, midpoint)


@pytest.mark.slow
def test_undamped_energy_balance_is_bounded():
    """Ten periods of the released steel rod at 20 steps a period (100 midpoint solves):
    the energy balance T + V − (T₀ + V₀) stays below 1e-5 of the vibration's energy
    (measured 8.4e-7 over the first five periods, 2.6e-6 over the last five; at 10 steps a
    period 9.0e-5 and 8.8e-5). Each part is a midpoint step, whose potential work is the
    force's Gauss average along the part's path: the backward part's error does not cancel
    the forward ones', so the balance is looser than the midpoint rule's at as many solves
    (7.6e-8 and 1.4e-7 at 50 steps a period)."""
    period = 2.0 * math.pi / first_frequency(STEEL)
    run = rodsim.simulate(wire(21), 10.0 * period, step=period / 20, output_dt=period / 10,
                          initial=RELEASE, integrator="midpoint4")
    assert run.success, run.message
    energy = vibration_energy(run)
    assert energy > 0.0 and np.all(run.dissipated_energy == 0.0)
    assert np.max(np.abs(run.energy_error)) < 1e-5 * energy
    assert np.max(run.kinetic_energy) > 0.9 * energy  # it does vibrate


def test_tolerances_and_friction_are_refused():
    """Fixed steps only, without friction: one line before any work."""
    with pytest.raises(SceneError, match="fixed steps") as caught:
        rodsim.simulate(wire(5), 0.01, integrator="midpoint4", rtol=1e-5)
    assert "\n" not in str(caught.value)
    scene = Scene.from_dict(catheter(11, 0.2, 0.5))
    with pytest.raises(SceneError, match="allowed: integrator 'midpoint'") as caught:
        rodsim.simulate(scene, 0.01, integrator="midpoint4")
    assert "\n" not in str(caught.value)
