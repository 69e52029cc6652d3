"""``rodsim plot --show LAYERS`` (issue 36): only the named layers are drawn, on the figure
of a run, track or trajectory, their movie and the html view, with --hide's layer names and
check (rodsim/app/figures/layers.py); what no layer holds (the panels, their axes and
limits, the title) is drawn as in the full figure.

Checked on the artists' and traces' names, not pixels, and against --hide: ``--show A,B``
draws exactly what ``--hide`` of every other layer draws.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

import rodsim
from rodsim.app.figures import PlotError, draw_figure, plot_dataset, style
from rodsim.app.figures.layers import LAYERS, layers_left_out
from rodsim.io.archive import read_dataset, write_dataset
from rodsim.io.run_dataset import run_dataset

#: Shipped scenes with the layers --show tendon,shape leaves out: table3-catheter1 (tendon
#: and its actuation load), tip-on-tissue (a tip moment, a plane obstacle, contact forces).
SCENES = ("table3-catheter1", "tip-on-tissue")
#: The gid prefixes of the layers --show tendon,shape keeps, and of those it leaves out
#: (the arrows' scale notes go with their arrows).
KEPT = ("rod:", "tendon:", "termination:", "disk:")
LEFT_OUT = ("load:", "contact:", "obstacle:", "scale:")


@pytest.fixture(scope="module", params=SCENES)
def shipped(request, tmp_path_factory):
    """The run archive of a shipped scene, written and read back as ``rodsim plot`` reads
    it (its path, its Dataset)."""
    result = rodsim.solve(request.param)
    assert result.success, result.message
    path = write_dataset(run_dataset(result),
                         tmp_path_factory.mktemp("show") / f"{request.param}.nc")
    return path, read_dataset(path)


def figure_of(ds, **options):
    """(every artist's gid, each panel's x and y limits) of ``ds``'s figure."""
    with style():
        figure = draw_figure(ds, **options)
        try:
            gids = {a.get_gid() for a in figure.findobj() if a.get_gid()}
            limits = [(ax.get_xlim(), ax.get_ylim()) for ax in figure.axes]
        finally:
            plt.close(figure)
    return gids, limits


def test_show_tendon_shape_draws_rods_and_tendons_only(shipped):
    _, ds = shipped
    every, frame = figure_of(ds)
    assert any(g.startswith("rod:") for g in every)
    assert any(g.startswith(("load:", "obstacle:")) for g in every)  # the scene has them
    gids, limits = figure_of(ds, show="tendon,shape")
    assert {g for g in every if g.startswith(KEPT)} == gids - {None}
    assert not any(g.startswith(LEFT_OUT) for g in gids)
    # the panels and their frame do not depend on the layers drawn
    np.testing.assert_array_equal(limits, frame)
    # the same as --hide of every other layer, and the order of the names is free
    assert gids == figure_of(ds, hide="load,contact,obstacle")[0]
    assert gids == figure_of(ds, show=["shape", "Tendon", ""])[0]


def test_each_layer_alone(shipped):
    """``--show X`` draws X's artists and no other layer's (rods: ``--show shape``)."""
    _, ds = shipped
    prefixes = {"shape": ("rod:",), "tendon": ("tendon:", "termination:", "disk:"),
                "load": ("load:", "scale:forces", "scale:moments"),
                "contact": ("contact:", "scale:contact"), "obstacle": ("obstacle:",)}
    assert set(prefixes) == set(LAYERS)
    every, _ = figure_of(ds)
    for layer, mine in prefixes.items():
        gids, _ = figure_of(ds, show=layer)
        assert gids == {g for g in every if g.startswith(mine)}, layer


def test_the_command_line_and_the_html_view(shipped, tmp_path, cli, capsys):
    path, ds = shipped
    assert cli(["plot", str(path), "--show", "tendon,shape", "--format", "svg", "-o",
                str(tmp_path / "shown")]) == 0
    assert "shown.svg" in capsys.readouterr().out
    svg = (tmp_path / "shown.svg").read_text(encoding="utf-8")
    assert 'id="rod:catheter"' in svg
    assert not any(f'id="{prefix}' in svg for prefix in LEFT_OUT)
    pytest.importorskip("plotly", reason="plotly is the optional extra rodsim[view3d]")
    from rodsim.app.figures.view3d import view_figure

    names = {t.name for t in view_figure(ds).data}
    assert names & {"loads", "contact forces"} or any("tissue" in n for n in names)
    shown = {t.name for t in view_figure(ds, hide=layers_left_out("tendon,shape")).data}
    assert "catheter" in shown and not shown & {"loads", "contact forces"}
    assert not any("tissue" in str(n) for n in shown)
    (html,) = plot_dataset(ds, tmp_path / "view", ["html"], show="shape", cdn=True)
    text = html.read_text(encoding="utf-8")
    assert '"name":"catheter"' in text and '"name":"loads"' not in text


def test_the_movie_gets_the_shown_layers(shipped, tmp_path, cli, capsys, monkeypatch):
    """``--movie`` with ``--show``: the movie is drawn with the layers --show leaves out
    (the archive's kind is set to a track's only to reach the movie; the writer is
    replaced, so nothing is drawn)."""
    import rodsim.app.figures.movie as movie

    path, _ = shipped
    seen = []

    def fake_check(ds, target=None, encoder=None):
        return encoder

    def fake_write(ds, target, colour, hide, encoder):
        seen.append(hide)
        return target

    monkeypatch.setattr(movie, "check_movie", fake_check)
    monkeypatch.setattr(movie, "write_movie", fake_write)
    assert cli(["plot", str(path), "--show", "tendon", "--movie-format", "gif",
                "-o", str(tmp_path / "m.gif")]) == 0
    assert seen == [frozenset(LAYERS) - {"tendon"}]
    assert "m.gif" in capsys.readouterr().out


@pytest.mark.parametrize("argv, words", [
    (["--show", "tendons"], ("'tendons'", ", ".join(LAYERS))),
    (["--show", "shape,rods"], ("'rods'", ", ".join(LAYERS))),
    (["--show", "tendon", "--hide", "load"], ("--show and --hide",)),
    (["--show", ","], ("names no layer", ", ".join(LAYERS))),
    (["--show", "tendon", "--hide", "lod"], ("'lod'",)),
])
def test_bad_requests_are_one_line_and_write_nothing(shipped, tmp_path, cli, capsys, argv,
                                                     words):
    path, _ = shipped
    out = tmp_path / "out"
    out.mkdir()
    assert cli(["plot", str(path), *argv, "-o", str(out / "fig"), "--movie"]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert all(w in err for w in words), err
    assert list(out.iterdir()) == [] and captured.out == ""


def test_the_python_calls_refuse_as_the_command_does(shipped):
    _, ds = shipped
    with pytest.raises(PlotError, match="layers: " + ", ".join(LAYERS)):
        draw_figure(ds, show="tendons")
    with pytest.raises(PlotError, match="--show and --hide"):
        draw_figure(ds, show=["shape"], hide=["load"])
    with pytest.raises(PlotError, match="names no layer"):
        layers_left_out(show=[])
    assert layers_left_out() == frozenset() and layers_left_out(None, "load") == {"load"}
    assert layers_left_out(",".join(LAYERS)) == frozenset()


def test_a_fit_or_study_refuses_show_by_name():
    """--show (even naming every layer) applies to a run's, track's or trajectory's figure
    only; the refusal names --show, not --hide."""
    import xarray as xr

    study = xr.Dataset(attrs={"study": "s"})
    with pytest.raises(PlotError, match=r"^--show applies to the figure of a run"):
        draw_figure(study, show=",".join(LAYERS))
