"""Fixed-step physical time with outputs between step ends (docs/dynamics.md, "Outputs
between steps"; rodsim/solvers/physical/dense_output.py): the outputs force no step, their
positions are as accurate as the scheme's own states, and their energy balance is the
step ends' — checked against runs of the same scheme at forty times finer steps, and
against the same run with an output at every step."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_simulate import STEEL, first_frequency, vibration_energy, wire
from test_simulate_friction import CYCLE, TENSION
from test_simulate_friction import _scene as friction_catheter
from user_robots import KINDS, user_rod

import rodsim
from rodsim.io.archive_schema import ArchiveSchemaError, check_archive
from rodsim.solvers.physical.trajectory import step_plan


def test_step_plan_lays_out_equal_steps_and_the_outputs_each_makes():
    outputs = [0.0, 0.05, 0.1, 0.15]
    between = list(step_plan(outputs, 0.04, between=True))
    assert [round(t1 - t0, 12) for t0, t1, _ in between] == [0.0375] * 4
    assert [due for _, _, due in between] == [[], [0.05], [0.1], [0.15]]
    reached = list(step_plan(outputs, 0.04))
    assert len(reached) == 6  # two steps between consecutive outputs
    assert [due for _, t1, due in reached if due] == [[0.05], [0.1], [0.15]]
    assert all(due == [t1] for _, t1, due in reached if due)
    many = list(step_plan(list(np.arange(11) * 0.01), 0.1, between=True))
    assert len(many) == 1 and many[0][2] == list(np.arange(1, 11) * 0.01)


def _runs(rod: dict, nodes: int, force: float, per_step: int, per_output: int,
          integrator: str = "midpoint", periods: float = 2.0):
    """(outputs between steps, its reference, an output every step, its reference): the
    release from a tip force ``force`` [N], steps of T/``per_step``, outputs every
    T/``per_output``; each reference the same scheme at 40 times finer steps."""
    period = 2.0 * math.pi / first_frequency(rod)
    scene = wire(nodes, rod)
    initial = {"tip_load.force": [0.0, -force, 0.0]}

    def run(step: float, output: float) -> rodsim.app.simulate.Simulation:
        result = rodsim.simulate(scene, periods * period, step=step, output_dt=output,
                                 initial=initial, integrator=integrator)
        assert result.success, result.message
        return result

    between = period / per_output
    every = period / per_step
    return (run(every, between), run(between / 40, between), run(every, every),
            run(every / 40, every))


def _tip_error(run, reference) -> float:
    assert np.allclose(run.times, reference.times, rtol=0.0, atol=1e-12)
    return float(np.max(np.abs(run.positions[:, -1, 1] - reference.positions[:, -1, 1])))


@pytest.mark.parametrize("integrator", ["midpoint", "midpoint4"])
def test_outputs_between_steps_cost_no_step_and_no_accuracy(integrator):
    """The steel rod released from 0.1 N (N = 11) at 25 steps and 20 outputs a period: 50
    steps over two periods (80 before: each output ended a step); the tip at the outputs as
    far from the fine-step reference as the steps' own ends are from theirs (measured
    1.006× midpoint, 1.023× midpoint4); the energy balance that of the step ends
    (measured 2.3e-6 and 8.7e-7 of the vibration's energy)."""
    between, reference, every, every_reference = _runs(STEEL, 11, 0.1, 25, 20, integrator)
    assert len(between.times) == 41
    assert between.steps == every.steps < 80  # the same steps as an output every step
    # output k at kT/20 ends a step (jT/25) where k/20 = j/25: every fourth; the others are
    # read off an interpolant, and say so
    assert np.array_equal(between.interpolated, np.arange(41) % 4 != 0)
    assert len(every.interpolated) == len(every.times) and not every.interpolated.any()
    assert _tip_error(between, reference) <= 1.1 * _tip_error(every, every_reference)
    energy = vibration_energy(every)
    assert np.max(np.abs(between.energy_error)) <= 1.0001 * np.max(np.abs(every.energy_error))
    assert np.max(np.abs(between.energy_error)) < 1e-5 * energy


@pytest.mark.parametrize("seed", range(len(KINDS)))
def test_a_family_of_user_robots_with_outputs_between_steps(seed):
    """A steel and a nitinol wire and a soft polymer catheter (seeded, as a user writes
    them), N = 21, 30 steps and 7 outputs a period: the outputs' tip error within the
    steps' own (measured 0.42–0.79 of it), the balance within the step ends'."""
    rng = np.random.default_rng(100 + seed)
    rod = user_rod(rng, KINDS[seed])
    stiffness = rod["youngs_modulus"] * math.pi * rod["radius"] ** 4 / 4.0
    force = float(rng.uniform(0.08, 0.15)) * stiffness / rod["length"] ** 2
    between, reference, every, every_reference = _runs(rod, 21, force, 30, 7)
    assert between.steps == every.steps
    assert _tip_error(between, reference) <= 1.1 * _tip_error(every, every_reference)
    assert np.max(np.abs(between.energy_error)) <= 1.0001 * np.max(np.abs(every.energy_error))


def test_friction_keeps_a_step_end_at_every_output():
    """Friction's history is read at the outputs: its fixed steps still end on each (2 ms
    steps, 5 ms outputs: three steps an output), the friction state kept at every one."""
    cycle = rodsim.Sinusoid(1.25, 20.0, phase=-0.5 * np.pi, offset=1.75)
    run = rodsim.simulate(friction_catheter(0.2), 0.05, output_dt=0.005, step=2e-3,
                          initial={TENSION: CYCLE[0]}, program={TENSION: cycle})
    assert run.success, run.message
    assert run.friction is not None and run.friction.tension.shape[0] == len(run.times) == 11
    assert len(run.interpolated) == 11 and not run.interpolated.any()
    assert np.all(np.isfinite(run.friction.tension))


def test_the_archive_says_which_outputs_were_interpolated():
    """The trajectory archive's ``interpolated(time)``: 1 where the output was read off
    its step's interpolant, as the run says (fixed steps of 1 ms, outputs every 1.5 ms:
    every other output between step ends; IDA's outputs inside its steps, its start and
    end its own states); a value other than 0 or 1 is refused by the archive check."""
    fixed = rodsim.simulate("table1-50g", 0.012, output_dt=0.0015, step=0.001)
    assert fixed.success, fixed.message
    assert np.array_equal(fixed.interpolated, np.arange(len(fixed.times)) % 2 == 1)
    ds = fixed.to_xarray()
    assert np.array_equal(ds["interpolated"].values, fixed.interpolated.astype(np.int8))
    check_archive(ds)
    ida = rodsim.simulate("table1-50g", 0.012, output_dt=0.002, integrator="ida")
    assert ida.success, ida.message
    assert not ida.interpolated[0] and not ida.interpolated[-1]
    assert ida.interpolated[1:-1].all()  # IDA's steps grow far past 2 ms here
    ds["interpolated"].values[1] = 2
    with pytest.raises(ArchiveSchemaError, match="interpolated"):
        check_archive(ds)
