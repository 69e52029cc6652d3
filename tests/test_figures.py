"""Figures that do not mislead (issue 22): an order fitted only where the error still falls,
3D runs in three projections, the interactive 3D view (plotly, optional), short labels with
units."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

import rodsim
from rodsim.app.figures import (
    PlotError,
    draw_figure,
    plot_dataset,
    short_key,
    study_errors,
    style,
    view3d,
)
from rodsim.io.archive import read_dataset, write_dataset
from rodsim.io.run_dataset import run_dataset


def test_the_order_is_fitted_only_where_the_error_still_falls():
    """An error ∝ K^-1 that levels off at a floor (Fig. 7A's shape): the order over the whole
    sweep was the plateau's average (0.25 on fig7a); fitted where it falls it is 1."""
    k = np.array([1e1, 3e1, 1e2, 3e2, 1e3, 1e4, 1e5, 1e6])
    error = np.where(k <= 1e3, 0.5 / k, 5e-4 * (1 + 1e-3 * np.log10(k)))
    order, fitted = study_errors._fitted_order(k, error)
    assert order == pytest.approx(1.0, rel=1e-9)
    np.testing.assert_array_equal(fitted, k <= 1e3)
    # An error that falls over the whole sweep is fitted over all of it, in any order of x.
    nodes = np.array([40.0, 5.0, 20.0, 10.0])
    order, fitted = study_errors._fitted_order(nodes, 3.0 * nodes ** -2.0)
    assert order == pytest.approx(2.0, rel=1e-9) and fitted.all()
    # No fall, no order (and never "nan" in a title: the result line says so).
    assert np.isnan(study_errors._fitted_order(k, np.full(k.shape, 1e-3))[0])


def _texts(figure) -> str:
    parts = [figure._suptitle.get_text() if figure._suptitle else ""]
    for axes in figure.axes:
        parts += [axes.get_title(), axes.get_xlabel(), axes.get_ylabel()]
    return "\n".join(parts)


@pytest.fixture(scope="module")
def bent_in_3d(tmp_path_factory):
    """four-tendons pulled by two neighbouring tendons: the tip leaves the x–y plane."""
    scene = rodsim.load_scene("four-tendons", ["tendon_py.tendon_actuation.force=1.5",
                                               "tendon_pz.tendon_actuation.force=0.8"])
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    path = write_dataset(run_dataset(result), tmp_path_factory.mktemp("3d") / "four.nc")
    return read_dataset(path), result


def test_a_3d_run_is_drawn_in_three_projections_with_its_tip_in_the_title(bent_in_3d):
    ds, result = bent_in_3d
    tip = result.tip("catheter")
    assert abs(tip[2]) > 1e-3  # a z the x–y view alone would hide
    with style():
        figure = draw_figure(ds)
        try:
            labels = [(a.get_xlabel(), a.get_ylabel()) for a in figure.axes]
            text = _texts(figure)
        finally:
            plt.close(figure)
    assert labels == [("x [m]", "y [m]"), ("x [m]", "z [m]"), ("y [m]", "z [m]")]
    assert f"{1e3 * tip[2]:.4g}" in text, text


def test_a_planar_run_keeps_one_view():
    ds = run_dataset(rodsim.solve("table1-50g", "static", overrides=["nodes=8"]))
    with style():
        figure = draw_figure(ds)
        try:
            assert len(figure.axes) == 1
        finally:
            plt.close(figure)


def test_the_interactive_3d_view(bent_in_3d, tmp_path, cli, capsys):
    """With plotly: `rodsim plot` of a 3D run adds stem.html with every rod; a study is
    refused. (Its absence is tested below.)"""
    pytest.importorskip("plotly", reason="plotly is the optional extra rodsim[view3d]")
    ds, _ = bent_in_3d
    archive = write_dataset(ds, tmp_path / "four.nc")
    assert cli(["plot", str(archive)]) == 0, capsys.readouterr().err
    assert "four.html" in capsys.readouterr().out
    page = (tmp_path / "four.html").read_text(encoding="utf-8")
    for rod in ("catheter", "tendon_py", "tendon_mz"):
        assert f'"name":"{rod}"' in page, rod
    assert '"type":"scatter3d"' in page and '"aspectmode":"manual"' in page
    planar = write_dataset(run_dataset(rodsim.solve("table1-50g", "static",
                                                    overrides=["nodes=8"])),
                           tmp_path / "planar.nc")
    assert cli(["plot", str(planar)]) == 0
    assert not (tmp_path / "planar.html").exists()  # nothing to see in 3D
    assert cli(["plot", str(planar), "--format", "html"]) == 0  # unless asked


def test_the_3d_view_loads_plotly_from_its_cdn_when_asked(bent_in_3d, tmp_path, cli, capsys):
    """`--cdn` writes the html view (even with other formats named) with a script tag for
    plotly's CDN instead of plotly's JavaScript: the same traces, a far smaller file."""
    pytest.importorskip("plotly", reason="plotly is the optional extra rodsim[view3d]")
    ds, _ = bent_in_3d
    archive = write_dataset(ds, tmp_path / "four.nc")
    assert cli(["plot", str(archive), "--format", "html", "-o", str(tmp_path / "full")]) == 0
    assert cli(["plot", str(archive), "--format", "png", "--cdn",
                "-o", str(tmp_path / "small")]) == 0, capsys.readouterr().err
    assert "small.html" in capsys.readouterr().out
    full = (tmp_path / "full.html").read_text(encoding="utf-8")
    small = (tmp_path / "small.html").read_text(encoding="utf-8")
    assert 'src="https://cdn.plot.ly/' in small and "cdn.plot.ly/plotly" not in full
    for rod in ("catheter", "tendon_py", "tendon_mz"):
        assert f'"name":"{rod}"' in small, rod
    assert len(small) < 0.1 * len(full), (len(small), len(full))


def test_without_plotly_html_is_a_one_line_error_and_the_rest_still_draws(
        bent_in_3d, tmp_path, monkeypatch, cli, capsys):
    monkeypatch.setattr(view3d, "available", lambda: False)
    ds, _ = bent_in_3d
    archive = write_dataset(ds, tmp_path / "four.nc")
    assert cli(["plot", str(archive)]) == 0
    assert not (tmp_path / "four.html").exists() and (tmp_path / "four.png").exists()
    assert cli(["plot", str(archive), "--format", "png,html"]) == 2
    err = capsys.readouterr().err
    assert "plotly" in err and "rodsim[view3d]" in err and "Traceback" not in err
    with pytest.raises(PlotError, match="plotly"):
        plot_dataset(ds, tmp_path / "again", ["html"])


def test_labels_are_short_and_carry_units(tmp_path, cli, capsys):
    assert short_key("tendons.tendon.tendon_actuation.force") == "force (tendon)"
    assert short_key("rods.catheter.tip_load.mass") == "mass (catheter)"
    output = tmp_path / "track.nc"
    assert cli(["track", "table1-50g", "--set", "nodes=8", "--ramp",
                "tip_load.mass=0:0.05:3", "-o", str(output)]) == 0, capsys.readouterr().err
    ds = read_dataset(output)
    with style():
        figure = draw_figure(ds)
        try:
            text = _texts(figure)
        finally:
            plt.close(figure)
    assert "mass (catheter) [kg]" in text and "rods.catheter" not in text
    # The title names the last step's tip, computed from the stored positions.
    tip_y = float(ds["position"].isel(step=-1).sel(node=ds["rod"] == "catheter")[-1, 1])
    assert "tip of catheter at mass (catheter) = 0.05 kg" in text
    assert f"{1e3 * tip_y:.4g}" in text


def test_a_centerlines_figure_of_many_points_gets_a_compact_legend(tmp_path):
    """A study of more than LEGEND_POINTS (12) points draws its centerlines with one legend
    entry per value of the colour sweep (the last one) and one per line style (the other
    sweep), not one per point. It raised AttributeError (the labels went to the labels
    module, not the list), found by mypy."""
    from rodsim.app.figures.study_centerlines import LEGEND_POINTS
    from rodsim.app.study import Study, Sweep
    from rodsim.app.study_runner import run_study

    masses = (0.005, 0.01, 0.02, 0.03, 0.04, 0.05, 0.07)
    study = Study(name="many_points", title="tip against N and mass", paper="tests only",
                  scene="table1-50g", integrator="static", reference="exact",
                  plot="centerlines",
                  sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (6, 11), "1", "N"),
                                    Sweep("mass", "rods.catheter.tip_load.mass", masses, "kg",
                                          "tip mass")]})
    ds = run_study(study, "small", tmp_path / "many.nc", workers=1)
    assert ds["status"].size == 14 > LEGEND_POINTS
    with style():
        figure = draw_figure(ds)
        try:
            legend = figure.axes[0].get_legend()
            texts = [text.get_text() for text in legend.get_texts()]
        finally:
            plt.close(figure)
    assert len(legend.legend_handles) == len(texts)
    for mass in masses:
        assert f"mass = {mass:g} kg" in texts
    assert "nodes = 6" in texts and "nodes = 11" in texts
    assert not any("nodes" in text and "mass" in text for text in texts)  # no point's own
