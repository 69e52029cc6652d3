"""Smoke tests of every shipped study (studies/*.py) at its "small" size.

Parametrised over :func:`rodsim.app.study.available_studies`, so a new study file is covered
without new test code: each runs in this process (``workers=1``), and its Dataset must be
well-formed (one dimension per sweep with the declared coordinates, units and long names, no
failed point, errors exactly where a reference exists), re-open with plain
``xr.open_dataset`` and plot to PNG and PDF. A few cheap physics checks follow, on the same
runs (each study runs once per session). Every test that runs a study is marked ``slow``
(the file takes about 38 s of CPU, fig8_regime 8 of them): the README's command leaves
them out, .ci/run runs them.
"""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr
from matplotlib.text import Text

from rodsim.app.figures import draw_figure, plot_dataset, style
from rodsim.app.study import (
    STATUS,
    StudySpec,
    available_studies,
    grid_points,
    point_scene,
    rerun_study,
)
from rodsim.app.study_runner import run_study
from rodsim.core.analytic.reference import REFERENCE_KINDS, reference_centerline

STUDIES = available_studies()


@pytest.fixture(scope="session")
def small(tmp_path_factory):
    """``small(name)``: (archive path, Dataset) of the study's small run, run once."""
    cache: dict[str, tuple[Path, xr.Dataset]] = {}
    folder = tmp_path_factory.mktemp("studies")

    def run(name: str) -> tuple[Path, xr.Dataset]:
        if name not in cache:
            path = folder / f"{name}.nc"
            dataset = run_study(STUDIES[name], "small", path, workers=1)
            cache[name] = (path, dataset)
        return cache[name]

    return run


def _has_reference(spec: StudySpec, index: tuple[int, ...], sigma: np.ndarray) -> bool:
    scene = point_scene(spec, index)
    length = next(iter(scene.rods.values())).length
    return reference_centerline(scene, spec.reference, sigma * length) is not None


def test_the_paper_figures_are_all_declared():
    expected = {"fig6", "fig7a", "fig7b", "fig8", "fig9", "fig14", "fig15", "fig16", "fig17",
                "fig18", "fig22", "convergence", "gravity"}
    assert expected <= set(STUDIES), sorted(expected - set(STUDIES))
    for study in STUDIES.values():
        assert {"small", "full"} <= set(study.sweeps), study.name


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(STUDIES))
def test_small_study_runs_and_plots(name, small, tmp_path):
    study = STUDIES[name]
    path, ds = small(name)
    spec = StudySpec.from_json(ds.attrs["spec_json"])

    # One dimension per sweep, in order, with the declared coordinates.
    sweeps = study.sweeps["small"]
    assert ds["status"].dims == tuple(s.name for s in sweeps)
    for sweep in sweeps:
        coordinate = ds[sweep.name]
        assert coordinate.size == len(sweep.values), sweep.name
        expected = list(sweep.coordinate)
        if all(isinstance(v, (int, float)) for v in expected):
            np.testing.assert_allclose(coordinate.values.astype(float), expected, rtol=1e-12)
            assert coordinate.attrs["units"] == sweep.units
        else:  # named values ("corde", "on", "catheter 2"): text has no units
            assert [str(v) for v in coordinate.values] == [str(v) for v in expected]
        assert coordinate.attrs["long_name"] == sweep.long_name

    # Units and long names (docs/archive.md, "Study archives"): every variable and
    # coordinate has a long name; every numeric one units, the status flags included; text
    # (message, rod and axis names, named sweep values) none.
    for key, variable in ds.variables.items():
        assert variable.attrs.get("long_name"), f"{name}: {key} has no long_name"
        if np.issubdtype(variable.dtype, np.number):
            assert variable.attrs.get("units"), f"{name}: {key} has no units"
        else:
            assert variable.dtype.kind in "UO", f"{name}: {key} is {variable.dtype}"
            assert "units" not in variable.attrs, f"{name}: {key} is text and has units"

    # No failed point.
    assert ds.attrs["failed_points"] == 0, ds["message"].values
    assert np.all(ds["status"].values == STATUS["ok"])
    assert ds.attrs["points"] == len(grid_points(spec))

    # Errors: none without a reference, else finite exactly where the point has one.
    if study.reference is None:
        for key in ("tip_error", "area_error", "history_error"):
            assert key not in ds, f"{name} has no reference but stores {key}"
    elif study.reference == "last":
        tip_error, area_error = ds["tip_error"].values, ds["area_error"].values
        assert np.all(np.isfinite(tip_error)) and np.all(np.isfinite(area_error))
        assert np.all(ds["tip_error"].isel({sweeps[0].name: -1}).values == 0.0)
    else:
        assert study.reference in REFERENCE_KINDS
        tip_error, area_error = ds["tip_error"].values, ds["area_error"].values
        sigma = ds["sigma"].values
        has = np.zeros(ds["status"].shape, dtype=bool)
        for index in grid_points(spec):
            has[index] = _has_reference(spec, index, sigma)
        assert has.any(), f"{name}: no point has a {study.reference} reference"
        assert np.all(np.isfinite(tip_error[has])) and np.all(np.isfinite(area_error[has]))
        assert np.all(np.isnan(tip_error[~has])) and np.all(np.isnan(area_error[~has]))
        if study.history:
            first = ds["history_error"].isel(step=0).values
            assert np.all(np.isfinite(first))

    # The archive re-opens with plain xarray and is drawn from the Dataset alone.
    with xr.open_dataset(path) as reopened:
        reopened.load()
    assert set(reopened.data_vars) == set(ds.data_vars)
    np.testing.assert_allclose(reopened["tip"].values, ds["tip"].values, rtol=0.0, atol=0.0)
    assert reopened.attrs["study"] == name
    png, pdf = plot_dataset(reopened, tmp_path / name)
    assert png.read_bytes().startswith(b"\x89PNG\r\n\x1a\n") and png.stat().st_size > 5000
    assert pdf.read_bytes().startswith(b"%PDF") and pdf.stat().st_size > 1000


def _measured(ds: xr.Dataset) -> str:
    """The measured-result line of the study figure's title, drawn in rodsim's style; checks
    on the way that no text of the figure is smaller than 8 pt."""
    with style():
        figure = draw_figure(ds)
        try:
            figure.canvas.draw()  # creates the tick labels
            small_text = [(t.get_text(), t.get_fontsize()) for t in figure.findobj(Text)
                          if t.get_text() and t.get_fontsize() < 8.0]
            title = figure.get_suptitle()
        finally:
            plt.close(figure)
    assert not small_text, small_text
    head, _, result = " ".join(title.split()).partition("measured:")  # unwrapped
    result = result.replace(" ".join(ds.attrs.get("paper", "").split()), "").strip()
    assert ds.attrs["study"] in head and result, title
    return result


def _perturbed(ds: xr.Dataset) -> xr.Dataset:
    """The archive with every measured quantity changed: errors and tips doubled, one step
    fewer in every history."""
    out = ds.copy(deep=True)
    for key in ("tip_error", "area_error", "tip"):
        if key in out:
            out[key] = out[key] * 2.0
    if "history_error" in out:
        out["history_error"] = out["history_error"].shift(step=-1)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(STUDIES))
def test_small_study_figure_states_what_was_measured(name, small):
    """The title's measured line holds a number and follows the archive's data: it changes
    when the measured quantities do; no text is below 8 pt."""
    ds = small(name)[1]
    measured = _measured(ds)
    assert any(ch.isdigit() for ch in measured), measured
    assert _measured(_perturbed(ds)) != measured


# Physics on the small runs -------------------------------------------------------------------


def tip_y(ds: xr.Dataset) -> xr.DataArray:
    return ds["tip"].isel(rod=0).sel(axis="y")


@pytest.mark.slow
def test_fig6_cosserat_model_matches_the_elastica(small):
    ds = small("fig6")[1]
    assert float(ds["tip_error"].max()) < 2e-3  # paper: < 1 % of L for 20 and 50 g
    assert np.all(np.diff(tip_y(ds).values) < 0.0)  # a heavier mass deflects more


@pytest.mark.slow
def test_fig7_errors_fall_with_n_and_k_p(small):
    assert np.all(np.diff(small("fig7b")[1]["tip_error"].values) < 0.0)
    errors = small("fig7a")[1]["tip_error"].values
    assert np.all(np.diff(errors) < 0.0) and errors[-1] < 1e-3


@pytest.mark.slow
def test_fig8_every_damping_reaches_the_same_equilibrium(small):
    ds = small("fig8")[1]
    tips = ds["tip"].isel(rod=0).values.reshape(-1, 3)
    assert np.ptp(tips, axis=0).max() < 1e-8
    history = ds["history_error"].values.reshape(-1, ds.sizes["step"])
    final = np.array([row[np.isfinite(row)][-1] for row in history])  # padded with NaN
    np.testing.assert_allclose(final, ds["tip_error"].values.ravel(), rtol=1e-6)
    assert np.all(history[:, 0] > final)


@pytest.mark.slow
def test_fig8_regime_xi_0_9_comes_to_rest_first(small):
    """With the masses scaled to h² ω₁² = 0.003 (docs/design.md, erratum 12) the paper's ordering
    holds: ξ = 0.9 needs fewer steps to rest than 0.5 (overdamped) and 1.0 (only backward
    Euler's own damping), and all three reach the same equilibrium."""
    ds = small("fig8_regime")[1]
    steps = dict(zip(ds["xi"].values.tolist(), ds["steps"].values.ravel().tolist(),
                     strict=True))
    assert steps[0.9] < steps[0.5] and steps[0.9] < steps[1.0], steps
    tips = ds["tip"].isel(rod=0).values.reshape(-1, 3)
    assert np.ptp(tips, axis=0).max() < 1e-6 * float(np.abs(tips).max())


@pytest.mark.slow
def test_fig9_corde_deflects_far_less_than_corrected(small):
    ds = small("fig9")[1]
    corrected = np.abs(tip_y(ds).sel(stiffness="corrected").values)
    corde = np.abs(tip_y(ds).sel(stiffness="corde").values)
    assert np.all(corde < 1e-2 * corrected)
    assert float(ds["tip_error"].sel(stiffness="corrected").max()) < 3e-2  # paper: < 3 % L
    assert float(ds["tip_error"].sel(stiffness="corde").max()) > 0.1


@pytest.mark.slow
def test_fig14_15_control_points(small):
    errors = small("fig14")[1]["tip_error"].values
    assert np.all(np.diff(errors) < 0.0)  # converges as N_C = N_T grows
    assert float(small("fig15")[1]["tip_error"].max()) < 1e-3  # N_T barely matters


@pytest.mark.slow
def test_fig17_18_endpoint_constants(small):
    # More K_C -> more deflection (Fig. 17); more K_E -> less, in K_E >= 1100 (Fig. 18).
    assert np.all(np.diff(tip_y(small("fig17")[1]).values) > 0.0)
    assert np.all(np.diff(tip_y(small("fig18")[1]).values) < 0.0)


@pytest.mark.slow
def test_fig22_fits_bend_towards_the_lumen(small):
    ds = small("fig22")[1]
    assert np.all(tip_y(ds).values > 0.0)  # the lumen is on +y


@pytest.mark.slow
def test_gravity_on_deflects_more_than_off(small):
    ds = small("gravity")[1]
    off, on = tip_y(ds).sel(gravity="off").values, tip_y(ds).sel(gravity="on").values
    assert np.all(on < off)
    assert np.all(np.isfinite(ds["tip_error"].sel(gravity="off").values))


@pytest.mark.slow
def test_convergence_error_falls_with_n_and_k_l(small):
    """K_L is per unit tendon length, so the lumen's compliance error does not fall with N:
    at the small K_L it is a floor above the discretisation error, which falls with N at
    the large one."""
    errors = small("convergence")[1]["tip_error"].isel(K_P=0)  # dims (nodes, K_L)
    assert np.all(errors.isel(K_L=-1).diff("nodes").values < 0.0)
    assert np.all(errors.diff("K_L").values < 0.0)


@pytest.mark.slow
def test_a_study_without_reference_reruns(small):
    """fig16 stores no errors (no reference): `rerun` of one of its points still works."""
    ds = small("fig16")[1]
    assert "tip_error" not in ds
    first = float(ds["K_L"].values[0])
    records, largest = rerun_study(ds, {"K_L": first})
    assert [r["status"] for r in records] == [STATUS["ok"]]
    assert largest < 1e-9 * 0.16  # L = 0.16 m: the CLI's default tolerance


# Figures that do not mislead (issue 22) -------------------------------------------------------


def _texts(figure) -> list[str]:
    texts = [figure._suptitle.get_text()] if figure._suptitle else []
    for axes in figure.axes:
        texts += [axes.get_title(), axes.get_xlabel(), axes.get_ylabel(),
                  axes.yaxis.get_offset_text().get_text()]
        legend = axes.get_legend()
        if legend is not None:
            texts += [t.get_text() for t in legend.get_texts()]
    return texts


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(STUDIES))
def test_no_figure_text_reads_nan(name, small):
    """gravity's title read "gravity = on: nan %" (no exact reference with self-weight)."""
    import matplotlib.pyplot as plt

    with style():
        figure = draw_figure(small(name)[1])
        try:
            texts = _texts(figure)
        finally:
            plt.close(figure)
    bad = [t for t in texts if re.search(r"\bnan\b", t, re.IGNORECASE)]
    assert not bad, bad


@pytest.mark.slow
def test_fig16_tip_panel_shows_the_size_of_the_change(small):
    """Fig. 16's tip moves by a fraction of a µm over K_L: the panel drew it as a steep curve
    on an offset axis. Its y range now spans at least 1 % of L (the curve is flat), there is
    no offset, and the title gives the change, measured from the archive."""
    import matplotlib.pyplot as plt

    from rodsim.app.figures.study_centerlines import MIN_TIP_RANGE

    ds = small("fig16")[1]
    y = ds["tip"].isel(rod=0).sel(axis="y").values
    change = float(y.max() - y.min())
    length = 0.16  # table3-catheter1's catheter
    assert 0 < change < 1e-5 * length
    with style():
        figure = draw_figure(ds)
        try:
            tips = figure.axes[1]
            figure.canvas.draw()
            low, high = tips.get_ylim()
            assert high - low >= MIN_TIP_RANGE * length * (1 - 1e-9)
            assert tips.yaxis.get_offset_text().get_text() == ""
            assert f"{change * 1e6:.3g} µm" in tips.get_title()
        finally:
            plt.close(figure)
