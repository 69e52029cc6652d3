"""Results read well in a notebook (issue 36): ``repr`` of a Result, Track, Fit and Reach is
a summary of at most ten lines (a dataclass's own repr printed every array: 23 500
characters), ``_repr_html_`` the same rows as a table, and ``dir(rodsim)`` lists the entry
points that are imported on first use."""

from __future__ import annotations

import html

import numpy as np
import pytest

import rodsim
from rodsim.app.inverse.fit import Points
from rodsim.solvers.summary import MAX_LINES


def check(obj, *expected: str) -> None:
    text = repr(obj)
    lines = text.splitlines()
    assert 3 <= len(lines) <= MAX_LINES, text
    assert max(len(line) for line in lines) <= 120, text
    page = obj._repr_html_()
    assert page.startswith("<table>") and page.endswith("</table>")
    for item in expected:
        assert item in text, (item, text)
        assert html.escape(item) in page, item


def test_a_results_repr_is_short_and_names_its_tip():
    result = rodsim.solve("tdcr-two-segment")
    tip = result.tip("backbone")
    check(result, "tdcr-two-segment", "static", "stable", "backbone (61 nodes)",
          ", ".join(f"{1e3 * v:.4g}" for v in tip) + " mm")
    assert len(repr(result)) < 1000
    # the fields stay the dataclass's
    assert result.trajectory is None and isinstance(result.tension_profiles, dict)


def test_a_failed_results_repr_says_so():
    result = rodsim.solve("table1-50g", "static", overrides=[
        "nodes=8", "solver.static.max_newton=1", "solver.static.min_load_step=0.5"])
    assert not result.success
    check(result, "FAILED")


@pytest.mark.parametrize("seed", [0, 1])
def test_a_track_fit_and_reach_repr(seed):
    """A soft polymer cantilever and a steel-like one under mN to N tip forces."""
    rng = np.random.default_rng(seed)
    modulus = float(rng.choice([5e6, 2e11]))
    radius = 0.001 if modulus < 1e9 else 0.0003
    force = 0.01 * modulus * np.pi * radius**4 / 4 / 0.1**2
    scene = rodsim.load_scene({"name": f"rod{seed}", "rods": {"wire": {
        "length": 0.1, "radius": radius, "nodes": 9, "youngs_modulus": modulus,
        "density": 1100.0, "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
        "tip_load": {"mass": 0.0, "force": [0.0, -force, 0.0]}}}})
    forces = np.linspace(0.0, 2 * force, 4)
    track = rodsim.track(scene, {"tip_load.force[1]": -forces})
    assert track.success, track.message
    check(track, f"4 of {len(forces)} completed", "every step stable",
          ", ".join(f"{1e3 * v:.4g}" for v in track.tips("wire")[-1]) + " mm")
    truth = rodsim.solve(scene, "static", overrides=[f"tip_load.force=[0, {-1.5 * force}, 0]"])
    fit = rodsim.fit(scene, Points(truth.positions("wire")[1:], None), ["tip_load.force[1]"])
    check(fit, "fitted", "residual RMS", "tip_load.force[1] = ")
    reach = rodsim.reach(scene, truth.tip("wire"), ["tip_load.force[1]"])
    check(reach, "distance", "tip of wire", "target")


def test_dir_lists_the_lazy_entry_points():
    names = dir(rodsim)
    for entry in ("solve", "load_scene", "track", "fit", "reach", "run_dataset", "modes",
                  "penalty_error", "sensitivity", "build_model", "__version__"):
        assert entry in names, entry
        assert getattr(rodsim, entry) is not None


def test_a_simulations_repr_names_its_times_tip_programs_and_energy():
    """A 9-node cantilever let go from rest, its tip force programmed: the rows are the run's
    own numbers (outputs, the tip at the last output, the largest energy-balance error)."""
    from dataclasses import replace

    run = rodsim.simulate("table1-50g", 0.05, output_dt=0.01, overrides=["nodes=9"],
                          program={"tip_load.force[1]": ([0.0, 0.05], [0.0, -0.02])})
    assert run.success, run.message
    error = float(np.max(np.abs(run.energy_error)))
    check(run, "Simulation", "table1-50g", "midpoint", "6 outputs, t = 0 to 0.05 s",
          f"{run.steps} steps", "rest state", "tip_load.force[1]",
          ", ".join(f"{1e3 * v:.4g}" for v in run.positions[-1, 8]) + " mm",
          f"balance within {error:.2g} J")
    assert len(repr(run)) < 1000
    stopped = replace(run, success=False, message="stopped after t = 0.03 s")
    check(stopped, "FAILED: stopped after t = 0.03 s")


def test_a_modes_repr_names_its_frequencies_and_damping():
    """The 9-node cantilever's lowest modes, undamped and with Kelvin–Voigt damping, and a
    failed equilibrium."""
    modes = rodsim.modes("table1-50g", 3, overrides=["nodes=9"])
    assert modes.success, modes.message
    check(modes, "3 lowest modes", ", ".join(f"{f:.4g}" for f in modes.frequencies) + " Hz",
          ", ".join(f"{1e3 * v:.4g}" for v in modes.result.tip()) + " mm", "stable")
    assert "damping ratios" not in repr(modes)
    damped = rodsim.modes("table1-50g", 3, overrides=["nodes=9", "retardation_time=0.01"])
    assert np.all(damped.matched_damping_ratios > 0.0)
    check(damped, "damping ratios",
          ", ".join(f"{z:.3g}" for z in damped.matched_damping_ratios))
    failed = rodsim.modes("table1-50g", 3, overrides=[
        "nodes=8", "solver.static.max_newton=1", "solver.static.min_load_step=0.5"])
    assert not failed.success
    check(failed, "no modes", "FAILED: no equilibrium")


def test_a_results_to_xarray_is_its_run_archive(tmp_path, monkeypatch):
    """``result.to_xarray()`` is the archive ``rodsim.run_dataset`` makes (the same values
    and attributes, the creation time aside), and reads back as written; a Result whose
    entry points never handed the maker in says so in one line."""
    from rodsim.io.archive import read_dataset, write_dataset
    from rodsim.solvers import result as result_module

    result = rodsim.solve("tdcr-two-segment")
    ds = result.to_xarray()
    expected = rodsim.run_dataset(result)
    assert ds.equals(expected)
    stamped = {"history", "date_created"}
    assert {k: v for k, v in ds.attrs.items() if k not in stamped} == {
        k: v for k, v in expected.attrs.items() if k not in stamped}
    np.testing.assert_array_equal(ds["position"].values[ds["rod"].values == "backbone"],
                                  result.positions("backbone"))
    back = read_dataset(write_dataset(ds, tmp_path / "run.nc"))
    np.testing.assert_array_equal(back["position"].values, ds["position"].values)
    monkeypatch.setattr(result_module, "_ARCHIVE_MAKER", [])
    with pytest.raises(RuntimeError, match="rodsim.run_dataset") as missing:
        result.to_xarray()
    assert "\n" not in str(missing.value)
