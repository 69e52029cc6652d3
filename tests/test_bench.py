"""Smoke tests of the benchmarks (benchmarks/rodsim_bench, ``rodsim bench … --size small``):
well-formed outputs, and the ``bench`` command finding them in the checkout.

Timings are never asserted (shared machine); only that the archives re-open with the machine
description, that every successful run has a measured (finite) error and time, and that the
figure and the markdown table exist. The benchmarks whose smallest size takes more than
about a second of CPU are marked ``slow`` (the README's command leaves them out; .ci/run
runs them).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import rodsim
import rodsim.solvers
from rodsim.app import bench_locator
from rodsim_bench import (
    paper_regime,
    pyelastica,
    scaling,
    skip_work,
    stress,
    work_precision,
)

MACHINE_KEYS = ("machine_cpu", "machine_cores", "machine_platform", "machine_python",
                "machine_numpy", "machine_scipy", "machine_scikit_sundae", "machine_date",
                "machine_git_commit", "machine_OMP_NUM_THREADS")


def _open(path) -> xr.Dataset:
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return ds.load()


def _check_common(paths, stem: str) -> xr.Dataset:
    names = {p.name for p in paths}
    assert {f"{stem}.nc", f"{stem}.png", f"{stem}.md"} <= names
    for path in paths:
        assert path.exists() and path.stat().st_size > 0
    png = next(p for p in paths if p.suffix == ".png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ds = _open(next(p for p in paths if p.suffix == ".nc"))
    for key in MACHINE_KEYS:
        assert key in ds.attrs and str(ds.attrs[key]), key
    for name, variable in ds.data_vars.items():
        assert "long_name" in variable.attrs, name
        if variable.dtype.kind == "f":
            assert "units" in variable.attrs, name
    return ds


@pytest.fixture(scope="module")
def work_precision_small(tmp_path_factory):
    output = tmp_path_factory.mktemp("work_precision")
    calls: list[tuple[float | None, str]] = []
    paths = work_precision.run("small", output, lambda f, s: calls.append((f, s)))
    return paths, calls


@pytest.mark.slow
def test_work_precision_small_outputs(work_precision_small):
    paths, calls = work_precision_small
    ds = _check_common(paths, "work-precision-small")
    assert ds.attrs["benchmark"] == "work-precision" and ds.attrs["size"] == "small"
    assert set(ds["scene"].values) == set(work_precision.SCENES)
    ok = ds["success"].values == 1
    assert ok.sum() >= 0.8 * ds.sizes["point"]
    for scene in work_precision.SCENES:
        assert (ok & (ds["scene"].values == scene)).any(), scene
    # Every successful run has a measured error and time; failures keep their message.
    assert np.all(np.isfinite(ds["error"].values[ok]))
    assert np.all(ds["error"].values[ok] >= 0)
    assert np.all(np.isfinite(ds["wall_time"].values[ok]) & (ds["wall_time"].values[ok] > 0))
    assert all(str(m) for m in ds["message"].values[~ok])
    # The errors are solver errors: at most a few τ (the scaled residual) over L here.
    tolerance = np.maximum(ds["tolerance"].values, ds["effective_tolerance"].values)
    assert np.all(ds["error"].values[ok] < 1e3 * tolerance[ok] + 1e-12)
    families = set(ds["family"].values[ok])
    assert {"static", "paper", "cvode", "ida", "scipy"} <= families
    # The static solve is the reference itself: error at round-off.
    static = ok & (ds["family"].values == "static")
    assert np.all(ds["error"].values[static] < 1e-12)
    # Progress: fractions in [0, 1] ending at 1, with a status line each time.
    fractions = [f for f, _ in calls if f is not None]
    assert fractions and all(0.0 <= f <= 1.0 for f in fractions) and fractions[-1] == 1.0
    assert all(isinstance(s, str) and s for _, s in calls)
    text = next(p for p in paths if p.suffix == ".md").read_text()
    assert "| scene |" in text and "Machine:" in text


@pytest.mark.slow
def test_scaling_small_outputs_via_cli(tmp_path, cli, capsys):
    assert cli(["bench", "scaling", "--size", "small", "-o", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    paths = sorted(tmp_path.glob("scaling-small.*"))
    assert all(str(p) in out for p in paths)
    ds = _check_common(paths, "scaling-small")
    assert ds.attrs["benchmark"] == "scaling" and ds.attrs["band_limit"] == 4000
    assert int(ds["nodes"].max()) >= 200
    success = ds["success"].values
    ran = np.isfinite(success)
    ok = success == 1
    assert ok[ran].mean() >= 0.8
    for config in ("static", "paper", "cvode", "ida"):  # every integrator at every N
        assert np.all(ds["success"].sel(config=config).values == 1), config
    assert np.all(np.isfinite(ds["wall_time"].values[ok]) & (ds["wall_time"].values[ok] > 0))
    assert np.all(np.isfinite(ds["peak_memory"].values[ok]))
    assert np.all(np.isfinite(ds["error"].values[ok]))
    assert np.all(ds["error"].values[ok] < 1e-3)  # same equilibrium as static
    assert np.all(ds["unknowns"].values > 0)
    # cvode/ida in "auto" mode report the linear solver they picked.
    assert set(ds["linear_solver"].sel(config="cvode").values) <= {"band", "sparse"}
    # The band solver's dense template shows in its memory at N = 200 (n ≈ 1400).
    # (In-process measure: a baseline process's resident size varies by a few MiB.)
    band = float(ds["solve_memory"].sel(config="cvode overdamped band", nodes=200))
    sparse = float(ds["solve_memory"].sel(config="cvode overdamped sparse", nodes=200))
    assert band > sparse + 5.0  # the template is n² × 8 B = 15 MiB here


@pytest.mark.slow
def test_paper_regime_small_outputs(tmp_path, cli, capsys):
    """`rodsim bench paper-regime --size small`: the files, every method in the table, every
    run successful, and the regime (M scaled to h² ω₁² = 0.003) taking more steps to rest
    than the same paper integrator with the physical masses (h² ω₁² ≈ 26)."""
    assert cli(["bench", "paper-regime", "--size", "small", "-o", str(tmp_path)]) == 0
    paths = sorted(tmp_path.glob("paper-regime-small.*"))
    out = capsys.readouterr().out
    assert paths and all(str(p) in out for p in paths)
    ds = _check_common(paths, "paper-regime-small")
    assert ds.attrs["benchmark"] == "paper-regime" and ds.attrs["size"] == "small"
    assert np.all(ds["success"].values == 1), ds["message"].values
    assert np.all(np.isfinite(ds["error"].values))
    assert np.all(np.isfinite(ds["wall_time"].values) & (ds["wall_time"].values > 0))
    text = (tmp_path / "paper-regime-small.md").read_text()
    methods, _ = paper_regime.methods_for("small")
    for method in methods:
        assert f"| {method.label} |" in text, method.label
    assert "Machine:" in text and "FAILED" not in text
    groups = ds["group"].values
    assert set(groups) == {"static", "paper regime", "paper physical M", "cvode"}
    regime = float(ds["steps"].values[groups == "paper regime"][0])
    physical = float(ds["steps"].values[groups == "paper physical M"][0])
    assert regime > 5 * physical, (regime, physical)
    assert float(ds["h2_omega2"].values[groups == "paper regime"][0]) == 0.003
    # Same equilibrium: M changes the path, not where the rod comes to rest.
    assert np.all(ds["error"].values < 1e-3)


def test_work_precision_runs_the_scipy_baseline_by_name():
    """The benchmark's scipy methods are the registered ``scipy`` integrator with options."""
    methods, _ = work_precision.methods_for("small", "table1-50g")
    scipy = [m for m in methods if m.family == "scipy"]
    assert {m.settings["method"] for m in scipy} == {"BDF", "LSODA"}
    assert all(m.solver == "scipy" for m in scipy)
    scene = rodsim.load_scene("table1-50g", ["nodes=10", *scipy[0].overrides()])
    options = rodsim.solvers.registered_integrators()["scipy"].options_of(scene)
    assert options.method == scipy[0].settings["method"]


def test_scipy_baseline_budget_is_a_failure_not_a_hang():
    result = rodsim.solve("table1-50g", "scipy", overrides=["nodes=10", "max_wall_time=1e-3"])
    assert not result.success and "wall-time budget" in result.message


def test_bench_command_finds_the_benchmarks_in_the_checkout():
    package = bench_locator.load_benchmarks()
    assert package.__name__ == "rodsim_bench" and "work-precision" in package.BENCHMARKS
    root = bench_locator.checkout_root()
    assert root is not None and bench_locator.default_output() == root / "benchmarks" / "results"
    import sys

    import rodsim.app.api  # noqa: F401  (the library, imported in full)
    library = [name for name, module in sys.modules.items()
               if name.startswith("rodsim.") and module is not None]
    assert library and not any("rodsim_bench" in name for name in library)


def test_bench_help_names_every_benchmark(cli, capsys):
    """The CLI cannot import the benchmarks (they are outside the package), so its help
    lists them by hand; this keeps that list equal to ``rodsim_bench.BENCHMARKS``."""
    with pytest.raises(SystemExit):
        cli(["bench", "--help"])
    # argparse may wrap a line after a name's hyphen ("force-from-\nshape")
    text = " ".join(capsys.readouterr().out.split()).replace("- ", "-")
    for name in bench_locator.load_benchmarks().BENCHMARKS:
        assert name in text, f"'rodsim bench --help' does not name {name!r}"


def test_bench_without_a_checkout_says_so(cli, capsys, monkeypatch, tmp_path):
    """An installed rodsim has no benchmarks (and no benchmarks/results): one clear line,
    no traceback."""
    import sys

    monkeypatch.setattr(bench_locator, "checkout_root", lambda: None)
    for name in [n for n in sys.modules if n == "rodsim_bench" or n.startswith("rodsim_bench.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if not p.endswith("benchmarks")])
    assert cli(["bench", "skip-work", "--size", "small", "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "not installed with rodsim" in err and "Traceback" not in err


def test_bench_commit_needs_a_checkout(cli, capsys, monkeypatch):
    monkeypatch.setattr(bench_locator, "default_output", lambda: None)
    assert cli(["bench", "skip-work", "--commit"]) == 2
    err = capsys.readouterr().err
    assert "-o/--output" in err and "Traceback" not in err


def test_bench_medium_size_only_where_a_benchmark_declares_it(cli, capsys, tmp_path,
                                                              recorded_bench):
    """``--size medium`` (the stress map's ~15-minute size) is refused in one line by a
    benchmark without it, before anything runs."""
    from rodsim_bench import stress

    assert "medium" in stress.SIZES
    assert cli(["bench", "skip-work", "--size", "medium", "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "no medium size" in err and "Traceback" not in err and not recorded_bench


@pytest.fixture
def recorded_bench(monkeypatch):
    """``rodsim bench skip-work`` with its ``run`` replaced by one that records its size and
    folder (what the command decides, without running a benchmark)."""
    from rodsim_bench import skip_work

    calls = []
    monkeypatch.setattr(skip_work, "run",
                        lambda size, output, progress: calls.append((size, output)) or [])
    return calls


def test_bench_defaults_to_the_small_size_outside_the_committed_results(
        cli, capsys, monkeypatch, tmp_path, recorded_bench):
    """Issue 22: `rodsim bench NAME` ran the full size and wrote into the checkout's
    committed benchmarks/results. Now: small, into runs/bench of the current folder; the
    help says so; --commit (and only it) writes to benchmarks/results."""
    monkeypatch.chdir(tmp_path)
    assert cli(["bench", "skip-work"]) == 0
    assert recorded_bench == [("small", bench_locator.DEFAULT_OUTPUT)]
    assert (tmp_path / "runs" / "bench").is_dir()
    assert cli(["bench", "skip-work", "--commit", "--size", "full"]) == 0
    assert recorded_bench[-1] == ("full", bench_locator.default_output())
    assert cli(["bench", "skip-work", "--commit", "-o", str(tmp_path)]) == 2
    capsys.readouterr()
    with pytest.raises(SystemExit):
        cli(["bench", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "small (the default)" in text and "runs/bench" in text


def test_bench_finds_the_checkout_pip_installed_from_or_the_current_folder(
        monkeypatch, tmp_path):
    """After a plain `pip install .` rodsim lives in site-packages: the checkout is the
    folder pip recorded (direct_url.json), else the current folder or a parent."""
    root = bench_locator.checkout_root()
    assert root is not None
    elsewhere = tmp_path / "site-packages" / "rodsim" / "app" / "bench_locator.py"
    monkeypatch.setattr(bench_locator, "__file__", str(elsewhere))
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(bench_locator, "_installed_from", lambda: root)
    assert bench_locator.checkout_root() == root
    monkeypatch.setattr(bench_locator, "_installed_from", lambda: None)
    assert bench_locator.checkout_root() is None
    monkeypatch.chdir(root / "docs")
    assert bench_locator.checkout_root() == root


def test_failed_jobs_are_recorded_with_their_message():
    jobs = [scaling.Job("time", 10, "no-such-integrator", max_wall_time=10.0, max_repeats=0)]
    results = scaling.run_jobs(jobs, 1, lambda job: 120.0, lambda f, s: None, lambda j: "x")
    assert not results[0]["ok"] and "no-such-integrator" in results[0]["error"]


@pytest.mark.slow
def test_stress_small_outputs(tmp_path):
    """The stress map's smoke version: every run is classified, none crashed, and none
    reported success with a non-finite result; every failure carries a diagnostic."""
    paths = stress.run("small", tmp_path)
    ds = _check_common(paths, "stress-small")
    outcome = ds["outcome"].values
    assert outcome.shape == (ds.sizes["config"], len(stress.INTEGRATORS))
    assert not np.any(outcome == stress.OUTCOMES.index("crash"))
    assert not np.any(outcome == stress.OUTCOMES.index("nan_success"))
    failed = outcome != stress.OUTCOMES.index("converged")
    assert all(str(m).strip() for m in ds["message"].values[failed])
    converged = ~failed
    assert np.all(np.isfinite(ds["tip_error"].values[converged]))


@pytest.mark.slow
def test_skip_work_small_outputs(tmp_path):
    paths = skip_work.run("small", tmp_path)
    assert {p.name for p in paths} == {"skip-work-small.nc", "skip-work-small.md"}
    assert {p.suffix for p in paths} == {".nc", ".md"}
    ds = _open(next(p for p in paths if p.suffix == ".nc"))
    for key in MACHINE_KEYS:
        assert key in ds.attrs, key
    rows = set(ds["row"].values)
    assert {"formulation", "Jacobian reuse", "planar reduction", "unlisted terms"} <= rows
    timed = ds["time_a"].values
    assert np.all(np.isfinite(timed) & (timed > 0))
    # rodsim's Newton with lagged Jacobian reuse converged (chord does not: the cap, NaN).
    reuse = ds["row"].values == "Jacobian reuse"
    assert reuse.sum() == 2
    lagged = reuse & (np.char.find(ds["compared"].values.astype(str), "lagged") >= 0)
    assert lagged.sum() == 1 and np.all(np.isfinite(ds["time_b"].values[lagged]))


@pytest.mark.slow
def test_kernels_small_outputs(tmp_path):
    """``rodsim bench kernels --size small``: both evaluation paths timed, every solve
    converged on the same equilibrium, compile and cache-load times measured."""
    from rodsim_bench import kernels

    paths = kernels.run("small", tmp_path, lambda fraction, status: None)
    assert {p.name for p in paths} == {"kernels-small.json", "kernels-small.md"}
    import json

    report = json.loads((tmp_path / "kernels-small.json").read_text())
    assert report["compile"]["first_compile_s"] > 0 and report["compile"]["cache_load_s"] > 0
    assert {row["kernels"] for row in report["evaluation_cost"]} == {"numpy", "compiled"}
    for row in report["solves"]:
        assert row["success"], row["message"]
        assert np.isfinite(row["best_s"]) and row["best_s"] > 0
        assert row["error_over_L"] < 1e-6
    assert report["cvode_profile"]
    (track,) = report["tracking"]
    assert track["success"] and track["steps"] == 21
    assert 0 < track["warm_step_mean_s"] < track["cold_solve_s"]


@pytest.mark.slow
def test_string_tendon_small_outputs(tmp_path):
    """``rodsim bench string-tendon --size small``: two cases of tdcr-two-segment solved,
    timed and scored against the Rucker–Webster reference within the scene's accuracy aim."""
    import json

    from rodsim_bench import string_tendon

    paths = string_tendon.run("small", tmp_path, lambda fraction, status: None)
    assert {p.name for p in paths} == {"string-tendon-small.json", "string-tendon-small.md"}
    report = json.loads((tmp_path / "string-tendon-small.json").read_text())
    assert len(report["cases"]) == 2
    for row in report["cases"]:
        solve = row["solves"]["static"]
        assert solve["success"] and solve["cpu_s"] > 0
        assert solve["error_over_L"] < 1e-4
    assert "| default" in (tmp_path / "string-tendon-small.md").read_text()


@pytest.mark.slow
def test_friction_small_outputs(tmp_path):
    """``rodsim bench friction --size small``: both scenes' cycles and static solves ran at
    μ = 0 and 0.3; the ramp goes up and back down; the frictionless solve's ratio is 1."""
    import json

    from rodsim_bench import friction

    values = friction.cycle(3.0, 35)
    assert len(values) == 35 and values[0] == values[-1] and values.max() == 3.0
    assert values[0] == pytest.approx(0.3) and np.all(np.diff(values)[:17] > 0)
    paths = friction.run("small", tmp_path, lambda fraction, status: None)
    assert {p.name for p in paths} == {"friction-small.json", "friction-small.md"}
    rows = json.loads((tmp_path / "friction-small.json").read_text())["rows"]
    assert {(r["scene"], r["friction"]) for r in rows} == {
        (name, mu) for name in friction.CASES for mu in (0.0, 0.3)}
    for row in rows:
        assert row["track_success"] and row["solve_success"] and row["steps_per_second"] > 0
        assert (row["solve_ratio"] == 1.0) == (row["friction"] == 0.0)
    assert "| tdcr-two-segment | 0.3 |" in (tmp_path / "friction-small.md").read_text()


# ------------------------------------------- figure titles state the measured result
RESULTS = Path(__file__).resolve().parents[1] / "benchmarks" / "results"


def _suptitle(draw, ds, tmp_path, monkeypatch) -> str:
    """The suptitle a bench figure is saved with."""
    from matplotlib.figure import Figure

    seen = []
    monkeypatch.setattr(Figure, "savefig",
                        lambda self, *a, **k: seen.append(self.get_suptitle()))
    draw(ds, tmp_path / "figure.png")
    assert len(seen) == 1
    return seen[0].replace("\n", " ")


def test_scaling_title_states_the_fitted_exponents(tmp_path, monkeypatch):
    ds = xr.load_dataset(RESULTS / "scaling-full.nc")
    text = scaling.measured_result(ds)
    assert text.replace("\n", " ") in _suptitle(scaling._plot, ds, tmp_path, monkeypatch)
    nodes = ds["nodes"].values.astype(float)
    upper = nodes >= nodes.max() / 40
    expected = np.polyfit(np.log(nodes[upper]),
                          np.log(ds["wall_time"].sel(config="cvode").values[upper]), 1)[0]
    assert f"cvode {expected:.2f}" in text, text
    # One more power of N in CVODE's times shows in its exponent and in its ratio to static.
    slower = ds.copy(deep=True)
    slower["wall_time"].loc[{"config": "cvode"}] = slower["wall_time"].sel(config="cvode") * (
        slower["nodes"] / slower["nodes"][0])
    changed = scaling.measured_result(slower)
    assert f"cvode {expected + 1:.2f}" in changed, changed
    assert changed != text


def test_work_precision_title_states_the_fastest_runs(tmp_path, monkeypatch):
    ds = xr.load_dataset(RESULTS / "work-precision-full.nc")
    text = work_precision.measured_result(ds)
    assert " ".join(text.split()) in " ".join(
        _suptitle(work_precision._plot, ds, tmp_path, monkeypatch).split())
    for scene in ("table1-50g", "table3-catheter1"):
        static, _ = work_precision.best_time(ds, scene, "static",
                                             work_precision.TITLE_ERROR)
        cvode, _ = work_precision.best_time(ds, scene, "cvode", work_precision.TITLE_ERROR)
        assert f"{scene}: static {1e3 * static:.3g} ms" in text, text
        assert f"cvode {cvode / static:.2g}×" in text, text
    # Twice the static times halve every ratio.
    slower = ds.copy(deep=True)
    static = (slower["family"] == "static").values
    slower["wall_time"].values[static] *= 2.0
    assert work_precision.measured_result(slower) != text


def test_paper_regime_title_states_the_measured_ratios(tmp_path, monkeypatch):
    ds = xr.load_dataset(RESULTS / "paper-regime-full.nc")
    text = paper_regime.measured_result(ds)
    assert " ".join(text.split()) in " ".join(
        _suptitle(paper_regime._plot, ds, tmp_path, monkeypatch).split())
    level = paper_regime.TITLE_ERROR
    assert paper_regime.title_level(ds) == level
    paper, k = paper_regime.best(ds, "paper regime", level)
    cvode, _ = paper_regime.best(ds, "cvode", level)
    assert k >= 0 and f"CVODE {paper / cvode:.3g}× faster" in text, text
    assert f"ξ = {float(ds['xi'].values[k]):g}" in text, text
    # Slower regime runs raise the ratio.
    slower = ds.copy(deep=True)
    slower["wall_time"].values[(slower["group"] == "paper regime").values] *= 2.0
    assert f"CVODE {2 * paper / cvode:.3g}× faster" in paper_regime.measured_result(slower)


def test_stress_title_states_the_share_converged(tmp_path, monkeypatch):
    ds = xr.load_dataset(RESULTS / "stress-full.nc")
    text = stress.measured_result(ds)
    assert text in _suptitle(stress._figure, ds, tmp_path, monkeypatch)
    refused = (ds["outcome"] == stress.OUTCOMES.index("refused")).any("integrator").values
    converged = (ds["outcome"].sel(integrator="cvode").values[~refused]
                 == stress.OUTCOMES.index("converged"))
    assert f"cvode {100 * converged.mean():.0f} %" in text, text
    assert f"of {int((~refused).sum())} configurations" in text
    # A crash shows in the title.
    crashed = ds.copy(deep=True)
    crashed["outcome"].values[np.flatnonzero(~refused)[0], 0] = stress.OUTCOMES.index("crash")
    assert "1 crashes" in stress.measured_result(crashed)


def test_pyelastica_benchmark_skips_without_pyelastica(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "elastica", None)  # `import elastica` raises ImportError
    messages = []
    assert pyelastica.run("small", tmp_path, lambda f, s: messages.append(s)) == []
    assert messages == [pyelastica.INSTALL_HINT]
    assert "pip install pyelastica==1.0.0" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_pyelastica_benchmark_matches_the_scene():
    rod = pyelastica.cantilever(rodsim.load_scene("table1-50g").data)
    assert rod.force == (0.0, -0.05 * 9.81, 0.0) and rod.nodes == 40
    numbers = pyelastica.pyelastica_settings(rod, pyelastica.Settings(40))
    assert numbers["elements"] == 39
    # PyElastica's shear stiffness alpha_c G A is rodsim's centerline penalty K_P.
    assert math.isclose(pyelastica.ALPHA_C * numbers["shear_modulus"] * rod.area, rod.penalty)
    assert math.isclose(numbers["dt"] * numbers["wave_speed"] / numbers["dl"], 0.5)
    assert math.isclose(numbers["damping"], 2.0 * rod.first_mode)
    assert 16.9 < rod.first_mode < 17.0  # 1.8751² sqrt(EI / (rho A L⁴)), rad/s
    with pytest.raises(ValueError, match="not the Table 1 cantilever"):
        pyelastica.cantilever(rodsim.load_scene("table3-catheter1").data)


def test_pyelastica_benchmark_errors_and_verdict():
    reference = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, -0.1, 0.0]])
    moved = reference + np.array([[0.0, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.01, 0.0]])
    assert np.allclose(pyelastica.node_errors(moved, reference, 2.0), (0.005, 0.01))
    assert np.isnan(pyelastica.node_errors(moved * np.nan, reference, 2.0)[0])
    stops = [{"threshold": t, "wall_s": 1.0, "tip_error": 1e-2, "max_error": 1e-2}
             for t in pyelastica.THRESHOLDS]
    row = {"settings": {"nodes": 40}, "stops": stops, "oracle": None}
    cvode = {"success": True, "wall_s": 0.01, "tip_error": 1e-4, "max_error": 1e-4}
    assert pyelastica.verdict(row, cvode)["holds"]
    assert not pyelastica.verdict(row, cvode | {"tip_error": 2e-3})["holds"]  # 5x the error
    assert not pyelastica.verdict(row, cvode | {"wall_s": 0.1})["holds"]  # 10x the time


@pytest.mark.slow
def test_startup_small_outputs(tmp_path):
    """``rodsim bench startup --size small``: every command has a positive CPU time, every
    phase a finite one, and the table is written."""
    from rodsim_bench import startup

    paths = startup.run("small", tmp_path)
    assert {p.name for p in paths} == {"startup-small.nc", "startup-small.md"}
    ds = _open(tmp_path / "startup-small.nc")
    for key in MACHINE_KEYS:
        assert key in ds.attrs
    assert list(ds["command"].values) == list(startup.COMMANDS)
    assert np.all(ds["cpu"].values > 0)
    assert np.all(np.isfinite(ds["phase_cpu"].values))
    assert "| run |" in (tmp_path / "startup-small.md").read_text()


@pytest.mark.slow
def test_tracking_small_outputs(tmp_path):
    """``rodsim bench tracking --size small``: both variants tracked on both scenes, their
    states equal to round-off, rates finite, the verdicts' CPU a part of the track's; the
    Tracker's floor a step positive and below its step."""
    from rodsim_bench import tracking

    paths = tracking.run("small", tmp_path)
    assert {p.name for p in paths} == {"tracking-small.nc", "tracking-small.md"}
    ds = _open(tmp_path / "tracking-small.nc")
    assert list(ds["variant"].values) == list(tracking.VARIANTS)
    assert list(ds["scene"].values) == [case[0] for case in tracking.CASES]
    assert np.all(np.isfinite(ds["steps_per_second"].values))
    assert np.all(ds["largest_state_difference"].values < 1e-12)
    cpu = ds["cpu"].values[:, 0].min(axis=-1)
    assert np.all((ds["verdict_cpu"].values > 0) & (ds["verdict_cpu"].values < cpu))
    step = ds["tracker_cpu"].values.min(axis=-1) / (tracking.SIZES["small"]["steps"] - 1)
    assert np.all((ds["tracker_floor"].values > 0) & (ds["tracker_floor"].values < step))


@pytest.mark.slow
def test_workers_small_outputs(tmp_path):
    """``rodsim bench workers --size small``: its study, local and dask, both worker counts
    ran, times positive."""
    from rodsim_bench import workers

    paths = workers.run("small", tmp_path)
    assert {p.name for p in paths} == {"workers-small.nc", "workers-small.md"}
    ds = _open(tmp_path / "workers-small.nc")
    assert list(ds["workers"].values) == list(workers.WORKERS)
    assert list(ds["runner"].values) == ["local", "dask"]
    assert list(ds["study"].values) == list(workers.SIZES["small"]["studies"])
    assert np.all(ds["wall"].values > 0) and np.all(ds["cpu"].values > 0)


@pytest.mark.slow
def test_batch_small_outputs(tmp_path):
    """``rodsim bench batch --size small``: 1 and 2 local workers ran every case, cold and
    warm, the same equilibria (bit for bit) as the other run of their kind; the cold ones
    as the cases solved alone (round-off), the warm ones within the equilibrium's
    round-off (tests/test_batch_warm.py)."""
    from rodsim_bench import batch

    paths = batch.run("small", tmp_path)
    assert {p.name for p in paths} == {"batch-small.nc", "batch-small.md"}
    ds = _open(tmp_path / "batch-small.nc")
    assert list(ds["runner"].values) == ["local-1", "local-2", "local-1-warm",
                                         "local-2-warm"]
    assert np.all(ds["failed_cases"].values == 0)
    assert np.all(ds["largest_difference"].values == 0.0)
    assert ds.attrs["largest_difference_from_alone"] <= 1e-12 * 0.4
    assert np.all(ds["difference_from_cold"].values <= 5e-9 * 0.4)
    assert ds.attrs["largest_warm_difference_from_alone"] <= 5e-9 * 0.4
    assert ds.attrs["cases_failed_alone"] == 0
    assert np.all(ds["equilibria_per_cpu_second"].values > 0)


def test_a_baseline_tree_runs_that_revisions_code(tmp_path):
    """``RODSIM_BENCH_BASELINE`` (benchmarks/rodsim_bench/baseline.py): the revision's tree is
    extracted and ``import rodsim`` in it is that tree's, not this checkout's."""
    from rodsim_bench.baseline import BaselineTree

    tree = BaselineTree("HEAD", tmp_path)
    done = tree.python(["-c", "import rodsim; print(rodsim.__file__)"])
    assert Path(done.stdout.strip()).is_relative_to(tmp_path / "tree")
    assert len(tree.commit) == 40
    with pytest.raises(RuntimeError, match="baseline"):
        tree.python(["-c", "raise SystemExit(3)"])


def test_floor_small_outputs(tmp_path):
    """``rodsim bench floor --size small``: each scene's solve counted (Newton's F, ∂F/∂x and
    linear solves present: a conservative scene's line search calls the energy), the raw
    costs positive and the floor below the solve it is a part of."""
    from rodsim_bench import floor

    paths = floor.run("small", tmp_path, lambda *_: None)
    assert {p.name for p in paths} == {"floor-small.json", "floor-small.md"}
    report = json.loads((tmp_path / "floor-small.json").read_text())
    assert {"cpu", "cores_available", "python", "git_commit"} <= set(report["machine"])
    for row in report["rows"]:
        jacobians = row["counts"].get("jacobian", 0) + row["counts"].get("jacobian_alone", 0)
        assert jacobians >= row["newton_iters"] > 0
        assert row["counts"]["linear"] >= row["newton_iters"]
        assert all(row["raw_s"][key] > 0 for key in ("force", "jacobian", "jacobian_alone",
                                                     "linear"))
        assert 0 < row["floor_s"] < row["solve_s"]
    assert "| four-tendons |" in (tmp_path / "floor-small.md").read_text()


def test_iterations_small_outputs(tmp_path):
    """``rodsim bench iterations --size small``: each case solved once, its counts those of
    the same solve made here (a count is deterministic in one process), and the cases the
    tests bound with tests/counts.py among the full size's."""
    import rodsim
    from rodsim_bench import iterations

    paths = iterations.run("small", tmp_path, lambda *_: None)
    assert {p.name for p in paths} == {"iterations-small.json", "iterations-small.md"}
    report = json.loads((tmp_path / "iterations-small.json").read_text())
    assert {"cpu", "numpy", "scipy", "git_commit"} <= set(report["machine"])
    first = report["cases"][0]
    again = rodsim.solve(first["scene"], first["integrator"], overrides=first["overrides"])
    assert first["success"] and first["newton_iters"] == again.stats["newton_iters"] > 0
    assert "table3-catheter3 static" in iterations.CASES
    assert f"| {first['case']} | yes | " in (tmp_path / "iterations-small.md").read_text()


@pytest.mark.slow
def test_dynamics_small_outputs(tmp_path):
    """``rodsim bench dynamics --size small``: the midpoint rule, the paper's Euler, the
    midpoint rule under error control and IDA timed against IDA's tight reference, each
    more accurate at its finer setting (no timing is asserted)."""
    from rodsim_bench import dynamics

    paths = dynamics.run("small", tmp_path, lambda *_: None)
    assert {p.name for p in paths} == {"dynamics-small.json", "dynamics-small.md"}
    rows = json.loads((tmp_path / "dynamics-small.json").read_text())["rows"]
    assert [row["integrator"] for row in rows] == ["midpoint", "midpoint", "paper", "paper",
                                                   "midpoint-ec", "midpoint-ec",
                                                   "ida", "ida"]
    assert all(row["success"] and row["cpu_s"] > 0.0 for row in rows)
    errors = [row["tip_error_over_L"] for row in rows]
    assert errors[1] < errors[0] and errors[3] < errors[2] and errors[7] < errors[6]
    assert errors[5] < errors[4]  # error control: the tighter rtol, the smaller error
    assert errors[2] > errors[0]  # first order against second, at the same step
    assert "| ida | rtol = atol = 1e-05 |" in (tmp_path / "dynamics-small.md").read_text()


def test_modes_small_outputs(tmp_path):
    """``rodsim bench modes --size small``: tdcr-two-segment's modes timed, its report
    written with the aim and positive frequencies (no timing is asserted)."""
    from rodsim_bench import modes

    paths = modes.run("small", tmp_path, lambda *_: None)
    assert {p.name for p in paths} == {"modes-small.json", "modes-small.md"}
    report = json.loads((tmp_path / "modes-small.json").read_text())
    (row,) = report["rows"]
    assert row["scene"] == "tdcr-two-segment" and row["symmetric"]
    assert row["modes_s"] > 0.0 and all(f > 0.0 for f in row["frequencies_hz"])
    assert "| tdcr-two-segment |" in (tmp_path / "modes-small.md").read_text()


@pytest.mark.slow
def test_step_cost_small_outputs(tmp_path):
    """``rodsim bench step-cost --size small``: every scene timed per step, its steps those
    of its step length (no timing is asserted)."""
    from rodsim_bench import step_cost

    paths = step_cost.run("small", tmp_path, lambda *_: None)
    assert {p.name for p in paths} == {"step-cost-small.json", "step-cost-small.md"}
    rows = json.loads((tmp_path / "step-cost-small.json").read_text())["rows"]
    assert [row["scene"] for row in rows] == list(step_cost.SCENES)
    assert [row["steps"] for row in rows] == [50, 50, 50, 100, 40]
    assert all(row["ms_per_step"] > 0.0 for row in rows)
    assert "| tdcr-two-segment, ramp | 40 |" in (tmp_path / "step-cost-small.md").read_text()


@pytest.mark.slow
def test_real_time_small_outputs(tmp_path):
    """``rodsim bench real-time --size small``: the reference (the fourth-order
    composition), the midpoint runs and the composition's (their step counts those of their
    fixed steps, five solves a composed step), the error-controlled midpoint runs and IDA's
    and CVODE's windows each give a row with a finite tip error; the floor's parts are
    positive and each fixed-step scheme has its solves at the aim (no timing is
    asserted)."""
    from rodsim_bench import real_time

    paths = real_time.run("small", tmp_path, lambda *_: None)
    assert {p.name for p in paths} == {"real-time-small.json", "real-time-small.md"}
    report = json.loads((tmp_path / "real-time-small.json").read_text())
    rows = report["rows"]
    config = real_time.SIZES["small"]
    fixed = len(config["midpoint"]) + len(config["composed"])
    assert [row["integrator"] for row in rows] == (
        ["midpoint4"] + ["midpoint"] * len(config["midpoint"])
        + ["midpoint4"] * len(config["composed"]) + ["midpoint"] * len(config["controlled"])
        + [name for name, _ in config["sundials"]])
    controlled = rows[1 + fixed:][:len(config["controlled"])]
    assert all(row["setting"].startswith("error control, rtol = atol = ")
               for row in controlled)
    steps = round(config["t_end"] / real_time.OUTPUT_DT)
    assert [row["steps"] for row in rows[:1 + fixed]] == [
        steps * per for per in (config["reference"], *config["midpoint"],
                                *config["composed"])]
    assert [row["solves"] for row in rows[:1 + fixed]] == [
        steps * per * parts for per, parts in
        ((config["reference"], 5), *((per, 1) for per in config["midpoint"]),
         *((per, 5) for per in config["composed"]))]
    assert all(row["success"] and np.isfinite(row["tip_error_over_L"]) for row in rows)
    assert rows[0]["tip_error_over_L"] == 0.0 and report["reference_bound_over_L"] > 0.0
    assert all(report["floor"][part] > 0.0 for part in ("fresh_ms", "factor_ms",
                                                        "residual_ms", "solve_ms"))
    assert set(report["needed"]) == {"midpoint", "midpoint4"}
    assert "| midpoint4 | reference" in (tmp_path / "real-time-small.md").read_text()
