"""The figures of a trajectory (``rodsim simulate``) and of a modes archive (``rodsim
modes``) (issue 36): a trajectory's tip panel draws the tip's coordinates at every output
time and its energy panel the balance the result itself reports; a modes figure's panels
are the lowest modes, each titled with its frequency (the first against Euler–Bernoulli's
closed form) and drawn as the equilibrium ± the mode scaled to a tenth of the extent.
Every drawn line is read back from the figure."""

from __future__ import annotations

import math
import re

import matplotlib.pyplot as plt
import numpy as np
import pytest
from test_simulate import STEEL, first_frequency, wire

import rodsim
from rodsim.app.figures import draw_figure, style
from rodsim.app.figures.modes import AMPLITUDE
from rodsim.io.archive import read_dataset, write_dataset


def drawn_panels(ds) -> dict[tuple[str, str], list]:
    """Each panel of the figure of ``ds`` by its (x label, y label): its lines as
    (label, x data, y data), and its title."""
    with style():
        figure = draw_figure(ds)
        try:
            return {(ax.get_xlabel(), ax.get_ylabel()):
                    [ax.get_title(), [(line.get_label(), np.asarray(line.get_xdata(), float),
                                       np.asarray(line.get_ydata(), float))
                                      for line in ax.get_lines()]]
                    for ax in figure.axes if ax.get_xlabel()}
        finally:
            plt.close(figure)


@pytest.fixture(scope="module")
def release(tmp_path_factory):
    """The steel wire (N = 9) let go from rest under a programmed tip force, 6 outputs,
    and its archive written and read back."""
    run = rodsim.simulate(wire(9), 0.02, output_dt=0.004,
                          program={"tip_load.force[1]": ([0.0, 0.02], [0.0, -0.5])})
    assert run.success, run.message
    path = tmp_path_factory.mktemp("release") / "release.nc"
    return run, read_dataset(write_dataset(run.to_xarray(), path))


def test_a_trajectorys_tip_panel_draws_the_tip_at_every_output_time(release):
    run, ds = release
    panels = drawn_panels(ds)
    _, lines = panels[("t [s]", "tip of wire [m]")]
    assert [label for label, _, _ in lines] == ["x", "y", "z"]
    for axis, (_, t, value) in enumerate(lines):
        np.testing.assert_array_equal(t, run.times)
        np.testing.assert_array_equal(value, run.positions[:, 8, axis])
    assert run.positions[-1, 8, 1] < -1e-4  # pushed down: the panel shows a motion


def test_a_trajectorys_energy_panel_draws_the_balance_the_result_reports(release):
    """The balance line is T + V + D − W − (T₀ + V₀) of the archive, equal to the
    in-memory result's ``energy_error`` (to round-off: the archive stores what the run
    computed); the balance is small beside the work line (the programmed force's, which
    the kinetic and potential energies take up: the wire is undamped)."""
    run, ds = release
    _, lines = drawn_panels(ds)[("t [s]", "energy [J]")]
    by_label = {label: (t, value) for label, t, value in lines}
    assert set(by_label) == {"kinetic T", "potential V - V0", "dissipated D", "work W",
                             "balance T + V + D - W - (T0 + V0)"}
    t, balance = by_label["balance T + V + D - W - (T0 + V0)"]
    np.testing.assert_array_equal(t, run.times)
    np.testing.assert_allclose(balance, run.energy_error, rtol=0,
                               atol=1e-12 * float(np.max(np.abs(run.work))))
    np.testing.assert_array_equal(by_label["kinetic T"][1], run.kinetic_energy)
    np.testing.assert_array_equal(by_label["work W"][1], run.work)
    assert abs(run.work[-1]) > 1e-4 and np.max(np.abs(balance)) < 0.01 * abs(run.work[-1])


def test_a_modes_figure_draws_the_lowest_modes_titled_with_their_frequencies(tmp_path):
    """The steel wire (N = 21): four panels, mode k titled with the archive's frequency;
    the first within 2 % of Euler–Bernoulli's (β₁L)² √(EI/ρA)/(2π L²) (shear and rotary
    inertia lower it a little); in each panel the grey equilibrium and the equilibrium
    ± the mode shape scaled so that its largest displacement is AMPLITUDE × the extent."""
    modes = rodsim.modes(wire(21), 5)
    assert modes.success, modes.message
    ds = read_dataset(write_dataset(modes.to_xarray(), tmp_path / "modes.nc"))
    with style():
        figure = draw_figure(ds)
        try:
            axes = [ax for ax in figure.axes if ax.get_xlabel()]
            titles = [ax.get_title() for ax in axes]
            lines = [[(np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float))
                      for line in ax.get_lines()] for ax in axes]
        finally:
            plt.close(figure)
    assert len(axes) == 4
    frequencies = ds["frequency"].values
    for k, title in enumerate(titles):
        found = re.match(rf"mode {k + 1}: ([0-9.e+-]+) Hz", title)
        assert found, title
        assert float(found[1]) == pytest.approx(frequencies[k], rel=5e-4)
    euler_bernoulli = first_frequency(STEEL) / (2 * math.pi)
    assert float(re.match(r"mode 1: ([0-9.e+-]+)", titles[0])[1]) == pytest.approx(
        euler_bernoulli, rel=0.02)
    positions = ds["position"].values
    extent = float(np.max(np.ptp(positions, axis=0)))
    for k, panel in enumerate(lines):
        (gx, gy), (px, py), (mx, my) = panel
        np.testing.assert_array_equal(gx, positions[:, 0])  # along x, the longest extent
        plus = np.stack([px - gx, py - gy], axis=1)
        np.testing.assert_allclose(np.stack([gx - mx, gy - my], axis=1), plus, atol=1e-15)
        shape = ds["mode_position"].values[k]
        assert np.max(np.abs(plus)) <= AMPLITUDE * extent * (1 + 1e-12)
        # the drawn displacement is the mode's own, in the plane it moves most in
        moved = shape[:, [0, int(np.argmax(np.sum(shape[:, 1:] ** 2, axis=0))) + 1]]
        scale = AMPLITUDE * extent / float(np.max(np.abs(shape)))
        np.testing.assert_allclose(plus, scale * moved, atol=1e-12 * extent)
