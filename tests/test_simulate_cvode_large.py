"""CVODE on a large rod (rodsim.simulate(integrator="cvode"); docs/dynamics.md, "CVODE"):
the banded, mass-scaled Newton matrix with GMRES (rodsim/solvers/physical/ode_newton.py)
against the dense Newton matrix it replaces, against IDA and the implicit midpoint rule at
fine steps, and the first natural frequency against Euler–Bernoulli. Scenes as a user
writes them from docs/."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_simulate import BETA_1, RELEASE, STEEL, crossings, first_frequency, modal, wire

import rodsim
import rodsim.solvers.physical.ida_run as ida_run
from rodsim.solvers.physical import ode_newton

PERIOD = 2.0 * math.pi / first_frequency(STEEL)
LENGTH = STEEL["length"]


def test_size_rule():
    """Dense up to DENSE_LIMIT unknowns (a small rod's run unchanged), banded above; by size
    alone. The steel rod at N = 21 has 260 unknowns, at N = 81 1040."""
    assert ode_newton.linear_solver(260) == "dense"
    assert ode_newton.linear_solver(ode_newton.DENSE_LIMIT) == "dense"
    assert ode_newton.linear_solver(ode_newton.DENSE_LIMIT + 1) == "band_gmres"
    assert ode_newton.linear_solver(1040) == "band_gmres"


def test_banded_solve_inverts_the_dense_newton_matrix(monkeypatch):
    """At N = 41 (520 unknowns: banded) every preconditioner solve z of CVODE's first steps
    satisfies (I − γ J) z = r with J the dense Jacobian of the explicit form (ode.py's own
    assembly, M_r⁻¹ applied densely) to 1e-8 of |r| (measured 3.1e-11: the round-off of a
    stiff matrix; a wrong one misses by O(1)): the band LU of S − γ H solves the very matrix
    CVODE's Newton iteration works on."""
    residuals: list[float] = []

    class Checked(ode_newton.BandedNewton):
        def setup(self, t: float, y: np.ndarray) -> None:
            super().setup(t, y)
            self.at = (t, y.copy())

        def solve(self, rhs: np.ndarray, out: np.ndarray) -> None:
            super().solve(rhs, out)
            if len(residuals) < 20:
                t, y = self.at
                dense = self.ode.jacobian(t, y[self.place])[np.ix_(self.order, self.order)]
                newton = np.eye(len(rhs)) - self.gamma * dense
                residuals.append(float(np.linalg.norm(newton @ out - rhs)
                                       / np.linalg.norm(rhs)))

    monkeypatch.setattr(ida_run, "BandedNewton", Checked)
    run = rodsim.simulate(wire(41), PERIOD / 10, integrator="cvode", output_dt=PERIOD / 20,
                          initial=RELEASE)
    assert run.success, run.message
    assert len(residuals) == 20
    assert max(residuals) < 1e-8, max(residuals)


@pytest.mark.slow
def test_large_rod_agrees_with_ida_and_the_midpoint_rule():
    """N = 81, one period after the release, the tip at 20 output times: CVODE (banded) at
    rtol = atol = 1e-5 within 1e-4 L of IDA at the same tolerance and of the midpoint rule
    at 1600 steps a period (whose phase error (ωh)²/12 moves the tip by about 1e-7 L; IDA
    at 1e-7 would take over 200 000 steps here: it resolves the highest bending modes). IDA
    and the midpoint rule agree within 1e-4 L themselves. Measured: CVODE 4.0e-5 L from
    the midpoint rule and 1.9e-5 L from IDA, IDA 2.1e-5 L from the midpoint rule."""
    options = {"output_dt": PERIOD / 20, "initial": RELEASE}
    scene = wire(81)
    cvode = rodsim.simulate(scene, PERIOD, integrator="cvode", rtol=1e-5, atol=1e-5,
                            max_order=2, **options)
    ida = rodsim.simulate(scene, PERIOD, integrator="ida", rtol=1e-5, atol=1e-5,
                          max_order=2, **options)
    midpoint = rodsim.simulate(scene, PERIOD, step=PERIOD / 1600, **options)
    for run in (cvode, ida, midpoint):
        assert run.success, run.message

    def distance(a: rodsim.app.simulate.Simulation, b: rodsim.app.simulate.Simulation
                 ) -> float:
        return float(np.max(np.abs(a.positions[:, -1] - b.positions[:, -1]))) / LENGTH

    assert distance(ida, midpoint) < 1e-4, distance(ida, midpoint)
    assert distance(cvode, midpoint) < 1e-4, distance(cvode, midpoint)
    assert distance(cvode, ida) < 1e-4, distance(cvode, ida)
    assert np.max(np.abs(np.linalg.norm(cvode.quaternions, axis=2) - 1.0)) < 1e-14


@pytest.mark.slow
def test_first_frequency_against_euler_bernoulli():
    """A free vibration of the steel rod at N = 81 with CVODE (banded), released from a 0.1 N
    tip force, three periods at rtol = atol = 1e-5: the first mode's period from the zero
    crossings of its modal coordinate within 1e-3 of Euler–Bernoulli's, β₁L = 1.87510
    (the N = 81 discretisation alone is −7.1e-5 in frequency, docs/dynamics.md). Measured
    1.6e-4 long, 8.8e-5 of it from rodsim.modes' discrete period (BDF 2's phase error)."""
    assert abs(BETA_1 - 1.87510) < 1e-5
    run = rodsim.simulate(wire(81), 3.0 * PERIOD, integrator="cvode", rtol=1e-5, atol=1e-5,
                          max_order=2, output_dt=PERIOD / 100, initial=RELEASE)
    assert run.success, run.message
    zeros = crossings(run.times, modal(run))
    measured = 2.0 * (zeros[-1] - zeros[0]) / (len(zeros) - 1)
    assert len(zeros) >= 5
    assert abs(measured / PERIOD - 1.0) < 1e-3, measured / PERIOD - 1.0
