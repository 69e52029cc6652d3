"""Results read well in a notebook (issue 36): ``repr`` of a Result, Track, Fit and Reach is
a summary of at most ten lines (a dataclass's own repr printed every array: 23 500
characters), ``_repr_html_`` the same rows as a table, and ``dir(rodsim)`` lists the entry
points that are imported on first use."""

from __future__ import annotations

import html
import re

import numpy as np
import pytest

import rodsim
from rodsim.app.inverse.fit import Points
from rodsim.solvers.summary import MAX_LINES, SKETCH_SIZE, sketch_svg, summary_html


def check(obj, *expected: str) -> None:
    text = repr(obj)
    lines = text.splitlines()
    assert 3 <= len(lines) <= MAX_LINES, text
    assert max(len(line) for line in lines) <= 120, text
    page = obj._repr_html_()
    table = page[page.index("<table>"):page.index("</table>") + len("</table>")]
    assert page == table or page.endswith(f"{table}{sketch_of(page)}</div>"), page[:200]
    for item in expected:
        assert item in text, (item, text)
        assert html.escape(item) in page, item


def sketch_of(page: str) -> str:
    """The inline SVG sketch of an HTML summary ("" when there is none)."""
    found = re.search(r"<svg .*</svg>", page, re.DOTALL)
    return found[0] if found else ""


def sketched(page: str) -> tuple[str, list[np.ndarray], list[np.ndarray], list[np.ndarray],
                                 Scale]:
    """The sketch's plane ("x–y", …), its solid and dashed polylines' points and its marks
    [px], and its scale [px/m] read from its scale bar and the bar's label (to the bar's
    0.05 px over its length: ``Scale``)."""
    svg = sketch_of(page)
    assert svg.startswith("<svg xmlns='http://www.w3.org/2000/svg'"), svg[:80]
    solid, dashed = [], []
    for points, style in re.findall(r"<polyline points='([^']*)' fill='none' ([^/]*)/>", svg):
        xy = np.array([[float(v) for v in p.split(",")] for p in points.split()])
        (dashed if "dasharray" in style else solid).append(xy)
    marks = [np.array([float(x), float(y)])
             for x, y in re.findall(r"<circle cx='([^']*)' cy='([^']*)'", svg)]
    x1, x2 = (float(v) for v in re.search(r"<line x1='([^']*)' y1='[^']*' x2='([^']*)'",
                                          svg).groups())
    value, unit = re.search(r">([0-9.]+) (mm|m)</text>", svg).groups()
    metres = float(value) * (1e-3 if unit == "mm" else 1.0)
    plane = re.search(r"<title>shape in (.–.)</title>", svg)[1]
    return plane, solid, dashed, marks, Scale((x2 - x1) / metres, x2 - x1)


class Scale(float):
    """Pixels a metre, read from a scale bar ``bar`` px long written to 0.05 px."""

    def __new__(cls, value: float, bar: float):
        out = super().__new__(cls, value)
        out.bar = bar
        return out


def check_drawn(drawn_px: np.ndarray, points: np.ndarray, plane: str, scale: Scale) -> None:
    """The sketch's points [px] are ``points`` (n, 3) [m] in ``plane`` at ``scale``, up the
    page (moved as a whole: the margin), to the 0.05 px the SVG is written to and the scale
    bar's own rounding over the distance from the first point."""
    a, b = ("xyz".index(plane[0]), "xyz".index(plane[2]))
    expected = np.stack([points[:, a] * scale, -points[:, b] * scale], axis=1)
    offset = drawn_px[0] - expected[0]
    reach = float(np.max(np.abs(expected - expected[0])))
    np.testing.assert_allclose(drawn_px, expected + offset, rtol=0,
                               atol=0.11 + 0.1 / scale.bar * reach)


def test_the_sketch_draws_a_known_shape_to_scale_in_its_plane():
    """A quarter circle of radius 50 mm in x–z, a dashed straight path along y, two marks:
    the plane is the two axes the shape extends most along, x and z; one scale for both;
    the scale bar a round length of at most a third of the width."""
    angle = np.linspace(0.0, np.pi / 2, 20)
    arc = np.stack([0.05 * np.sin(angle), np.zeros(20), 0.05 * (np.cos(angle) - 1)], axis=1)
    path = np.array([[0.0, 0.0, 0.0], [0.0, 0.01, 0.0]])
    page = summary_html("t", [("a", "b")], sketch_svg([arc], [path], [arc[[0, -1]]]))
    plane, solid, dashed, marks, scale = sketched(page)
    assert plane == "x–z" and len(solid) == 1 and len(dashed) == 1 and len(marks) == 2
    check_drawn(solid[0], arc, plane, scale)
    check_drawn(np.array(marks), arc[[0, -1]], plane, scale)
    width = float(re.search(r"width='([0-9.]+)'", sketch_of(page))[1])
    assert width <= SKETCH_SIZE[0] and 0.05 * scale <= SKETCH_SIZE[1]
    assert "20 mm" in page or "10 mm" in page  # at most a third of 50 mm
    assert sketch_svg([np.full((3, 3), np.nan)]) == "" and sketch_svg([]) == ""


def test_a_results_repr_is_short_and_names_its_tip():
    result = rodsim.solve("tdcr-two-segment")
    tip = result.tip("backbone")
    check(result, "tdcr-two-segment", "static", "stable", "backbone (61 nodes)",
          ", ".join(f"{1e3 * v:.4g}" for v in tip) + " mm")
    assert len(repr(result)) < 1000
    # the sketch: the backbone, to scale
    plane, solid, _, _, scale = sketched(result._repr_html_())
    assert plane == "x–z" and len(solid) == 1  # the tip: 29 mm in y, -41 mm in z
    check_drawn(solid[0], result.positions("backbone"), plane, scale)
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
    plane, solid, dashed, _, scale = sketched(track._repr_html_())
    check_drawn(solid[0], track.positions[-1], plane, scale)
    check_drawn(dashed[0], track.tips("wire"), plane, scale)
    truth = rodsim.solve(scene, "static", overrides=[f"tip_load.force=[0, {-1.5 * force}, 0]"])
    fit = rodsim.fit(scene, Points(truth.positions("wire")[1:], None), ["tip_load.force[1]"])
    check(fit, "fitted", "residual RMS", "tip_load.force[1] = ")
    reach = rodsim.reach(scene, truth.tip("wire"), ["tip_load.force[1]"])
    check(reach, "distance", "tip of wire", "target")
    plane, solid, _, marks, scale = sketched(fit._repr_html_())
    assert len(marks) == len(truth.positions("wire")) - 1
    drawn = np.concatenate([solid[0], np.array(marks)])
    check_drawn(drawn, np.concatenate([fit.result.positions("wire"),
                                       truth.positions("wire")[1:]]), plane, scale)
    plane, solid, _, marks, scale = sketched(reach._repr_html_())
    check_drawn(np.concatenate([solid[0], marks[0][None]]),
                np.concatenate([reach.result.positions("wire"), truth.tip("wire")[None]]),
                plane, scale)


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
    plane, solid, dashed, _, scale = sketched(run._repr_html_())
    check_drawn(solid[0], run.positions[-1], plane, scale)
    check_drawn(dashed[0], run.positions[:, 8], plane, scale)
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
    plane, solid, _, _, scale = sketched(modes._repr_html_())
    check_drawn(solid[0], modes.result.positions(), plane, scale)
    damped = rodsim.modes("table1-50g", 3, overrides=["nodes=9", "retardation_time=0.01"])
    assert np.all(damped.matched_damping_ratios > 0.0)
    check(damped, "damping ratios",
          ", ".join(f"{z:.3g}" for z in damped.matched_damping_ratios))
    failed = rodsim.modes("table1-50g", 3, overrides=[
        "nodes=8", "solver.static.max_newton=1", "solver.static.min_load_step=0.5"])
    assert not failed.success
    check(failed, "no modes", "FAILED: no equilibrium")
    assert sketch_of(failed._repr_html_()) == ""


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
