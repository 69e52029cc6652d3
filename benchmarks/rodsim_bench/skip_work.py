"""What skipping unneeded work buys (``rodsim bench skip-work``), measured in one run.

Rows (each a ratio of two timings taken in the same run, minimum of repeats after a
warm-up):

- **formulation**: CVODE and IDA on the overdamped (first-order) vs the inertial
  (second-order) pseudo-dynamics, when only the equilibrium is wanted;
- **unlisted terms**: the cost of a term a scene lists but does not need (self-weight with
  g = 0) against not listing it — terms a scene does not list are never built;
- **Jacobian reuse**: rodsim's Newton solver (rodsim/solvers/newton.py) with a fresh analytic
  Jacobian every iteration (what ``static`` does) against its ``reuse="chord"`` option (one
  Jacobian and one factorisation reused throughout) and ``reuse="lagged"`` (the
  factorisation is reused while each iteration at least halves the residual, refreshed
  otherwise — SUNDIALS' own policy, in spirit);
- **planar reduction**: the static Newton solve of a planar scene with its linear systems
  reduced to the in-plane coordinates (x, y and the two quaternion combinations of a
  rotation about z) against the full 3-D systems — the forces and Jacobians are still
  evaluated in 3-D, so this measures what dropping the out-of-plane unknowns would save;
- **load ramp** and **mass scaling**: the pseudo-dynamics options, on and off;
- **obstacles**: a scene without obstacles builds no contact term and pays nothing for
  contact; the row gives what a listed obstacle out of the rod's reach costs per force and
  Jacobian evaluation.

Outputs ``skip-work-<size>.nc`` and ``skip-work-<size>.md`` (with the machine description).
"""

from __future__ import annotations

import time
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import xarray as xr

import rodsim
from rodsim.core.model import Model
from rodsim.core.rod.quaternion import rest_quaternion
from rodsim.core.scene import scene_paths
from rodsim.io.archive import write_dataset
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.newton import JACOBIAN_REUSE, NewtonProblem, newton
from rodsim_bench.machine import machine

__all__ = ["run"]

SIZES = {"small": {"repeats": 1, "nodes": (20,), "scenes": ("table1-50g",)},
         "full": {"repeats": 5, "nodes": (40, 1000),
                  "scenes": ("table1-50g", "table3-catheter1")}}


def _best(function: Callable[[], object], repeats: int) -> tuple[float, object]:
    """Minimum wall time over ``repeats`` runs after one warm-up, and the last result."""
    out = function()
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        out = function()
        best = min(best, time.perf_counter() - start)
    return best, out


def _planar_basis(model: Model) -> sp.csc_matrix:
    """Columns spanning the in-plane motions: x, y of every node and, per quaternion, the
    two-dimensional span of rotations about z applied to the rest orientation."""
    q0 = rest_quaternion()
    # d/dθ of rot_z(θ) ⊗ q0 at θ = 0 is ½ (ẑ, 0) ⊗ q0 (vector part first, real part last)
    z_axis = np.array([0.0, 0.0, 1.0])
    turning = 0.5 * np.r_[q0[3] * z_axis + np.cross(z_axis, q0[:3]), -z_axis @ q0[:3]]
    columns, rows, values = [], [], []
    free_of = {int(i): k for k, i in enumerate(model.free)}
    column = 0
    for rod in model.rods.values():
        for node in rod.layout.position_index:
            for axis in (0, 1):
                if int(node[axis]) in free_of:
                    rows.append(free_of[int(node[axis])])
                    values.append(1.0)
                    columns.append(column)
                    column += 1
        for quaternion in rod.layout.quaternion_index:
            if int(quaternion[0]) not in free_of:
                continue
            for direction in (q0, turning / np.linalg.norm(turning)):
                for k in range(4):
                    rows.append(free_of[int(quaternion[k])])
                    values.append(direction[k])
                    columns.append(column)
                column += 1
    return sp.csc_matrix((values, (rows, columns)), shape=(model.n, column))


class PlanarLinear:
    """The linear solves of :func:`rodsim.solvers.newton.newton` restricted to the in-plane
    coordinates: J is projected onto the columns of ``basis`` (Bᵀ J B, SuperLU) and the step
    mapped back (B Δp); forces and Jacobians are still evaluated in 3-D."""

    def __init__(self, model: Model, basis: sp.csc_matrix) -> None:
        self.model, self.basis = model, basis
        self._full = model.pattern
        self._diagonal = LinearSolver(model.pattern, model.pattern_rows, model.pattern_cols,
                                      (model.band.lower, model.band.upper), False)

    def diagonal(self, data: np.ndarray) -> np.ndarray:
        return self._diagonal.diagonal(data)

    def factorized(self, data: np.ndarray) -> Callable[[np.ndarray], np.ndarray] | None:
        matrix = sp.csc_matrix((data, self._full.indices, self._full.indptr),
                               shape=self._full.shape)
        try:
            lu = spla.splu((self.basis.T @ matrix @ self.basis).tocsc())
        except RuntimeError:
            return None
        return lambda rhs: self.basis @ lu.solve(self.basis.T @ rhs)

    def solve(self, data: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        solve = self.factorized(data)
        return solve(rhs) if solve is not None else np.full(self.model.n, np.nan)


def _newton(model: Model, basis: sp.csc_matrix | None, reuse: str = "fresh",
            tolerance: float = 1e-9, limit: int = 400) -> tuple[int, np.ndarray, bool]:
    """rodsim's Newton solver (:func:`rodsim.solvers.newton.newton`, energy line search) at
    full load from rest, on the planar coordinates (``basis``) or all of them, with a
    Jacobian policy from :data:`~rodsim.solvers.newton.JACOBIAN_REUSE`: (iterations, state,
    converged)."""
    linear = (PlanarLinear(model, basis) if basis is not None else
              LinearSolver(model.pattern, model.pattern_rows, model.pattern_cols,
                           (model.band.lower, model.band.upper), model.conservative))
    problem = NewtonProblem(force=model.force, jacobian=model.jacobian_data, linear=linear,
                            force_residual=model.force_residual, weight=model.residual_weight,
                            potential=model.energy)
    outcome = newton(problem, model.x0, max(tolerance, model.residual_floor), limit,
                     polish=False, reuse=reuse)
    return outcome.iterations, outcome.x, outcome.converged


def _iterations(count: int, converged: bool) -> str:
    return f"{count}" if converged else f"{count} (not converged: the cap)"


def run(size: str, output_dir: Path, progress=None) -> list[Path]:
    setting = SIZES[size]
    repeats = setting["repeats"]
    rows: list[dict[str, object]] = []

    def row(name: str, scene: str, what: str, fast: float, slow: float, note: str) -> None:
        rows.append({"row": name, "scene": scene, "compared": what, "time_a": fast,
                     "time_b": slow, "gain": slow / fast, "note": note})
        if progress is not None:
            progress(None, f"skip-work: {name} on {scene}: {slow / fast:.2f}×")

    def timed(scene: str, integrator: str, overrides: list[str]) -> float:
        """Best solve time (model built outside the timing); NaN if the run fails."""
        loaded = rodsim.load_scene(scene, [*overrides, "max_wall_time=60"])
        model = Model(loaded)
        t, result = _best(lambda: rodsim.solve(loaded, integrator, model=model), repeats)
        return t if result.success else np.nan

    for scene in setting["scenes"]:
        for integrator in ("cvode", "ida"):
            times = {form: timed(scene, integrator,
                                 [f"solver.{integrator}.formulation='{form}'"])
                     for form in ("overdamped", "inertial")}
            failed = [form for form, t in times.items() if np.isnan(t)]
            row("formulation", scene, f"{integrator}: overdamped (a) vs inertial (b)",
                times["overdamped"], times["inertial"],
                f"{' and '.join(failed)} failed" if failed else "")
        for option in ("load_ramp", "mass_scaling"):
            on, off = timed(scene, "cvode", []), timed(scene, "cvode", [f"solver.cvode.{option}=0"])
            row(option, scene, "cvode: default on (a) vs off (b)", on, off,
                "off failed" if np.isnan(off) else "on failed" if np.isnan(on) else "")

    base = rodsim.load_scene("table1-50g")
    listed = base.with_overrides(["terms=['stretch','bend_twist','centerline','tip_load',"
                                  "'gravity']", "gravity.gravity=0"])
    for scene_label, scene in (("unlisted", base), ("listed, g = 0", listed)):
        model = Model(scene)
        x = model.x0 + 1e-4
        t, _ = _best(lambda m=model, y=x: [m.force(y) for _ in range(200)], repeats)
        rows_time = t / 200
        rows.append({"row": "unlisted terms", "scene": "table1-50g",
                     "compared": f"force evaluation, gravity {scene_label}", "time_a": rows_time,
                     "time_b": np.nan, "gain": np.nan, "note": "(a): one F(x) evaluation"})

    # Obstacles: a scene without them builds no contact term (nothing to pay); one that lists
    # a plane out of the rod's reach pays the idle term's evaluation.
    table = tomllib.loads(scene_paths()["table1-50g"].read_text(encoding="utf-8"))
    far = rodsim.load_scene(table | {"obstacles": {"far": {
        "type": "plane", "rods": ["catheter"], "point": [0.0, 1.0, 0.0],
        "normal": [0.0, -1.0, 0.0]}}})
    times = []
    for scene in (base, far):
        model = Model(scene)
        x = model.x0 + 1e-4
        t, _ = _best(lambda m=model, y=x: [m.evaluate(y) for _ in range(200)], repeats)
        times.append(t / 200)
    row("obstacles", "table1-50g", "F and J: no obstacle (a) vs a plane out of reach (b)",
        times[0], times[1], "(a) builds no contact term")

    for nodes in setting["nodes"]:
        model = rodsim.build_model(base.with_overrides([f"nodes={nodes}"]))
        basis = _planar_basis(model)
        runs = {policy: _best(lambda m=model, p=policy: _newton(m, None, p), repeats)
                for policy in JACOBIAN_REUSE}
        t_full, (n_full, x_full, _) = runs["fresh"]
        t_plane, (n_plane, x_plane, _) = _best(lambda m=model, b=basis: _newton(m, b),
                                               repeats)
        for policy in ("chord", "lagged"):
            t_reuse, (n_reuse, _, converged) = runs[policy]
            row("Jacobian reuse", f"table1-50g N={nodes}",
                f"fresh Jacobian (a) vs {policy} (b)", t_full,
                t_reuse if converged else np.nan,
                f"iterations {n_full} vs {_iterations(n_reuse, converged)}"
                + ("" if converged else f"; (b) ran {t_reuse:.3g} s and failed"))
        same = float(np.max(np.abs(x_plane - x_full)))
        row("planar reduction", f"table1-50g N={nodes}",
            f"planar systems, {basis.shape[1]} unknowns (a) vs 3-D, {model.n} (b)", t_plane,
            t_full, f"iterations {n_plane} vs {n_full}; states differ by {same:.1e}")

    ds = xr.Dataset(
        {key: ("row", [r[key] for r in rows]) for key in ("time_a", "time_b", "gain")}
        | {key: ("row", [str(r[key]) for r in rows]) for key in ("scene", "compared", "note")},
        coords={"row": ("row", [str(r["row"]) for r in rows])})
    for key, units in (("time_a", "s"), ("time_b", "s"), ("gain", "1")):
        ds[key].attrs = {"units": units, "long_name": {"time_a": "wall time of (a)",
                                                       "time_b": "wall time of (b)",
                                                       "gain": "time (b) / time (a)"}[key]}
    ds.attrs = {"title": "rodsim: what skipping unneeded work buys", "size": size,
                **{f"machine_{k}": v for k, v in machine().items()}}
    output = Path(output_dir) / f"skip-work-{size}.nc"
    write_dataset(ds, output)
    table = output.with_suffix(".md")
    lines = [f"# Skip what a scene doesn't need ({size}, minimum of {repeats} after a warm-up)",
             "", "| row | scene | compared | (a) [s] | (b) [s] | (b)/(a) | note |",
             "|---|---|---|--:|--:|--:|---|"]
    lines += [f"| {r['row']} | {r['scene']} | {r['compared']} | {r['time_a']:.4g} | "
              f"{r['time_b']:.4g} | {r['gain']:.3g} | {r['note']} |" for r in rows]
    lines += ["", "Machine: " + ", ".join(f"{k} {v}" for k, v in machine().items())]
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return [output, table]
