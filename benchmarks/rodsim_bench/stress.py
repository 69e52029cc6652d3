"""Stability stress map (``rodsim bench stress``): every integrator over a wide parameter box.

Configurations are drawn from Latin hypercubes (fixed seeds) over the hanging-mass cantilever
of Table 1: penalty K_P ∈ [1e2, 1e9] N, control points N ∈ [5, 2000], radius
r ∈ [1e-5, 1e-2] m, load parameter α = F L²/(2EI) ∈ [0.01, 20] (the hanging mass follows from
α, E and r), and the paper integrator's step h ∈ [0.01, 1] s. Most of that box is not
resolvable in double precision: a 10 µm rod under its α = 1 load with K_P = 1e6 has loads
far below the round-off of its penalty forces, and every integrator refuses such a scene up
front with that diagnostic (docs/model.md; tests/test_failures.py). The map therefore keeps
the first ``count`` draws whose model is resolvable (residual floor ≤
:data:`~rodsim.solvers.base.MAX_RESIDUAL_FLOOR`) and records how many draws were refused
(``box_draws``, ``box_refused``), so that all ``count`` configurations stress the
integrators. Each configuration runs with every integrator (defaults otherwise) under a
wall-time budget, through the study runner (parallel, resumable). Each run ends as

- ``converged``: at equilibrium (status ok);
- ``refused``: below round-off (as above; cannot happen for a kept draw unless the check
  and the integrators disagree);
- ``diverged``: the state or the force became non-finite, reported as a failure;
- ``failed``: a solver failure with its diagnostic (budget, Newton, SUNDIALS error …);
- ``crash``: an exception escaped the integrator — must never happen;

and a success with a non-finite result would be a ``nan_success`` — must never happen.
Outputs: ``stress.nc`` (the study Dataset plus ``outcome``), ``stress.png`` (heat maps of
the fraction converged) and ``stress.md`` (counts, where the paper integrator fails and the
adaptive ones do not, and the reverse).
"""

from __future__ import annotations

import functools
import itertools
import math
import re
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.stats import qmc

from rodsim.app.study import STATUS, Study, Sweep
from rodsim.app.study_runner import run_study
from rodsim_bench.machine import machine

__all__ = ["run", "configurations", "OUTCOMES"]

OUTCOMES = ("converged", "refused", "diverged", "failed", "crash", "nan_success")
INTEGRATORS = ("static", "paper", "cvode", "ida")
#: log10 bounds of (K_P [N], N, r [m], α, h [s]).
BOUNDS = np.array([[2.0, 9.0], [math.log10(5), math.log10(2000)], [-5.0, -2.0],
                   [-2.0, math.log10(20)], [-2.0, 0.0]])
#: medium: the full box and budget with 150 configurations (600 runs, about 15 min on a
#: loaded 2-core machine), for a re-measurement between full runs.
SIZES = {"small": {"count": 6, "max_nodes": 40, "budget": 5.0},
         "medium": {"count": 150, "max_nodes": 2000, "budget": 20.0},
         "full": {"count": 500, "max_nodes": 2000, "budget": 20.0}}
#: Table 1 material and length (the base scene), standard gravity.
E, LENGTH, GRAVITY = 5.9e6, 0.12, 9.81
BASE_SCENE = "table1-50g"
#: Scene keys set by a configuration's K_P, nodes, radius, mass and h.
KEYS = ("rods.catheter.centerline.K_P", "rods.catheter.nodes", "rods.catheter.radius",
        "rods.catheter.tip_load.mass", "solver.paper.h")
#: The configuration coordinates of the map: name, units, long name.
COORDINATES = (("K_P", "N", "centerline penalty K_P"), ("nodes", "1", "control points N"),
               ("radius", "m", "rod radius r"), ("alpha", "1", "load parameter F L²/(2EI)"),
               ("h", "s", "paper integrator's step h"))
#: One configuration: K_P [N], nodes, radius [m], α, mass [kg], h [s].
Configuration = dict[str, float]


@functools.cache
def sample(count: int, max_nodes: int, seed: int = 0) -> tuple[tuple[Configuration, ...], int]:
    """The first ``count`` resolvable configurations of Latin hypercubes over the box of the
    module docstring (seeds ``seed``, ``seed + 1``, … until enough are found), and the
    number of draws refused on the way as below round-off."""
    import rodsim
    from rodsim.solvers.base import MAX_RESIDUAL_FLOOR

    bounds = BOUNDS.copy()
    bounds[1, 1] = math.log10(max_nodes)
    base = rodsim.load_scene(BASE_SCENE)
    kept: list[Configuration] = []
    refused = 0
    for batch in itertools.count(seed):
        draws = qmc.LatinHypercube(d=len(bounds), seed=batch).random(count)
        for k_p, nodes, radius, alpha, step in 10.0 ** (bounds[:, 0] + draws
                                                        * (bounds[:, 1] - bounds[:, 0])):
            inertia = math.pi * radius**4 / 4.0
            force = 2.0 * E * inertia * alpha / LENGTH**2
            config = {"K_P": float(f"{k_p:.4g}"), "nodes": int(round(nodes)),
                      "radius": float(f"{radius:.4g}"), "alpha": float(f"{alpha:.4g}"),
                      "mass": float(force / GRAVITY), "h": float(f"{step:.4g}")}
            model = rodsim.build_model(base.with_overrides(_overrides(config)))
            if model.residual_floor > MAX_RESIDUAL_FLOOR:
                refused += 1
                continue
            kept.append(config)
            if len(kept) == count:
                return tuple(kept), refused
    raise AssertionError("unreachable")  # itertools.count never ends


def configurations(count: int, max_nodes: int, seed: int = 0) -> list[Configuration]:
    """``count`` resolvable configurations (see :func:`sample`)."""
    return list(sample(count, max_nodes, seed)[0])


def _overrides(config: Configuration) -> list[str]:
    """``--set`` strings that apply a configuration to the base scene."""
    names = ("K_P", "nodes", "radius", "mass", "h")
    return [f"{key}={config[name]!r}" for name, key in zip(names, KEYS, strict=True)]


def stress_study(size: str) -> Study:
    setting = SIZES[size]
    configs = configurations(setting["count"], setting["max_nodes"])
    values = tuple((c["K_P"], c["nodes"], c["radius"], c["mass"], c["h"]) for c in configs)
    sweeps = [Sweep("config", KEYS, values, "1", "configuration index",
                    labels=tuple(range(len(configs)))),
              Sweep("integrator", "solver.integrator", INTEGRATORS, "1", "integrator")]
    return Study(
        name="stress", title="stability stress map", paper="(rodsim benchmark)",
        scene=BASE_SCENE, integrator=None, reference="exact", plot="centerlines",
        overrides=(f"solver.max_wall_time={setting['budget']}",),
        sweeps={size: sweeps})


def classify(ds: xr.Dataset) -> xr.DataArray:
    """The outcome of each run (index into :data:`OUTCOMES`)."""
    status = ds["status"].values
    message = ds["message"].values.astype(str)
    finite = np.all(np.isfinite(ds["tip"].values), axis=(-2, -1))
    outcome = np.full(status.shape, OUTCOMES.index("failed"), dtype=np.int8)
    outcome[status == STATUS["ok"]] = OUTCOMES.index("converged")
    outcome[(status == STATUS["ok"]) & ~finite] = OUTCOMES.index("nan_success")
    lowered = np.char.lower(message)
    diverged = np.char.find(lowered, "non-finite") >= 0
    refused = np.char.find(lowered, "round-off of the internal forces") >= 0
    outcome[(status == STATUS["solver_failure"]) & diverged] = OUTCOMES.index("diverged")
    outcome[(status == STATUS["solver_failure"]) & refused] = OUTCOMES.index("refused")
    outcome[status == STATUS["error"]] = OUTCOMES.index("crash")
    return xr.DataArray(outcome, dims=ds["status"].dims,
                        attrs={"long_name": "outcome of the run",
                               "flag_values": list(range(len(OUTCOMES))),
                               "flag_meanings": " ".join(OUTCOMES)})


#: The heat maps: (x, y) configuration coordinates and their log10 bin edges.
HEAT_MAPS = (("K_P", "nodes", np.linspace(*BOUNDS[0], 8), np.linspace(*BOUNDS[1], 7)),
             ("alpha", "radius", np.linspace(*BOUNDS[3], 7), np.linspace(*BOUNDS[2], 7)),
             ("h", "alpha", np.linspace(*BOUNDS[4], 5), np.linspace(*BOUNDS[3], 7)))


def measured_result(ds: xr.Dataset) -> str:
    """The figure's result line, computed from the archive: the share of the configurations
    (those no integrator refused) each integrator converged on, and the count of crashes
    and of non-finite results reported as success (which must be 0)."""
    refused = (ds["outcome"] == OUTCOMES.index("refused")).any("integrator").values
    total = int((~refused).sum())
    shares, never = [], {"crash": 0, "nan_success": 0}
    for integrator in ds["integrator"].values.tolist():
        outcome = ds["outcome"].sel(integrator=integrator).values
        converged = int((outcome[~refused] == OUTCOMES.index("converged")).sum())
        shares.append(f"{integrator} {100.0 * converged / max(total, 1):.0f} %")
        for name in never:
            never[name] += int((outcome == OUTCOMES.index(name)).sum())
    return (f"converged on {', '.join(shares)} of {total} configurations; "
            f"{never['crash']} crashes, {never['nan_success']} non-finite results reported "
            "as success")


def _figure(ds: xr.Dataset, path: Path) -> None:
    """Heat maps of the fraction of configurations that converged, per integrator (columns)
    and pair of configuration coordinates (rows, log-spaced bins; the other coordinates vary
    within a bin). Each cell is labelled converged/configurations; empty bins stay blank.
    Only the paper integrator uses h: its row is a control for the other three. A title
    names any crash or NaN reported as success (which must never happen)."""
    from rodsim.app.figures import style  # selects the Agg backend

    with style():
        _draw(ds, path)


def _axis_label(ds: xr.Dataset, key: str) -> str:
    """``long name [units]`` of a configuration coordinate (``[1]``: a pure number)."""
    attrs = ds[key].attrs
    return f"{attrs.get('long_name', key)} [{attrs.get('units', '1')}]"


def _draw(ds: xr.Dataset, path: Path) -> None:
    """The heat maps of :func:`_figure`, drawn in the current style."""
    import matplotlib.pyplot as plt

    refused = (ds["outcome"] == OUTCOMES.index("refused")).any("integrator").values
    figure, axes = plt.subplots(len(HEAT_MAPS), len(INTEGRATORS), figsize=(15, 10),
                                constrained_layout=True, squeeze=False)
    image = None
    for column, integrator in enumerate(INTEGRATORS):
        outcome = ds["outcome"].sel(integrator=integrator).values
        converged = outcome == OUTCOMES.index("converged")
        for row, (xname, yname, xedges, yedges) in enumerate(HEAT_MAPS):
            x = np.log10(ds[xname].values[~refused])
            y = np.log10(ds[yname].values[~refused])
            total, _, _ = np.histogram2d(x, y, bins=(xedges, yedges))
            good, _, _ = np.histogram2d(x, y, bins=(xedges, yedges),
                                        weights=converged[~refused].astype(float))
            with np.errstate(invalid="ignore", divide="ignore"):
                fraction = np.where(total > 0, good / total, np.nan)
            ax = axes[row, column]
            image = ax.pcolormesh(10.0 ** xedges, 10.0 ** yedges, fraction.T, cmap="RdYlGn",
                                  vmin=0.0, vmax=1.0)
            for i, j in zip(*np.nonzero(total), strict=True):
                ax.text(10 ** (0.5 * (xedges[i] + xedges[i + 1])),
                        10 ** (0.5 * (yedges[j] + yedges[j + 1])),
                        f"{int(good[i, j])}/{int(total[i, j])}", ha="center", va="center",
                        fontsize=8)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel(_axis_label(ds, xname))
            ax.set_ylabel(_axis_label(ds, yname))
            if row == 0:
                never = ", ".join(f"{int(count)} {name}" for name in ("crash", "nan_success")
                                  if (count := (outcome == OUTCOMES.index(name)).sum()))
                ax.set_title(f"{integrator}: {int(converged[~refused].sum())}/"
                             f"{int((~refused).sum())} converged" + (f" ({never}!)" if never
                                                                      else ""))
    if image is not None:
        figure.colorbar(image, ax=axes, shrink=0.6,
                        label="fraction of the bin's configurations that converged [1]")
    figure.suptitle(f"Convergence map ({ds.attrs.get('size', '')}) — measured: "
                    f"{measured_result(ds)}\ncells: converged/configurations in the bin")
    figure.savefig(path, dpi=100)
    plt.close(figure)


def _agreement(ds: xr.Dataset, converged: xr.DataArray) -> list[str]:
    """Tip distance to ``static`` where both converged, over the rod length."""
    tip = ds["tip"].isel(rod=0)
    lines = ["## Agreement with `static` where both converged (tip distance / L)", "",
             "Both stop on a residual below max(τ, round-off floor); where the floor is near "
             "the refusal threshold the equilibrium is only that loosely defined, and "
             "`static` polishes past it with Newton.", "",
             "| integrator | runs | median | max | > 1e-6 | > 1e-4 |", "|---|--:|--:|--:|--:|--:|"]
    for integrator in INTEGRATORS[1:]:
        both = (converged.sel(integrator=integrator) & converged.sel(integrator="static")).values
        distance = np.linalg.norm((tip.sel(integrator=integrator) - tip.sel(integrator="static"))
                                  .values[both], axis=-1) / LENGTH
        if not distance.size:
            continue
        lines.append(f"| {integrator} | {distance.size} | {np.median(distance):.2g} | "
                     f"{distance.max():.2g} | {int((distance > 1e-6).sum())} | "
                     f"{int((distance > 1e-4).sum())} |")
    return [*lines, ""]


def _by_bins(ds: xr.Dataset, converged: xr.DataArray, refused: xr.DataArray) -> list[str]:
    """Converged runs per integrator by load parameter α and by N (configurations that are
    not refused)."""
    lines = ["## Converged runs by α and by N (configurations not refused)", "",
             "| bin | configurations | " + " | ".join(INTEGRATORS) + " |",
             "|---|--:|" + "--:|" * len(INTEGRATORS)]
    kept = ~refused.values
    for name, values, edges in (("α", ds["alpha"].values, (0.0, 1.0, 5.0, np.inf)),
                                ("N", ds["nodes"].values, (0, 50, 300, np.inf))):
        for low, high in zip(edges[:-1], edges[1:], strict=True):
            pick = kept & (values >= low) & (values < high)
            label = f"{low:g} ≤ {name} < {high:g}" if np.isfinite(high) else f"{name} ≥ {low:g}"
            lines.append(f"| {label} | {int(pick.sum())} | " + " | ".join(
                str(int(converged.sel(integrator=i).values[pick].sum())) for i in INTEGRATORS)
                + " |")
    return [*lines, ""]


def _markdown(ds: xr.Dataset) -> str:
    lines = [f"# Stress map ({ds.attrs['size']}, {ds.sizes['config']} configurations × "
             f"{ds.sizes['integrator']} integrators)", "",
             "| integrator | " + " | ".join(OUTCOMES)
             + " | median time, converged [s] | max time [s] |",
             "|---|" + "--:|" * (len(OUTCOMES) + 2)]
    for integrator in INTEGRATORS:
        outcome = ds["outcome"].sel(integrator=integrator).values
        times = ds["wall_time"].sel(integrator=integrator).values
        counts = [int(np.sum(outcome == k)) for k in range(len(OUTCOMES))]
        converged_times = times[outcome == OUTCOMES.index("converged")]
        median = np.median(converged_times) if converged_times.size else np.nan
        lines.append(f"| {integrator} | " + " | ".join(map(str, counts))
                     + f" | {median:.3g} | {np.nanmax(times):.3g} |")
    converged = ds["outcome"] == OUTCOMES.index("converged")
    paper = converged.sel(integrator="paper")
    adaptive = converged.sel(integrator="cvode") & converged.sel(integrator="ida")
    either = converged.sel(integrator="cvode") | converged.sel(integrator="ida")
    refused = (ds["outcome"] == OUTCOMES.index("refused")).any("integrator")
    draws, box_refused = int(ds.attrs["box_draws"]), int(ds.attrs["box_refused"])
    lines += ["", f"- draws from the box refused as below round-off (not in the map): "
              f"{box_refused} of {draws} ({box_refused / draws:.0%})",
              f"- configurations of the map refused by an integrator: {int(refused.sum())}",
              f"- paper fails where CVODE and IDA both converge: "
              f"{int((~paper & adaptive).sum())} configurations",
              f"- paper converges where CVODE or IDA fails: {int((paper & ~adaptive).sum())}"
              f" (where both fail: {int((paper & ~either).sum())})",
              f"- static (the reference) fails: "
              f"{int((ds['outcome'].sel(integrator='static') > OUTCOMES.index('refused')).sum())}",
              ""]
    lines += _agreement(ds, converged) + _by_bins(ds, converged, refused)
    for integrator in INTEGRATORS:
        failed = ~ds["outcome"].sel(integrator=integrator).isin(
            [OUTCOMES.index("converged"), OUTCOMES.index("refused")])
        messages = ds["message"].sel(integrator=integrator).values[failed.values]
        kinds: dict[str, int] = {}
        for message in messages:
            reason = str(message).split(": ", 1)[-1].split(" (residual")[0]
            reason = re.sub(r"\d[\d.e+-]*", "#", reason.split(" at ")[0])[:90]
            kinds[reason] = kinds.get(reason, 0) + 1
        if kinds:
            lines.append(f"Failures of `{integrator}`:")
            lines += [f"- {n} × {reason}" for reason, n in
                      sorted(kinds.items(), key=lambda item: -item[1])[:6]]
            lines.append("")
    lines.append("Machine: " + ", ".join(f"{k.removeprefix('machine_')} {v}"
                                         for k, v in ds.attrs.items()
                                         if k.startswith("machine_")))
    return "\n".join(lines) + "\n"


def run(size: str, output_dir: Path, progress=None) -> list[Path]:
    """Run (or resume) the stress map and write stress.nc, stress.png and stress.md."""
    if progress is not None:
        progress(None, "stress: drawing resolvable configurations from the box")
    study = stress_study(size)
    configs, box_refused = sample(SIZES[size]["count"], SIZES[size]["max_nodes"])
    output = Path(output_dir) / (f"stress-{size}.nc")

    resumed: list[int] = []  # runs recorded before this session (the first call's count)

    def report(done: int, failed: int, total: int, elapsed: float) -> None:
        if not resumed:
            resumed.append(done)
        ran = done - resumed[0]
        if progress is not None:
            eta = f", ETA {elapsed / ran * (total - done):.0f} s" if ran and done < total else ""
            progress(done / total, f"stress: {done}/{total} runs, {failed} not converged{eta}")

    from rodsim.io.archive import read_dataset

    spec = study.spec(size)
    if output.exists() and read_dataset(output).attrs.get("spec_json") == spec.to_json():
        # Already complete: re-derive outcomes, table and figure; keep the machine it ran on.
        ds = read_dataset(output)
    else:
        ds = run_study(study, size, output, progress=report)
        ds.attrs.update({f"machine_{k}": v for k, v in machine().items()})
    for key, units, long_name in COORDINATES:
        ds = ds.assign_coords({key: ("config", [c[key] for c in configs],
                                     {"units": units, "long_name": long_name})})
    ds["outcome"] = classify(ds)
    ds.attrs.update(box_draws=len(configs) + box_refused, box_refused=box_refused)
    from rodsim.io.archive import write_dataset

    write_dataset(ds, output)
    figure = output.with_suffix(".png")
    _figure(ds, figure)
    table = output.with_suffix(".md")
    table.write_text(_markdown(ds), encoding="utf-8")
    return [output, figure, table]
