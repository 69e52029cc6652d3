"""Work-precision benchmark (``rodsim bench work-precision``): error against wall time.

Two scenes: ``table1-50g`` (one rod, N = 40) and ``table3-catheter1`` (catheter and tendon).
On each, every method runs from the rest state to equilibrium:

- ``static``: Newton on F(x) = 0, the floor (no pseudo-dynamics at all);
- ``paper``: the paper's damped implicit Euler over the step h and the damping ξ;
- ``cvode``: CVODE over rtol (atol = rtol), inertial or overdamped, band or sparse (the
  shipped default is overdamped, band, rtol = atol = 1e-4), and the former default atol =
  1e-7 with rtol 1e-4, kept to show what it costs;
- ``ida``: IDA over rtol (atol = rtol), overdamped or inertial, band, and atol = 1e-7;
- ``scipy BDF`` / ``scipy LSODA``: the registered ``scipy`` integrator
  (rodsim/solvers/scipy_ivp.py: :func:`scipy.integrate.solve_ivp` on the same overdamped
  pseudo-dynamics, same pseudo-masses, damping and load ramp as rodsim's CVODE, with the
  model's analytic Jacobian, stopped by a terminal event on the same scaled residual) — an
  outside baseline, run through the same template as every other integrator.

Every method stops on the same scaled force residual ``solver.tolerance`` τ, which is swept
as well (the error at rest is set by τ; rtol only sets how the transient is followed, see
docs/benchmark-history.md). **Error** = largest control-point distance (every rod) to the exact
discrete equilibrium (``static`` with tolerance 1e-12, polished to round-off) / L (the
longest rod). **Time** = wall time of ``rodsim.solve(scene, name, model=model)`` (the
integrator's own set-up included, the model's assembly not: a fresh model is built before
every run, outside the timing, because a tendon model carries its registration state from
one solve into the next), minimum over the timed repeats after a warm-up run. The repeats
run round-robin over all points so a burst of load on a shared machine hits every point
alike.

Writes ``work-precision-<size>.nc`` (one row per point; the machine in the attributes),
``work-precision-<size>.png`` and ``work-precision-<size>.md`` under ``output_dir``; the full
size also profiles static, paper and CVODE on both scenes (per-evaluation costs and cProfile,
``work-precision-full-profile.json``, summarised in the markdown). The
helpers here (machine attributes, timing, tables) are shared with :mod:`rodsim_bench.scaling`.
"""

from __future__ import annotations

import json
import textwrap
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rodsim.solvers.result import count_text

__all__ = ["run", "report", "Method", "methods_for", "machine_attributes", "markdown_table",
           "error_over_length", "SCENES"]

Progress = Callable[[float | None, str], None]

#: The scenes and a short description of each.
SCENES = {"table1-50g": "single rod, paper Table 1 (50 g), N = 40",
          "table3-catheter1": "catheter + tendon, paper Table 3 (catheter 1), N_C = 30, "
                              "N_T = 10"}
#: Requested tolerance of the reference solve (raised by rodsim to the round-off floor).
REFERENCE_TOLERANCE = 1e-12
#: Errors below this are drawn at this value in the figure (log axis).
ERROR_FLOOR = 1e-15

# ------------------------------------------------------------------ shared helpers


def machine_attributes() -> dict[str, str]:
    """The machine description as netCDF attributes ``machine_<key>``."""
    from rodsim_bench.machine import machine

    return {f"machine_{key}": str(value) for key, value in machine().items()}


def machine_line(attrs: dict[str, Any]) -> str:
    """One markdown line describing the machine, from :func:`machine_attributes`."""
    m = {key[len("machine_"):]: value for key, value in attrs.items()
         if key.startswith("machine_")}
    return (f"Machine: {m.get('cpu')}, {m.get('cores')} cores ({m.get('cores_available')} "
            f"available), {m.get('platform')}; Python {m.get('python')}, numpy "
            f"{m.get('numpy')}, scipy {m.get('scipy')}, scikit-sundae {m.get('scikit_sundae')}, "
            f"rodsim {m.get('rodsim')} (commit {m.get('git_commit')}); OMP_NUM_THREADS = "
            f"{m.get('OMP_NUM_THREADS')}, OPENBLAS_NUM_THREADS = "
            f"{m.get('OPENBLAS_NUM_THREADS')}; {m.get('date')}.")


def markdown_table(headers: Sequence[str], rows: Iterable[Sequence[Any]],
                   align: str | None = None) -> list[str]:
    """A markdown table (``align``: one character per column, ``l`` or ``r``)."""
    align = align or "l" + "r" * (len(headers) - 1)
    lines = ["| " + " | ".join(headers) + " |",
             "|" + "|".join("---" if a == "l" else "--:" for a in align) + "|"]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return lines


def all_positions(model, x: np.ndarray) -> np.ndarray:
    """Control points of every rod of ``model`` at state ``x``, concatenated (M, 3)."""
    full = model.full(x)
    return np.concatenate([full[rod.layout.position_index] for rod in model.rods.values()])


def error_over_length(positions: np.ndarray, reference: np.ndarray, length: float) -> float:
    """Largest control-point distance to the reference, over L (NaN if not finite)."""
    if positions.shape != reference.shape or not np.all(np.isfinite(positions)):
        return float("nan")
    return float(np.max(np.linalg.norm(positions - reference, axis=1)) / length)


def fmt(value: float, digits: int = 2) -> str:
    """A number for a table: ``-`` for NaN."""
    if value is None or not np.isfinite(value):
        return "-"
    return f"{value:.{digits}e}" if (abs(value) < 1e-2 or abs(value) >= 1e4) and value else (
        f"{value:.{digits + 1}g}")


def count(value: float) -> str:
    """An integer statistic for a table: ``-`` for NaN."""
    return "-" if value is None or not np.isfinite(value) else str(int(value))


def seconds(value: float) -> str:
    """A wall time for a table, in s or ms."""
    if not np.isfinite(value):
        return "-"
    return f"{1e3 * value:.1f} ms" if value < 1.0 else f"{value:.2f} s"


def profile_solve(scene, integrator: str, top: int = 12) -> dict[str, Any]:
    """cProfile of one ``rodsim.solve`` on a fresh model after a warm-up solve: the total
    and the ``top`` functions by own time (numpy's built-ins included)."""
    import cProfile
    import io
    import pstats

    import rodsim

    rodsim.solve(scene, integrator, model=rodsim.build_model(scene))  # warm-up
    model = rodsim.build_model(scene)
    profiler = cProfile.Profile()
    begin = time.perf_counter()
    profiler.enable()
    result = rodsim.solve(scene, integrator, model=model)
    profiler.disable()
    wall = time.perf_counter() - begin
    stats = pstats.Stats(profiler, stream=io.StringIO())
    rows = []
    for (filename, line, function), (_, calls, own, cumulative, _) in stats.stats.items():
        for marker in ("site-packages/", "/rodsim/"):
            if marker in filename:
                filename = ("rodsim/" if marker == "/rodsim/" else "") + filename.split(
                    marker, 1)[1]
                break
        rows.append({"function": f"{filename}:{line}({function})", "calls": int(calls),
                     "own_s": float(own), "cumulative_s": float(cumulative)})
    rows.sort(key=lambda r: r["own_s"], reverse=True)
    return {"wall_time_s": wall, "total_s": float(stats.total_tt), "success": result.success,
            "stats": {k: float(v) for k, v in result.stats.items()}, "top_own": rows[:top]}


def markdown_profile(title: str, profile: dict[str, Any]) -> list[str]:
    """A profile from :func:`profile_solve` as a markdown section."""
    counts = profile.get("stats", {})
    lines = [f"### {title}", "",
             f"{profile['total_s']:.3f} s under the profiler; "
             + ", ".join(f"{k} {count_text(counts[k])}" for k in ("steps", "force_evals",
                                                          "jacobian_evals", "newton_iters")
                         if k in counts) + ". Top functions by own time:", ""]
    lines += markdown_table(["function", "calls", "own [s]", "cumulative [s]"],
                            [[f"`{r['function']}`", r["calls"], f"{r['own_s']:.3f}",
                              f"{r['cumulative_s']:.3f}"] for r in profile["top_own"]])
    return lines + [""]


# --------------------------------------------------------------------- methods


@dataclass(frozen=True)
class Method:
    """One configuration: a registered integrator with options."""

    label: str
    family: str  # static | paper | cvode | ida | scipy
    solver: str  # the integrator's registered name
    options: tuple[tuple[str, Any], ...] = ()

    @property
    def settings(self) -> dict[str, Any]:
        return dict(self.options)

    def overrides(self) -> list[str]:
        """Scene overrides setting the integrator's options."""
        return [f"solver.{self.solver}.{key}={value}" for key, value in self.options]


def _sundials(family: str, formulation: str, linear_solver: str, rtol: float,
              atol: float | None = None) -> Method:
    """atol = rtol unless given (then the label says so)."""
    short = {"inertial": "inert.", "overdamped": "overd."}[formulation]
    label = f"{family} {short} {linear_solver} rtol={rtol:.0e}"
    if atol is not None:
        label += f" atol={atol:.0e}"
    return Method(label, family, family,
                  (("formulation", formulation), ("linear_solver", linear_solver),
                   ("rtol", rtol), ("atol", rtol if atol is None else atol)))


def _scipy(name: str, rtol: float) -> Method:
    return Method(f"scipy {name} rtol={rtol:.0e}", "scipy", "scipy",
                  (("method", name), ("rtol", rtol), ("atol", rtol)))


def _paper(h: float, xi: float) -> Method:
    return Method(f"paper h={h:g} ξ={xi:g}", "paper", "paper", (("h", h), ("xi", xi)))


STATIC = Method("static (Newton)", "static", "static")


def methods_for(size: str, scene: str) -> tuple[list[Method], list[float]]:
    """The methods and the tolerances τ swept on ``scene`` at this ``size``."""
    if size == "small":
        if scene == "table1-50g":
            return ([STATIC, _paper(0.3, 0.9),
                     _sundials("cvode", "overdamped", "band", 1e-4),
                     _sundials("ida", "overdamped", "band", 1e-4),
                     _scipy("BDF", 1e-4), _scipy("LSODA", 1e-4)], [1e-4, 1e-8])
        return [_paper(0.2, 0.9)], [1e-6]
    rtols = (1e-3, 1e-4, 1e-6)
    methods = [STATIC]
    methods += [_paper(h, xi) for xi in (0.9, 0.5) for h in (0.03, 0.1, 0.3, 1.0)]
    methods += [_sundials("cvode", f, s, r) for f in ("overdamped", "inertial")
                for s in ("band", "sparse") for r in rtols]
    methods += [_sundials("ida", f, "band", r) for f in ("overdamped", "inertial")
                for r in rtols]
    # The former default atol = 1e-7 (overdamped, band, rtol 1e-4): 2-3x the cost at equal
    # error (docs/benchmark-history.md), which is why the shipped default is now atol = rtol = 1e-4.
    methods += [_sundials(name, "overdamped", "band", 1e-4, 1e-7) for name in ("cvode", "ida")]
    methods += [_scipy(name, r) for name in ("BDF", "LSODA") for r in rtols]
    return methods, list(TOLERANCES)


#: τ swept in the full benchmark; 1e-10 is below both scenes' round-off floors, so rodsim
#: raises it to the floor ("as tight as the model allows").
TOLERANCES = (1e-4, 1e-7, 1e-10)


# ---------------------------------------------------------------------- points


@dataclass
class Point:
    """One (scene, method, τ): its runs and what they measured."""

    scene: str
    method: Method
    tolerance: float
    max_wall_time: float
    repeats: int = 1
    times: list[float] = field(default_factory=list)
    first_time: float = float("nan")
    success: bool = False
    message: str = ""
    error: float = float("nan")
    residual: float = float("nan")
    effective_tolerance: float = float("nan")
    stats: dict[str, float] = field(default_factory=dict)

    def run_once(self, reference: np.ndarray, length: float, record: bool) -> float:
        """One run from a freshly built model; returns its wall time [s]."""
        import rodsim

        overrides = [*self.method.overrides(), f"solver.tolerance={self.tolerance!r}",
                     f"solver.max_wall_time={self.max_wall_time!r}"]
        scene = rodsim.load_scene(self.scene, overrides)
        model = rodsim.build_model(scene)
        begin = time.perf_counter()
        result = rodsim.solve(scene, self.method.solver, model=model)
        elapsed = time.perf_counter() - begin
        x, success, message = result.state, result.success, result.message
        residual, stats = result.residual, result.stats
        if record:
            self.first_time = elapsed
            self.success, self.message = bool(success), message
            self.error = error_over_length(all_positions(model, x), reference, length)
            self.residual = float(residual)
            self.effective_tolerance = float(stats.get("effective_tolerance", float("nan")))
            self.stats = {k: float(v) for k, v in stats.items()}
        return elapsed

    @property
    def time(self) -> float:
        """Minimum over the timed runs (the first run's time if there were none)."""
        return min(self.times) if self.times else self.first_time


def _reference(scene_name: str) -> tuple[np.ndarray, float, dict[str, Any]]:
    import rodsim

    scene = rodsim.load_scene(scene_name, [f"solver.tolerance={REFERENCE_TOLERANCE!r}"])
    model = rodsim.build_model(scene)
    result = rodsim.solve(scene, "static", model=model)
    if not result.success:
        raise RuntimeError(f"reference solve of {scene_name} failed: {result.message}")
    info = {"unknowns": model.n, "nonzeros": model.nnz,
            "bandwidth": max(model.band.lower, model.band.upper),
            "reference_residual": result.residual,
            "reference_tolerance": result.stats["effective_tolerance"],
            "residual_floor": model.residual_floor}
    return all_positions(model, result.state), model.length_scale, info


def _measure(points: list[Point], references: dict[str, tuple[np.ndarray, float]],
             long_run: float, progress: Progress) -> None:
    """Warm-up pass over every point (it records error and statistics), then timed passes,
    round-robin, until each point has its ``repeats``. A failed point is not run again (its
    time is the warm-up's); a point whose first run took longer than ``long_run`` seconds is
    timed once only."""
    planned = sum(1 + p.repeats for p in points)
    done = 0

    def tick(point: Point, what: str) -> None:
        nonlocal done
        done += 1
        progress(min(done / planned, 1.0),
                 f"work-precision: {what} {point.scene} {point.method.label} "
                 f"τ={point.tolerance:.0e}")

    for point in points:
        reference, length = references[point.scene]
        point.run_once(reference, length, record=True)
        tick(point, "warm-up")
    for k in range(max(p.repeats for p in points)):
        for point in points:
            if k >= point.repeats:
                continue
            if point.success and (k == 0 or point.first_time <= long_run):
                reference, length = references[point.scene]
                point.times.append(point.run_once(reference, length, record=False))
            tick(point, f"repeat {k + 1}/{point.repeats}")


#: Runs profiled in the full size (label, scene, integrator, overrides).
PROFILED = (
    ("static", "static", ()),
    ("paper h=0.3 ξ=0.9", "paper", ("solver.paper.h=0.3", "solver.paper.xi=0.9")),
    ("cvode overd. band rtol=1e-04", "cvode",
     ("solver.cvode.formulation=overdamped", "solver.cvode.linear_solver=band",
      "solver.cvode.rtol=1e-4", "solver.cvode.atol=1e-4")),
)


def evaluation_cost(scene_name: str, repeats: int = 5) -> dict[str, float]:
    """Wall time of one F(x) and one ∂F/∂x at the rest state (minimum over repeats × 50)."""
    import timeit

    import rodsim

    model = rodsim.build_model(rodsim.load_scene(scene_name))
    x = model.x0
    out = {"unknowns": float(model.n), "nonzeros": float(model.nnz)}
    for name, function in (("force_s", lambda: model.force(x)),
                           ("jacobian_s", lambda: model.jacobian_data(x))):
        out[name] = min(timeit.repeat(function, number=50, repeat=repeats)) / 50
    return out


def profiles(progress: Progress, tolerance: float = 1e-7) -> dict[str, Any]:
    """Per-evaluation costs of both scenes and cProfiles of static, paper and CVODE on
    each (τ = ``tolerance``): where the time goes."""
    import rodsim

    out: dict[str, Any] = {"tolerance": tolerance, "evaluation_cost": {}, "profiles": []}
    for scene_name in SCENES:
        progress(None, f"work-precision: profiling {scene_name}")
        out["evaluation_cost"][scene_name] = evaluation_cost(scene_name)
        for label, integrator, overrides in PROFILED:
            scene = rodsim.load_scene(scene_name, [*overrides,
                                                   f"solver.tolerance={tolerance!r}"])
            out["profiles"].append({"scene": scene_name, "label": label,
                                    **profile_solve(scene, integrator)})
    return out


# --------------------------------------------------------------------- outputs


def _dataset(points: list[Point], infos: dict[str, dict[str, Any]], size: str,
             repeats: dict[str, int]):
    import xarray as xr

    n = len(points)
    width = max([len(p.times) for p in points] + [1])
    runs = np.full((n, width), np.nan)
    for i, p in enumerate(points):
        runs[i, :len(p.times)] = p.times

    def setting(name: str, default: Any = np.nan) -> list[Any]:
        return [p.method.settings.get(name, default) for p in points]

    def stat(name: str) -> np.ndarray:
        return np.array([p.stats.get(name, np.nan) for p in points], dtype=float)

    variables = {
        "error": (np.array([p.error for p in points]), "1",
                  "largest control-point distance (every rod) to the exact discrete "
                  "equilibrium, over L"),
        "wall_time": (np.array([p.time for p in points]), "s",
                      "wall time to equilibrium, minimum over the timed runs"),
        "wall_time_runs": (runs, "s", "wall time of every timed run (NaN: not run)"),
        "first_run_time": (np.array([p.first_time for p in points]), "s",
                           "wall time of the warm-up run"),
        "timed_runs": (np.array([len(p.times) for p in points], dtype=np.int32), "1",
                       "number of timed runs after the warm-up"),
        "success": (np.array([p.success for p in points], dtype=np.int8), "1",
                    "1 if the run reached equilibrium"),
        "message": (np.array([p.message for p in points], dtype=str), "1",
                    "the solver's message"),
        "residual": (np.array([p.residual for p in points]), "1",
                     "scaled force residual of the final state"),
        "effective_tolerance": (np.array([p.effective_tolerance for p in points]), "1",
                                "residual tolerance used (τ raised to the round-off floor)"),
    }
    for name, doc in (("steps", "integrator steps"), ("force_evals", "evaluations of F(x)"),
                      ("jacobian_evals", "evaluations of the analytic Jacobian"),
                      ("newton_iters", "Newton iterations"),
                      ("linear_solves", "linear solves counted by rodsim"),
                      ("reinits", "solver re-initialisations after a registration change")):
        variables[name] = (stat(name), "1", doc)
    data_vars = {name: (("point",) + (("repeat",) if values.ndim == 2 else ()), values,
                        {"units": units, "long_name": long})
                 for name, (values, units, long) in variables.items()}
    coords = {
        "scene": ("point", np.array([p.scene for p in points], dtype=str),
                  {"long_name": "scene"}),
        "method": ("point", np.array([p.method.label for p in points], dtype=str),
                   {"long_name": "method and configuration (one series per value)"}),
        "family": ("point", np.array([p.method.family for p in points], dtype=str),
                   {"long_name": "method family (static, paper, cvode, ida, scipy)"}),
        "solver": ("point", np.array([p.method.solver for p in points], dtype=str),
                   {"long_name": "rodsim integrator"}),
        "tolerance": ("point", np.array([p.tolerance for p in points]),
                      {"units": "1", "long_name": "requested scaled residual tolerance τ "
                       "(solver.tolerance)"}),
        "rtol": ("point", np.array(setting("rtol"), dtype=float),
                 {"units": "1", "long_name": "relative tolerance (atol = rtol, relative to L "
                  "or 1); NaN if not applicable"}),
        "h": ("point", np.array(setting("h"), dtype=float),
              {"units": "s", "long_name": "paper integrator time step; NaN if n/a"}),
        "xi": ("point", np.array(setting("xi"), dtype=float),
               {"units": "1", "long_name": "paper integrator damping ξ; NaN if n/a"}),
        "formulation": ("point", np.array(setting("formulation", ""), dtype=str),
                        {"long_name": "pseudo-dynamics formulation ('' if n/a)"}),
        "linear_solver": ("point", np.array(setting("linear_solver", ""), dtype=str),
                          {"long_name": "SUNDIALS linear solver ('' if n/a)"}),
    }
    ds = xr.Dataset(data_vars, coords=coords)
    scenes = list(infos)
    for key, long in (("unknowns", "free coordinates"), ("nonzeros", "Jacobian non-zeros"),
                      ("bandwidth", "Jacobian half-bandwidth"),
                      ("reference_residual", "scaled residual of the reference"),
                      ("reference_tolerance", "effective tolerance of the reference"),
                      ("residual_floor", "model's round-off floor of the residual")):
        ds[f"scene_{key}"] = ("scene_name", np.array([infos[s][key] for s in scenes]),
                              {"units": "1", "long_name": long})
    ds = ds.assign_coords(scene_name=("scene_name", np.array(scenes, dtype=str),
                                      {"long_name": "scene"}))
    ds.attrs.update({
        "title": "rodsim work-precision benchmark",
        "benchmark": "work-precision",
        "size": size,
        "timed_repeats": max(repeats.values()),
        "timed_repeats_per_scene": ", ".join(f"{k}: {v}" for k, v in repeats.items()),
        "reference": f"static with solver.tolerance = {REFERENCE_TOLERANCE:g}",
        "error_definition": "max over control points of |r - r_ref| / L, L = longest rod",
        "time_definition": "wall time of one solve to equilibrium (integrator set-up "
                           "included, model assembly excluded), minimum over timed runs "
                           "after a warm-up",
        **machine_attributes(),
    })
    return ds


FAMILY_COLOURS = {"static": "black", "paper": "tab:blue", "cvode": "tab:red",
                  "ida": "tab:green", "scipy": "tab:purple"}


def _style(method: str, family: str, settings: dict[str, Any]) -> dict[str, Any]:
    """Line style of one series: colour by configuration, marker by h or rtol."""
    style: dict[str, Any] = {"color": FAMILY_COLOURS.get(family, "grey"), "lw": 1.1, "ms": 4}
    rtol_marker = {1e-3: "^", 1e-4: "o", 1e-6: "s"}
    if family == "paper":
        h = settings.get("h", np.nan)
        style["color"] = {0.03: "#08306b", 0.1: "#2171b5", 0.3: "#6baed6", 1.0: "#17becf"}.get(
            h, "tab:blue")
        style["marker"] = {0.03: "v", 0.1: "s", 0.3: "o", 1.0: "D"}.get(h, "o")
        style["ls"] = "-" if settings.get("xi") == 0.9 else "--"
    elif family in ("cvode", "ida"):
        key = (settings.get("formulation"), settings.get("linear_solver"))
        palette = ({("overdamped", "band"): "tab:red", ("overdamped", "sparse"): "tab:orange",
                    ("inertial", "band"): "tab:brown", ("inertial", "sparse"): "tab:pink"}
                   if family == "cvode" else
                   {("overdamped", "band"): "tab:green", ("inertial", "band"): "tab:olive"})
        style["color"] = palette.get(key, style["color"])
        style["marker"] = rtol_marker.get(settings.get("rtol"), "o")
        style["ls"] = "-" if key[0] == "overdamped" else ":"
        if settings.get("atol") != settings.get("rtol"):  # the former default atol 1e-7
            style.update(marker="x", ls="-.", ms=7,
                         color="darkred" if family == "cvode" else "darkgreen")
    elif family == "scipy":
        style["color"] = "tab:purple" if "BDF" in method else "tab:cyan"
        style["marker"] = rtol_marker.get(settings.get("rtol"), "D")
        style["ls"] = "-" if "BDF" in method else "--"
    else:
        style["marker"] = "*"
    return style


def _settings(series) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name in ("h", "xi", "rtol", "formulation", "linear_solver"):
        value = series[name].values[0]
        out[name] = float(value) if isinstance(value, (float, np.floating)) else str(value)
    rtol = out.get("rtol")
    label = str(series["method"].values[0])
    out["atol"] = float(label.split("atol=")[1]) if "atol=" in label else rtol
    return out


def pareto_front(errors: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points no other point beats in both error and time, by increasing error."""
    order = np.lexsort((times, errors))
    front_e, front_t, best = [], [], np.inf
    for k in order:
        if times[k] < best:
            best = times[k]
            front_e.append(errors[k])
            front_t.append(times[k])
    return np.array(front_e), np.array(front_t)


def _plot(ds, path: Path) -> Path:
    """The work-precision figure, drawn in rodsim's style (:func:`rodsim.app.figures.style`)."""
    from rodsim.app.figures import style  # selects the Agg backend

    with style():
        return _draw(ds, path)


def _draw(ds, path: Path) -> Path:
    """The panels of :func:`_plot`: one row per scene, one column per family group; a panel
    whose families ran nothing at this size says so instead of staying blank."""
    import matplotlib.pyplot as plt

    scenes = list(dict.fromkeys(ds["scene"].values.tolist()))
    panels = [("paper integrator", ("paper",)), ("CVODE", ("cvode",)),
              ("IDA and scipy", ("ida", "scipy")), ("fastest of each family", ())]
    # Legends below their panels (8-pt text: a dozen methods would hide the curves).
    fig, axes = plt.subplots(len(scenes), len(panels), figsize=(5.2 * len(panels),
                                                                  6.6 * len(scenes)),
                             squeeze=False, sharey="row", constrained_layout=True)
    for row, scene in enumerate(scenes):
        here = ds.where(ds["scene"] == scene, drop=True)
        ok = here.where(here["success"] == 1, drop=True)
        static = ok.where(ok["family"] == "static", drop=True)
        for col, (title, families) in enumerate(panels):
            ax = axes[row, col]
            measured = int(here["family"].isin(list(families) or FAMILIES).sum())
            for family in families:
                part = ok.where(ok["family"] == family, drop=True)
                for label in dict.fromkeys(part["method"].values.tolist()):
                    series = part.where(part["method"] == label, drop=True).sortby("tolerance")
                    error = np.maximum(series["error"].values, ERROR_FLOOR)
                    ax.loglog(error, series["wall_time"].values, label=label,
                              **_style(label, family, _settings(series)))
            if not families:  # the Pareto front of every family
                for family in FAMILIES:
                    part = ok.where(ok["family"] == family, drop=True)
                    if not part.sizes.get("point", 0):
                        continue
                    e, t = pareto_front(np.maximum(part["error"].values, ERROR_FLOOR),
                                        part["wall_time"].values)
                    ax.loglog(e, t, drawstyle="steps-post", marker="o", ms=4,
                              color=FAMILY_COLOURS[family], label=family)
            if static.sizes.get("point", 0):
                ax.axhline(float(static["wall_time"].min()), color="black", ls="-.", lw=1,
                           label="static (Newton), fastest τ")
                ax.loglog(np.maximum(static["error"].values, ERROR_FLOOR),
                          static["wall_time"].values, "k*", ms=7)
            failed = here.where((here["success"] == 0)
                                & here["family"].isin(list(families)), drop=True)
            count = failed.sizes.get("point", 0)
            ax.set_title(f"{scene}: {title}" + (f"\n({count} failed runs not shown)"
                                                 if count else ""))
            if not measured:
                ax.text(0.5, 0.5, f"no {' or '.join(families)} runs at this size",
                        ha="center", va="center", transform=ax.transAxes)
            ax.set_xlabel("error / L [1] (largest control-point distance to static)")
            if col == 0:
                ax.set_ylabel("wall time to equilibrium [s]")
            ax.set_xlim(0.3 * ERROR_FLOOR, 1.0)
            ax.grid(True, which="major", alpha=0.3)
            if ax.get_legend_handles_labels()[0]:
                ax.legend(ncol=2 if len(families) else 1, loc="upper center",
                          bbox_to_anchor=(0.5, -0.16))
    fig.suptitle(textwrap.fill(f"Work-precision ({ds.attrs.get('size')}) — measured: "
                               f"{measured_result(ds)}", int(12 * fig.get_figwidth()))
                 + f"\nerrors below {ERROR_FLOOR:g} drawn at {ERROR_FLOOR:g}; "
                 f"{ds.attrs.get('machine_cpu', '')}, {ds.attrs.get('machine_date', '')}")
    fig.savefig(path, dpi=72)
    plt.close(fig)
    return path


#: The error the figure's title compares the families at [1].
TITLE_ERROR = 1e-6


def measured_result(ds) -> str:
    """The figure's result line, computed from the archive: per scene, the fastest static
    run with error ≤ :data:`TITLE_ERROR` and each other family's fastest such run against
    it (× static; "none" when no run of the family got there)."""
    parts = []
    for scene in dict.fromkeys(ds["scene"].values.tolist()):
        static, _ = best_time(ds, scene, "static", TITLE_ERROR)
        others = []
        for family in FAMILIES[1:]:
            if not bool((ds["family"] == family).any()):
                continue
            time, _ = best_time(ds, scene, family, TITLE_ERROR)
            others.append(f"{family} " + ("none" if np.isnan(time) else
                                           f"{time / static:.2g}×" if np.isfinite(static)
                                           else f"{1e3 * time:.3g} ms"))
        head = f"static {1e3 * static:.3g} ms" if np.isfinite(static) else "static none"
        parts.append(f"{scene}: {head}" + (f", {', '.join(others)}" if others else ""))
    return (f"fastest run to error ≤ {TITLE_ERROR:g} L — " + "; ".join(parts))


def best_time(ds, scene: str, family: str, error: float) -> tuple[float, str]:
    """Fastest successful run of ``family`` on ``scene`` with error ≤ ``error``."""
    mask = ((ds["scene"] == scene) & (ds["family"] == family) & (ds["success"] == 1)
            & (ds["error"] <= error)).values
    if not mask.any():
        return float("nan"), "-"
    times = ds["wall_time"].values[mask]
    k = int(np.argmin(times))
    point = np.flatnonzero(mask)[k]
    return float(times[k]), (f"{ds['method'].values[point]}, "
                             f"τ={ds['tolerance'].values[point]:.0e}")


#: Error levels at which the families are compared ("at equal error").
COMPARE_AT = (1e-4, 1e-6, 1e-8, 1e-10)
FAMILIES = ("static", "paper", "cvode", "ida", "scipy")


def _markdown(ds, profile: dict[str, Any] | None = None) -> str:
    size = ds.attrs["size"]
    scenes = list(dict.fromkeys(ds["scene"].values.tolist()))
    lines = [f"# Work-precision benchmark ({size})", "",
             "Error = largest control-point distance (every rod) to the exact discrete "
             "equilibrium (`static`, tolerance 1e-12) / L. Time = wall time to equilibrium, "
             f"minimum over up to {ds.attrs['timed_repeats']} timed runs after a warm-up "
             "(model assembly excluded).", "", machine_line(ds.attrs), ""]
    for name in ds["scene_name"].values:
        sel = ds.sel(scene_name=name)
        lines.append(f"- `{name}`: {int(sel['scene_unknowns'])} unknowns, "
                     f"{int(sel['scene_nonzeros'])} Jacobian non-zeros, half-bandwidth "
                     f"{int(sel['scene_bandwidth'])}; residual floor "
                     f"{float(sel['scene_residual_floor']):.3g}.")
    lines += ["", "## Fastest run reaching each error level", "",
              "For each family, the fastest successful run (any configuration, any τ) whose "
              "error is at most the level; ratios are to the same level's `static` and "
              "`paper` times.", ""]
    rows = []
    for scene in scenes:
        for level in COMPARE_AT:
            static, _ = best_time(ds, scene, "static", level)
            paper, _ = best_time(ds, scene, "paper", level)
            for family in FAMILIES:
                t, where = best_time(ds, scene, family, level)
                rows.append([scene, f"{level:.0e}", family, seconds(t),
                             fmt(t / static), fmt(t / paper), where])
    lines += markdown_table(["scene", "error ≤", "family", "time", "× static", "× paper",
                             "fastest configuration"], rows, "lllrrrl")
    if len(scenes) > 1:
        lines += ["", "## Tendon scene over single rod (same family, same error level)", ""]
        rows = []
        for level in COMPARE_AT:
            for family in FAMILIES:
                single, _ = best_time(ds, scenes[0], family, level)
                tendon, _ = best_time(ds, scenes[1], family, level)
                rows.append([f"{level:.0e}", family, seconds(single), seconds(tendon),
                             fmt(tendon / single)])
        lines += markdown_table(["error ≤", "family", scenes[0], scenes[1], "ratio"], rows,
                                "llrrr")
    lines += ["", "## Every run", ""]
    rows = []
    for i in range(ds.sizes["point"]):
        p = ds.isel(point=i)
        status = "ok" if int(p["success"]) else f"FAILED: {str(p['message'].values)[:120]}"
        rows.append([str(p["scene"].values), str(p["method"].values),
                     f"{float(p['tolerance']):.0e}", fmt(float(p["error"])),
                     seconds(float(p["wall_time"])), int(p["timed_runs"]),
                     count(float(p["steps"])), count(float(p["force_evals"])),
                     count(float(p["jacobian_evals"])), status])
    lines += markdown_table(["scene", "method", "τ", "error / L", "time", "timed runs",
                             "steps", "F evals", "J evals", "status"], rows, "lllrrrrrrl")
    if profile:
        lines += ["", "## Where the time goes", "",
                  "One evaluation at the rest state (minimum over 5 × 50 calls):", ""]
        lines += markdown_table(
            ["scene", "unknowns", "Jacobian non-zeros", "F(x)", "∂F/∂x"],
            [[name, int(c["unknowns"]), int(c["nonzeros"]), f"{1e6 * c['force_s']:.0f} µs",
              f"{1e6 * c['jacobian_s']:.0f} µs"]
             for name, c in profile["evaluation_cost"].items()])
        lines += ["", f"cProfile of one solve (τ = {profile['tolerance']:g}, fresh model, "
                  "after a warm-up):", ""]
        for p in profile["profiles"]:
            lines += markdown_profile(f"{p['scene']}: {p['label']}", p)
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------- run


def run(size: str, output_dir: Path | str, progress: Progress | None = None) -> list[Path]:
    """Run the benchmark at ``size`` (``small`` or ``full``); returns the written paths."""
    from rodsim.io.archive import write_dataset

    if size not in ("small", "full"):
        raise ValueError(f"size {size!r}: expected 'small' or 'full'")
    progress = progress or (lambda fraction, status: None)
    output = Path(output_dir)
    output.mkdir(parents=True, exist_ok=True)
    # Timed runs after the warm-up, per scene (the tendon scene's runs are 10× longer).
    repeats = {"table1-50g": 1, "table3-catheter1": 1} if size == "small" else {
        "table1-50g": 3, "table3-catheter1": 2}
    max_wall_time = 20.0
    long_run = 5.0 if size == "small" else 10.0

    references: dict[str, tuple[np.ndarray, float]] = {}
    infos: dict[str, dict[str, Any]] = {}
    points: list[Point] = []
    for scene in SCENES:
        progress(None, f"work-precision: reference solve of {scene}")
        reference, length, info = _reference(scene)
        references[scene], infos[scene] = (reference, length), info
        methods, tolerances = methods_for(size, scene)
        points += [Point(scene, method, tol, max_wall_time, repeats[scene])
                   for method in methods for tol in tolerances]
    _measure(points, references, long_run, progress)

    ds = _dataset(points, infos, size, repeats)
    stem = output / f"work-precision-{size}"
    paths = [write_dataset(ds, stem.with_suffix(".nc"))]
    if size == "full":
        profile_path = stem.parent / f"{stem.name}-profile.json"
        profile_path.write_text(json.dumps(profiles(progress), indent=1) + "\n")
        paths.append(profile_path)
    return paths + report(ds, stem)


def report(ds, stem: Path | str) -> list[Path]:
    """Draw the figure and write the markdown of a work-precision Dataset, with the
    profiles of ``<stem>-profile.json`` if that file exists (this also works from a
    re-opened archive: ``report(xr.open_dataset(path).load(), path.with_suffix(""))``)."""
    stem = Path(stem)
    profile_path = stem.parent / f"{stem.name}-profile.json"
    profile = json.loads(profile_path.read_text()) if profile_path.exists() else None
    markdown = stem.with_suffix(".md")
    markdown.write_text(_markdown(ds, profile))
    return [_plot(ds, stem.with_suffix(".png")), markdown]
