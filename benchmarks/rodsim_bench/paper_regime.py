"""Adaptive against the paper integrator in the paper's damping regime
(``rodsim bench paper-regime``): error against wall time on ``table1-50g`` (the Fig. 8 scene).

With Table 1 in SI units h² ω₁² ≈ 26 for the slowest mode at h = 0.3 s, so the paper
integrator reaches rest in a handful of steps whatever its damping ξ is. The option
``solver.paper.h2_omega2`` scales its mass matrix so that h² ω₁² takes the given value; at
0.003 (M × ~8.6e3) the paper's Fig. 8 ordering of ξ appears (docs/studies.md, "Fig. 8 in
the paper's damping regime"). The equilibrium does not depend on M, so this benchmark asks
what that regime costs against CVODE and IDA, which choose their own steps and pseudo-masses
(their cost does not depend on the factor), with ``static`` (Newton) as the floor:

- ``static``;
- ``paper`` at the paper's h = 0.3 s with ``h2_omega2 = 0.003`` and ξ ∈ {0.5, 0.8, 0.9,
  0.95, 1.0} (the regime), and at h = 0.3, ξ = 0.9 with the physical masses
  (``h2_omega2 = 0``, rodsim's default) for contrast;
- ``cvode`` and ``ida`` at their defaults (overdamped, band, rtol = atol = 1e-4) and
  ``cvode`` at rtol = atol = 1e-6; and, for contrast, ``cvode`` and ``ida`` at their
  defaults without their Newton finish (``newton_switch = 0``: they integrate all the way to
  the tolerance instead of switching to Newton on F(x) = 0 once the scaled residual is
  below 0.1) — the adaptive integrators' own cost;

each at τ = ``solver.tolerance`` ∈ {1e-4, 1e-7, 1e-10} (1e-10 is raised to the scene's
round-off floor). Error and time are measured as in :mod:`rodsim_bench.work_precision`
(whose machinery this module uses): error = largest control-point distance to ``static`` at
tolerance 1e-12, over L; time = wall time of ``rodsim.solve`` on a prebuilt model, minimum
over the timed repeats (round-robin after a warm-up). Every run has a wall-time budget of
:data:`MAX_WALL_TIME` s; a run that exceeds it is kept as a failure with its message.

Writes ``paper-regime-<size>.nc``, ``paper-regime-<size>.md`` and ``paper-regime-<size>.png``
under ``output_dir``.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from rodsim_bench.work_precision import (
    ERROR_FLOOR,
    REFERENCE_TOLERANCE,
    STATIC,
    Method,
    Point,
    _dataset,
    _measure,
    _reference,
    _sundials,
    count,
    fmt,
    machine_line,
    markdown_table,
    seconds,
)

__all__ = ["run", "report", "methods_for", "SCENE", "H2_OMEGA2"]

Progress = Callable[[float | None, str], None]

#: The Fig. 8 scene (Table 1, 50 g, N = 40).
SCENE = "table1-50g"
#: The paper's step [s] and the regime's h² ω₁² (docs/studies.md, fig8_regime).
H = 0.3
H2_OMEGA2 = 0.003
#: Damping constants run in the regime (full size).
XIS = (0.5, 0.8, 0.9, 0.95, 1.0)
#: Tolerances τ (``solver.tolerance``) of the full size.
TOLERANCES = (1e-4, 1e-7, 1e-10)
#: Wall-time budget of every run [s] (``solver.max_wall_time``).
MAX_WALL_TIME = 60.0
#: Error levels of the headline comparison [1].
COMPARE_AT = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
#: The error level the figure's title compares at [1].
TITLE_ERROR = 1e-7
#: Groups of methods (the ``group`` coordinate), in table order.
GROUPS = ("static", "paper regime", "paper physical M", "cvode", "ida",
          "cvode, no Newton finish", "ida, no Newton finish")


def regime(xi: float, h: float = H) -> Method:
    """The paper integrator with M scaled to h² ω₁² = :data:`H2_OMEGA2`."""
    return Method(f"paper h={h:g} ξ={xi:g} h²ω₁²={H2_OMEGA2:g}", "paper", "paper",
                  (("h", h), ("xi", xi), ("h2_omega2", H2_OMEGA2)))


#: The paper integrator at the paper's setting with the physical masses (h² ω₁² ≈ 26).
PHYSICAL = Method(f"paper h={H:g} ξ=0.9 physical M", "paper", "paper",
                  (("h", H), ("xi", 0.9), ("h2_omega2", 0.0)))
CVODE_DEFAULT = _sundials("cvode", "overdamped", "band", 1e-4)


def no_finish(method: Method) -> Method:
    """``method`` (CVODE or IDA) integrating all the way to the tolerance: no Newton finish."""
    return replace(method, label=f"{method.label} no Newton finish",
                   options=(*method.options, ("newton_switch", 0.0)))


def group(method: Method) -> str:
    """The method's group (one of :data:`GROUPS`)."""
    if method.family == "paper":
        return "paper regime" if method.settings.get("h2_omega2", 0.0) > 0 else (
            "paper physical M")
    if method.settings.get("newton_switch") == 0.0:
        return f"{method.family}, no Newton finish"
    return method.family


def methods_for(size: str) -> tuple[list[Method], list[float]]:
    """The methods and the tolerances τ at this ``size``."""
    if size == "small":
        return [STATIC, regime(0.9), PHYSICAL, CVODE_DEFAULT], [1e-4]
    ida = _sundials("ida", "overdamped", "band", 1e-4)
    return ([STATIC, *(regime(xi) for xi in XIS), PHYSICAL, CVODE_DEFAULT, ida,
             _sundials("cvode", "overdamped", "band", 1e-6), no_finish(CVODE_DEFAULT),
             no_finish(ida)], list(TOLERANCES))


# --------------------------------------------------------------------- outputs


def _archive(points: list[Point], info: dict[str, Any], size: str, repeats: int):
    """The work-precision Dataset of these points, with the group, h² ω₁² and this
    benchmark's attributes."""
    ds = _dataset(points, {SCENE: info}, size, {SCENE: repeats})
    ds = ds.assign_coords(
        group=("point", np.array([group(p.method) for p in points], dtype=str),
               {"long_name": "method group (" + ", ".join(GROUPS) + ")"}),
        h2_omega2=("point", np.array([p.method.settings.get("h2_omega2", np.nan)
                                      for p in points], dtype=float),
                   {"units": "1", "long_name": "paper integrator's h² ω₁² target "
                    "(solver.paper.h2_omega2; 0: physical masses; NaN if n/a)"}),
        newton_switch=("point", np.array([p.method.settings.get("newton_switch", np.nan)
                                          for p in points], dtype=float),
                       {"units": "1", "long_name": "CVODE/IDA newton_switch if set (0: no "
                        "Newton finish; NaN: the default 0.1, or n/a)"}))
    ds.attrs.update({
        "title": "rodsim paper-regime benchmark: CVODE/IDA against the paper integrator "
                 "with h² ω₁² = 0.003",
        "benchmark": "paper-regime",
        "scene": SCENE,
        "h2_omega2": H2_OMEGA2,
        "max_wall_time": MAX_WALL_TIME,
    })
    return ds


def best(ds, group_name: str, level: float) -> tuple[float, int]:
    """Fastest successful run of ``group_name`` with error ≤ ``level``: (time, index),
    (NaN, -1) if none."""
    mask = ((ds["group"] == group_name) & (ds["success"] == 1)
            & (ds["error"] <= level)).values
    if not mask.any():
        return float("nan"), -1
    index = np.flatnonzero(mask)
    k = int(index[np.argmin(ds["wall_time"].values[mask])])
    return float(ds["wall_time"].values[k]), k


def _where(ds, k: int) -> str:
    if k < 0:
        return "-"
    return f"{ds['method'].values[k]}, τ={float(ds['tolerance'].values[k]):.0e}"


def title_level(ds) -> float:
    """:data:`TITLE_ERROR`, or, if no paper-regime run reached it (the small size), the
    tightest level of :data:`COMPARE_AT` one reached."""
    reached = [level for level in COMPARE_AT if best(ds, "paper regime", level)[1] >= 0]
    return TITLE_ERROR if TITLE_ERROR in reached or not reached else min(reached)


def measured_result(ds, level: float | None = None) -> str:
    """The figure's title: the fastest regime run to error ≤ ``level`` (default
    :func:`title_level`) against CVODE's (and IDA's) fastest."""
    level = title_level(ds) if level is None else level
    paper, kp = best(ds, "paper regime", level)
    head = f"paper regime (h²ω₁² = {ds.attrs['h2_omega2']:g})"
    if kp < 0:
        return f"{head}: no run reached error ≤ {level:g}"
    def against(names: tuple[str, ...]) -> list[str]:
        out = []
        for name in names:
            if not bool((ds["group"] == name).any()):
                continue
            t, k = best(ds, name, level)
            short = name.split(",")[0].upper()
            out.append(f"{short} none" if k < 0 else f"{short} {paper / t:.3g}× faster"
                       if t < paper else f"{short} {t / paper:.3g}× slower")
        return out

    xi = float(ds["xi"].values[kp])
    static, _ = best(ds, "static", level)
    bare = against(("cvode, no Newton finish", "ida, no Newton finish"))
    tail = (f"; without their Newton finish {', '.join(bare)}" if bare else "") + (
        f"; static {paper / static:.3g}× faster" if np.isfinite(static) else "")
    return (f"{head}: " + ", ".join(against(("cvode", "ida")) or ["no adaptive run"])
            + f" than the best ξ (ξ = {xi:g}, {seconds(paper)}) at error ≤ {level:g}" + tail)


def _markdown(ds) -> str:
    size = ds.attrs["size"]
    cvode = {float(ds["tolerance"].values[i]): float(ds["wall_time"].values[i])
             for i in range(ds.sizes["point"])
             if str(ds["method"].values[i]) == CVODE_DEFAULT.label
             and int(ds["success"].values[i])}
    lines = [f"# Paper-regime benchmark ({size})", "",
             f"Scene `{SCENE}` (the Fig. 8 scene). The paper integrator runs at h = {H:g} s "
             f"with its mass matrix scaled so that h² ω₁² = {ds.attrs['h2_omega2']:g} "
             "(`solver.paper.h2_omega2`; physical masses give ≈ 26), where the paper's Fig. 8 "
             "ordering of ξ appears; `paper … physical M` is the same integrator with "
             "rodsim's default masses. CVODE and IDA pick their own steps and pseudo-masses. "
             "Error = largest control-point distance to `static` at tolerance "
             f"{REFERENCE_TOLERANCE:g}, over L. Time = wall time of `rodsim.solve` on a "
             f"prebuilt model, minimum over up to {ds.attrs['timed_repeats']} timed runs "
             f"after a warm-up (round-robin); budget {ds.attrs['max_wall_time']:g} s per run. "
             "× CVODE = time over `cvode` at its default (overdamped, band, rtol = atol = "
             "1e-4) at the same τ.", "", machine_line(ds.attrs), "",
             f"Measured: {measured_result(ds)}.", "",
             "## Fastest run reaching each error level", "",
             "The fastest successful run of each group (any configuration, any τ) whose "
             "error is at most the level; ratios are the fastest paper-regime run's time "
             "over the group's.", ""]
    rows = []
    for level in COMPARE_AT:
        paper, _ = best(ds, "paper regime", level)
        for name in GROUPS:
            if not bool((ds["group"] == name).any()):
                continue
            t, k = best(ds, name, level)
            rows.append([f"{level:.0e}", name, seconds(t), fmt(paper / t), _where(ds, k)])
    lines += markdown_table(["error ≤", "group", "time", "paper regime / this",
                             "fastest configuration"], rows, "llrrl")
    lines += ["", "## Every run", ""]
    rows = []
    for i in range(ds.sizes["point"]):
        p = ds.isel(point=i)
        tol = float(p["tolerance"])
        ok = bool(int(p["success"]))
        status = "ok" if ok else f"FAILED: {str(p['message'].values)[:160]}"
        ratio = float(p["wall_time"]) / cvode[tol] if ok and tol in cvode else float("nan")
        rows.append([str(p["method"].values), f"{tol:.0e}", seconds(float(p["wall_time"])),
                     fmt(float(p["error"])), count(float(p["steps"])), fmt(ratio),
                     count(float(p["force_evals"])), count(float(p["jacobian_evals"])),
                     int(p["timed_runs"]), status])
    lines += markdown_table(["method", "τ", "time", "error / L", "steps", "× CVODE",
                             "F evals", "J evals", "timed runs", "status"], rows,
                            "llrrrrrrrl")
    return "\n".join(lines) + "\n"


def _style(ds, label: str) -> dict[str, Any]:
    k = int(np.flatnonzero(ds["method"].values == label)[0])
    name = str(ds["group"].values[k])
    if name == "paper regime":
        xi = float(ds["xi"].values[k])
        shades = {0.5: "#c6dbef", 0.8: "#6baed6", 0.9: "#08519c", 0.95: "#2171b5",
                  1.0: "#9ecae1"}
        return {"color": shades.get(xi, "tab:blue"), "marker": "o", "ls": "-",
                "lw": 2.0 if xi == 0.9 else 1.2}
    if name == "paper physical M":
        return {"color": "tab:cyan", "marker": "D", "ls": "--"}
    if name.startswith(("cvode", "ida")):
        rtol = float(ds["rtol"].values[k])
        finish = "no Newton finish" not in name
        return {"color": ("tab:red" if finish else "tab:orange") if name.startswith("cvode")
                else ("tab:green" if finish else "tab:olive"),
                "marker": "s" if finish else "^",
                "ls": "--" if not finish else "-" if rtol == 1e-4 else ":"}
    return {"color": "black", "marker": "*", "ls": "-.", "ms": 8}


def _plot(ds, path: Path) -> Path:
    """Error / L against wall time, one line per method over τ, in rodsim's style."""
    from rodsim.app.figures import style  # selects the Agg backend

    with style():
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8.0, 6.4), constrained_layout=True)
        ok = ds.where(ds["success"] == 1, drop=True)
        for label in dict.fromkeys(ds["method"].values.tolist()):
            series = ok.where(ok["method"] == label, drop=True)
            if not series.sizes.get("point", 0):
                continue
            series = series.sortby("tolerance")  # one line over τ
            ax.loglog(series["wall_time"].values,
                      np.maximum(series["error"].values, ERROR_FLOOR), label=label,
                      **{"ms": 5, "lw": 1.2, **_style(ds, label)})
        failed = int((ds["success"] == 0).sum())
        ax.set_xlabel("wall time to equilibrium [s]")
        ax.set_ylabel("error / L [1] (largest control-point distance to static)")
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(loc="best", fontsize=8)
        note = (f"{failed} failed run(s) not shown; " if failed else "") + (
            f"errors below {ERROR_FLOOR:g} drawn at {ERROR_FLOOR:g}; one point per τ; "
            f"{ds.attrs.get('machine_cpu', '')}, {ds.attrs.get('machine_date', '')}")
        fig.suptitle(textwrap.fill(measured_result(ds), 80) + "\n"
                     + textwrap.fill(note, 100), fontsize=9)
        fig.savefig(path, dpi=90)
        plt.close(fig)
    return path


def report(ds, stem: Path | str) -> list[Path]:
    """Write the figure and the markdown of a paper-regime Dataset (also from a re-opened
    archive: ``report(xr.open_dataset(path).load(), path.with_suffix(""))``)."""
    stem = Path(stem)
    markdown = stem.with_suffix(".md")
    markdown.write_text(_markdown(ds))
    return [_plot(ds, stem.with_suffix(".png")), markdown]


# ------------------------------------------------------------------------- run


def run(size: str, output_dir: Path | str, progress: Progress | None = None) -> list[Path]:
    """Run the benchmark at ``size`` (``small`` or ``full``); returns the written paths."""
    from rodsim.io.archive import write_dataset

    if size not in ("small", "full"):
        raise ValueError(f"size {size!r}: expected 'small' or 'full'")
    outer = progress or (lambda fraction, status: None)

    def progress(fraction: float | None, status: str) -> None:
        outer(fraction, status.replace("work-precision:", "paper-regime:", 1))

    output = Path(output_dir)
    output.mkdir(parents=True, exist_ok=True)
    repeats = 1 if size == "small" else 5
    long_run = 5.0 if size == "small" else 20.0
    progress(None, f"paper-regime: reference solve of {SCENE}")
    reference, length, info = _reference(SCENE)
    methods, tolerances = methods_for(size)
    points = [Point(SCENE, method, tol, MAX_WALL_TIME, repeats)
              for method in methods for tol in tolerances]
    _measure(points, {SCENE: (reference, length)}, long_run, progress)
    ds = _archive(points, info, size, repeats)
    stem = output / f"paper-regime-{size}"
    return [write_dataset(ds, stem.with_suffix(".nc"))] + report(ds, stem)
