"""The error-controlled midpoint rule's step-size controller (rodsim/solvers/physical/
step_controller.py; docs/dynamics.md, "The midpoint rule under error control") and the
steps it leaves in the trajectory archive: the PI controller against the elementary one on
a seeded family of robots not shipped (steel wires under newton loads, soft polymer
catheters under millinewton loads), the archive's accepted and rejected steps against the
run's own counts and times, and a repeat bit for bit."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from test_simulate import first_frequency, wire

import rodsim
import rodsim.app.simulate as simulate_module
from rodsim.io.archive import read_dataset, write_dataset
from rodsim.solvers.physical.error_control import ErrorControl
from rodsim.solvers.physical.step_controller import SAFETY, StepController


def robot(seed: int) -> tuple[dict, float, dict | None]:
    """A rod of the family, its tip force [N] and its damping: even seeds a steel wire (L
    0.3–0.5 m, r 0.8–1.5 mm) under 0.2–2 N, undamped; odd seeds a soft polymer catheter (E
    10–50 MPa, L 0.1–0.2 m, r 1–1.5 mm) under 1–5 mN, Kelvin–Voigt τ = 1 ms."""
    rng = np.random.default_rng(3317 + seed)
    if seed % 2 == 0:
        rod = {"length": float(rng.uniform(0.3, 0.5)),
               "radius": float(rng.uniform(0.8e-3, 1.5e-3)), "youngs_modulus": 207e9,
               "density": 8000.0, "poisson_ratio": 0.3}
        return rod, float(rng.uniform(0.2, 2.0)), None
    rod = {"length": float(rng.uniform(0.1, 0.2)), "radius": float(rng.uniform(1e-3, 1.5e-3)),
           "youngs_modulus": float(rng.uniform(10e6, 50e6)),
           "density": float(rng.uniform(1100.0, 1200.0)), "poisson_ratio": 0.45}
    return rod, float(rng.uniform(1e-3, 5e-3)), {"retardation_time": 1e-3}


def released(seed: int, controller: str, monkeypatch, rtol: float = 1e-5):
    """The family's robot ``seed`` (N = 11) released from its tip force, one period, at
    ``rtol`` under ``controller``."""
    rod, force, damping = robot(seed)
    period = 2.0 * math.pi / first_frequency(rod)
    scene = wire(11, rod, **({"damping": damping} if damping else {}))
    monkeypatch.setattr(simulate_module, "ErrorControl",
                        functools.partial(ErrorControl, controller=controller))
    return rodsim.simulate(scene, period, rtol=rtol, output_dt=period / 20,
                           initial={"tip_load.force": [0.0, -force, 0.0]})


def test_the_controllers_factors():
    """Both aim at the same error per step: at err = SAFETY³ (the elementary factor's 1) a
    PI step after an equal err keeps h; the first step and a retry after a rejection use
    the elementary factor (≤ 1 after a rejection, 0.2 after a failed Newton); a falling
    err lets the PI controller grow the step more than a steady one."""
    target = SAFETY**3
    for kind in ("elementary", "pi"):
        steady = StepController(kind)
        assert steady.accepted(target) == pytest.approx(1.0, rel=1e-12)
        assert steady.accepted(target) == pytest.approx(1.0, rel=1e-12)
        assert steady.rejected(4.0) == pytest.approx(SAFETY / 4.0 ** (1.0 / 3.0))
        assert steady.rejected(math.inf) == 0.2
        assert steady.accepted(0.1) == pytest.approx(SAFETY / 0.1 ** (1.0 / 3.0))
    pi = StepController("pi")
    pi.accepted(0.4)
    falling = pi.accepted(0.2)
    pi = StepController("pi")
    pi.accepted(0.2)
    assert falling > pi.accepted(0.2) > 1.0


@pytest.mark.slow
def test_the_pi_controller_rejects_fewer_steps(monkeypatch):
    """Six robots of the family (three steel wires, three polymer catheters) released at
    rtol 1e-5: the PI controller's rejected attempts at most half the elementary one's over
    the family (measured 19 against 55), none of its runs with more than the elementary
    run's + 2 (measured + 1 at most), and its steps at most 1.6 × (measured 0.81–1.33 ×)."""
    counts = {"elementary": [], "pi": []}
    steps = {"elementary": [], "pi": []}
    for seed in range(6):
        for kind in counts:
            run = released(seed, kind, monkeypatch)
            assert run.success, run.message
            counts[kind].append(run.rejected)
            steps[kind].append(run.steps)
    assert sum(counts["pi"]) <= 0.5 * sum(counts["elementary"]), counts
    assert all(p <= e + 2 for p, e in zip(counts["pi"], counts["elementary"], strict=True)), counts
    assert all(p <= 1.6 * e for p, e in zip(steps["pi"], steps["elementary"], strict=True)), steps


def test_the_archive_holds_the_steps_accepted_and_rejected(monkeypatch, tmp_path):
    """A polymer catheter of the family whose release the elementary controller steps with
    rejections: the archive's accepted steps tile [0, t_end] (their lengths sum to t_end,
    each ends where the next starts), its rejected attempts are as many as the run counts,
    each at an accepted step's start and longer than the step accepted there; the archive
    reads back (its schema checks them) and ``rodsim plot`` draws it."""
    from rodsim.app.cli import main as cli

    run = released(1, "elementary", monkeypatch)
    assert run.success and run.rejected > 0, (run.message, run.rejected)
    path = tmp_path / "run.nc"
    write_dataset(run.to_xarray(), path)
    ds = read_dataset(path)
    ends, sizes = ds["step_end"].values, ds["step_size"].values
    assert ds.sizes["rejected"] == run.rejected == int(ds.attrs["stats_rejected"])
    assert ds.sizes["accepted"] == int(ds.attrs["stats_accepted"])
    assert ends[-1] == pytest.approx(run.t_end, rel=1e-12)
    assert math.fsum(sizes) == pytest.approx(run.t_end, rel=1e-12)
    starts = ends - sizes
    assert np.allclose(starts[1:], ends[:-1], rtol=0.0, atol=1e-12 * run.t_end)
    assert np.all(ds["rejected_error"].values > 1.0)
    for t, h in zip(ds["rejected_time"].values, ds["rejected_size"].values, strict=True):
        k = int(np.argmin(np.abs(starts - t)))
        assert abs(starts[k] - t) <= 1e-12 * run.t_end
        assert sizes[k] < h
    assert cli(["plot", str(path), "-o", str(tmp_path / "figure"), "--format", "png"]) == 0
    assert "step_end" not in rodsim.simulate(wire(5), 0.01, step=1e-3).to_xarray()


@pytest.mark.parametrize("kind", ["pi", pytest.param("elementary", marks=pytest.mark.slow)])
def test_a_run_with_rejections_repeats_bit_for_bit(kind, monkeypatch):
    """No choice depends on the clock: the same run with rejections twice gives the same
    steps, rejections and numbers (the PI controller, the default, every time; the
    elementary one with the slow tests)."""
    runs = [released(3, kind, monkeypatch) for _ in range(2)]
    assert runs[0].rejected == runs[1].rejected > 0  # measured 4 (PI), 20
    logs = [run.step_log for run in runs]
    assert logs[0] is not None and logs[1] is not None
    for name in ("ends", "sizes", "rejected_times", "rejected_sizes", "rejected_errors"):
        assert np.array_equal(getattr(logs[0], name), getattr(logs[1], name)), name
    assert np.array_equal(runs[0].positions, runs[1].positions)
    assert np.array_equal(runs[0].energy_error, runs[1].energy_error)
