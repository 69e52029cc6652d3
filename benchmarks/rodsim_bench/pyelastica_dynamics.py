"""Benchmark ``pyelastica-dynamics``: PyElastica 1.0 against rodsim in physical time, CPU at
equal tip accuracy (issue 33's speed aim: "PyElastica 1.0's dynamic-cantilever example and
the steel rod, at equal or better tip accuracy: ≥ 100× less CPU than PyElastica").

PyElastica is never a rodsim dependency: pip install pyelastica==1.0.0 first — into the
environment, or into a folder of its own named by the environment variable
``RODSIM_PYELASTICA_PATH`` (``pip install --target DIR pyelastica==1.0.0 tqdm cma
--no-deps``; numba, numpy and scipy come from rodsim's environment). It runs in a process
of its own (rodsim_bench/pyelastica_dynamics_worker.py). Without it, ``run`` prints
``INSTALL_HINT`` and writes nothing.

Two cases, each the same physics in both codes: a straight clamped rod along +x, extensible
and shearable (PyElastica's shear stiffness α_c G A, α_c = 27/28, is rodsim's centerline
penalty K_P; its twist G J is rodsim's with the same G; E A, E I, ρ A and ρ I alike), no
gravity, undamped.

- ``example``: PyElastica's dynamic-cantilever example (examples/DynamicCantileverCase in
  its repository): L = 1 m, r = 0.02 m, E = 1e5 Pa, ρ = 2000 kg/m³, G = E/3 (its default,
  Poisson 0.5), 100 elements, dt = 0.05 dl, started straight with the Euler–Bernoulli first
  mode's velocity field along z (tip speed 5 mm/s, amplitude 0.02 L), 300 s (its
  final_time, about 12 periods).
- ``steel``: the steel rod of issue 33 (L = 0.4 m, r = 1.2 mm, E = 207 GPa, ρ = 8000,
  G = E/2.6) held at rest by a 2 N tip force along −y (deflection 0.3 L) and released at
  t = 0, one period of the first mode. PyElastica finds its own equilibrium under the force
  first (a run damped by ``AnalyticalLinearDamper`` at ν = 2 ω₁ for 18/ω₁ at C = 0.9, not
  timed: the first mode critically damped, left at (1 + 18) e⁻¹⁸ ≈ 3e-7 of the deflection);
  rodsim's time includes its static solve of the start (as a user calls
  ``rodsim.simulate``).

Tip error: the largest distance / L over the output times (20 a period) from a reference of
our own, converged in space and time and stated with its error estimates (the size of each
extrapolation's correction) — ``example``: rodsim's midpoint rule, Richardson-extrapolated
in N (41, 81 at full size) and in the step (200 and 400 a period), both second order;
``steel``: the midpoint rule at 3200 steps a period, Richardson-extrapolated in N (41, 81),
its time error bounded by the difference to 1600 steps a period (a sudden release excites
every mode, which the midpoint rule steps over with a first-order error from them; CVODE
at rtol = atol = 1e-8 resolves them and took 200 000 steps for 2 % of the period at
N = 41). Cross-checks against Euler–Bernoulli: the first natural
frequency (``rodsim.modes`` at the finest N; the difference is the rod's shear and rotary
inertia) and, for ``example``, the frequency and amplitude fitted to the reference's tip.

PyElastica steps with ``PositionVerlet`` at a Courant number C = dt ω_max / 2, ω_max the
fastest frequency of an element (``Case.fastest``: its stretch, 2 √(E/ρ) / dl, and its
rotation against the shear spring, √(α_c G A / (ρ I)), which sets the step of a thin rod,
dl ≫ r): the example's step (dt = 0.05 dl on its rod, C = 0.367; that C on the steel rod),
near its stability limit (C = 0.9; a probe at C = 1.0, which diverged on the steel rod in
30 000 steps), at several N. rodsim: the midpoint rule at several N and
steps a period, CVODE and IDA (BDF order ≤ 2) at several tolerances. CPU by
``time.process_time`` (PyElastica: the stepping only; rodsim: the whole ``rodsim.simulate``),
minimum of the repeats, after a warm-up that compiles or loads both codes' numba kernels.
Ratio: a PyElastica run's CPU over the cheapest rodsim run whose tip error is no larger.

Writes ``pyelastica-dynamics-<size>.json`` and ``.md``. Nothing is asserted.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

import rodsim
from rodsim.solvers.base import Progress
from rodsim.solvers.physical.coordinates import PhysicalCoordinates
from rodsim_bench.machine import machine, write_report

__all__ = ["run", "Case", "CASES", "INSTALL_HINT", "mode_shape", "rodsim_velocity"]

INSTALL_HINT = ("PyElastica is not installed; this benchmark needs it: pip install "
                "pyelastica==1.0.0 first (optional, never a rodsim dependency), or into a "
                "folder named by RODSIM_PYELASTICA_PATH")
#: PyElastica 1.0's shear coefficient of a circular section (α_c).
ALPHA_C = 27.0 / 28.0
#: First root β₁L of 1 + cos x cosh x = 0 (clamped–free).
BETA1 = 1.8751040687119611
#: The PyElastica example's dt / dl [s/m] (dt = 0.05 dl; a Courant number of 0.367 there).
EXAMPLE_DT_PER_DL = 0.05
#: The example's elements.
EXAMPLE_ELEMENTS = 100
#: Output times per period of the first mode.
OUTPUTS_PER_PERIOD = 20


@dataclass(frozen=True)
class Case:
    """A clamped straight rod along +x and how it is set moving."""

    name: str
    length: float
    radius: float
    youngs_modulus: float
    poisson_ratio: float  # G = E / (2 (1 + ν)) for shear (α_c G A) and twist (G J)
    density: float
    end_velocity: float = 0.0  # first mode's velocity field, tip speed along z [m/s]
    tip_force: float = 0.0  # released from this force along −y [N]
    horizon: float | None = None  # [s]; None: one period

    @property
    def area(self) -> float:
        return math.pi * self.radius**2

    @property
    def second_moment(self) -> float:
        return math.pi * self.radius**4 / 4.0

    @property
    def shear_modulus(self) -> float:
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def penalty(self) -> float:
        """rodsim's K_P [N] equal to PyElastica's shear stiffness α_c G A."""
        return ALPHA_C * self.shear_modulus * self.area

    @property
    def wave_speed(self) -> float:
        return math.sqrt(self.youngs_modulus / self.density)

    @property
    def omega(self) -> float:
        """Euler–Bernoulli first angular frequency [rad/s]."""
        return BETA1**2 * math.sqrt(self.youngs_modulus * self.second_moment
                                    / (self.density * self.area * self.length**4))

    @property
    def period(self) -> float:
        return 2.0 * math.pi / self.omega

    def fastest(self, elements: int) -> float:
        """The fastest angular frequency of PyElastica's rod at ``elements`` [rad/s]: an
        element's stretch and bending, 2 √(E/ρ) / dl, and its rotation against the shear
        spring, √(α_c G A / (ρ I)) (the one that limits dt when dl ≫ r)."""
        dl = self.length / elements
        return math.sqrt((2.0 * self.wave_speed / dl) ** 2
                         + self.penalty / (self.density * self.second_moment))


EXAMPLE = Case("example", 1.0, 0.02, 1e5, 0.5, 2000.0, end_velocity=0.005, horizon=300.0)
STEEL = Case("steel", 0.4, 1.2e-3, 207e9, 0.3, 8000.0, tip_force=2.0)
CASES = (EXAMPLE, STEEL)


def courant(case: Case, elements: int, dt: float) -> float:
    """PyElastica's step as a Courant number, dt ω_max / 2 (PositionVerlet is stable below
    1 for a linear oscillator; measured on the steel rod: 0.9 ran, 1.0 diverged)."""
    return dt * case.fastest(elements) / 2.0


#: The example's own step, dt = 0.05 dl at 100 elements, as a Courant number (0.367).
EXAMPLE_COURANT = courant(EXAMPLE, EXAMPLE_ELEMENTS, EXAMPLE_DT_PER_DL
                          * EXAMPLE.length / EXAMPLE_ELEMENTS)


def pyelastica_dt(case: Case, elements: int, number: float | None) -> float:
    """PyElastica's dt at Courant number ``number``; None: the example's rule (dt = 0.05 dl
    on its own rod, its Courant number EXAMPLE_COURANT on another)."""
    if number is None:
        if case is EXAMPLE:
            return EXAMPLE_DT_PER_DL * case.length / elements
        number = EXAMPLE_COURANT
    return 2.0 * number / case.fastest(elements)

#: Per size: the horizon's fraction (small: a smoke run), repeats, the references' N,
#: steps a period (half and full), PyElastica's (elements, Courant number)
#: and rodsim's runs per case.
SIZES: dict[str, dict[str, Any]] = {
    "small": {"fraction": 0.25, "repeats": 1, "reference_nodes": (11, 21),
              "reference_steps": {"example": (100, 200), "steel": (200, 400)},
              "pyelastica": {"example": ((25, None), (25, 0.9)),
                             "steel": ((10, None), (10, 0.9))},
              "rodsim": {"example": (("midpoint", 11, 50), ("midpoint", 11, 100)),
                         "steel": (("midpoint", 11, 100), ("cvode", 11, 1e-5))}},
    "full": {"fraction": 1.0, "repeats": 2, "reference_nodes": (41, 81),
             "reference_steps": {"example": (200, 400), "steel": (1600, 3200)},
             "pyelastica": {"example": ((100, None), (100, 0.9), (100, 1.0), (25, 0.9),
                                        (50, 0.9)),
                            "steel": ((20, None), (40, None), (20, 0.9), (40, 0.9),
                                      (80, 0.9), (40, 1.0))},
             "rodsim": {"example": (("midpoint", 6, 25), ("midpoint", 11, 20),
                                    ("midpoint", 11, 25),
                                    ("midpoint", 11, 50), ("midpoint", 11, 100),
                                    ("midpoint", 21, 50), ("midpoint", 21, 100),
                                    ("midpoint", 21, 200), ("midpoint", 41, 200),
                                    ("cvode", 11, 1e-4)),
                        "steel": (("midpoint", 6, 25), ("midpoint", 11, 25),
                                  ("midpoint", 11, 30), ("midpoint", 11, 40),
                                  ("midpoint", 11, 50), ("midpoint", 11, 100),
                                  ("midpoint", 11, 200),
                                  ("midpoint", 21, 200), ("midpoint", 21, 400),
                                  ("midpoint", 41, 400), ("midpoint", 41, 800),
                                  ("cvode", 11, 1e-5), ("cvode", 21, 1e-5),
                                  ("ida", 11, 1e-5))}},
}


def mode_shape(x: np.ndarray, length: float) -> np.ndarray:
    """The clamped–free Euler–Bernoulli first mode at ``x``, 1 at the tip."""
    def shape(s):
        b = BETA1 * np.asarray(s, float) / length
        ratio = (math.cosh(BETA1) + math.cos(BETA1)) / (math.sinh(BETA1) + math.sin(BETA1))
        return np.cosh(b) - np.cos(b) - ratio * (np.sinh(b) - np.sin(b))

    return shape(x) / shape(length)


def scene(case: Case, nodes: int) -> dict[str, Any]:
    """The rodsim scene of ``case`` at ``nodes``."""
    terms = ["stretch", "bend_twist", "centerline"]
    rod: dict[str, Any] = {"length": case.length, "radius": case.radius,
                           "youngs_modulus": case.youngs_modulus, "density": case.density,
                           "poisson_ratio": case.poisson_ratio, "nodes": nodes,
                           "centerline": {"K_P": case.penalty}}
    if case.tip_force:
        terms.append("tip_load")
        rod["tip_load"] = {"force": [0.0, 0.0, 0.0], "mass": 0.0}
    rod["terms"] = terms
    return {"name": f"pyelastica-{case.name}", "rods": {"rod": rod}}


def rodsim_velocity(case: Case, nodes: int) -> np.ndarray:
    """The physical velocities (each free position coordinate's rate, then each free
    segment's body rates, zero) of the first mode's field along z, tip speed
    ``end_velocity``, on rodsim's rod at ``nodes``."""
    model = rodsim.build_model(rodsim.load_scene(scene(case, nodes)))
    coordinates = PhysicalCoordinates.of(model, model.x0)
    (rod,) = model.rods.values()
    full = model.free[coordinates.positions]
    index = rod.layout.position_index
    node = np.array([np.argwhere(index == f)[0, 0] for f in full])
    axis = np.array([np.argwhere(index == f)[0, 1] for f in full])
    x = node * case.length / (nodes - 1)
    velocity = np.where(axis == 2, case.end_velocity * mode_shape(x, case.length), 0.0)
    return np.concatenate([velocity, np.zeros(3 * len(coordinates.quaternions))])


def simulate(case: Case, nodes: int, horizon: float, integrator: str, setting: float,
             strict: bool = True) -> tuple[float, Any]:
    """(CPU [s], Simulation) of one rodsim run: ``setting`` is steps a period (midpoint) or
    rtol = atol (CVODE, IDA; BDF order ≤ 2). A failed run raises when ``strict``."""
    options: dict[str, Any] = {"output_dt": case.period / OUTPUTS_PER_PERIOD,
                               "integrator": integrator}
    if integrator == "midpoint":
        options["step"] = case.period / setting
    else:
        options |= {"rtol": setting, "atol": setting, "max_order": 2}
    if case.tip_force:
        options["initial"] = {"tip_load.force": [0.0, -case.tip_force, 0.0]}
    else:
        options["initial_velocity"] = rodsim_velocity(case, nodes)
    started = time.process_time()
    result = rodsim.simulate(scene(case, nodes), horizon, **options)
    cpu = time.process_time() - started
    if strict and not result.success:
        raise RuntimeError(f"{case.name}: rodsim {integrator} at N = {nodes}: "
                           f"{result.message}")
    return cpu, result


def reference(case: Case, horizon: float, config: dict[str, Any], progress: Progress
              ) -> dict[str, Any]:
    """The converged tip trajectory of ``case`` (module docstring) with its error
    estimates [/ L]."""
    coarse, fine = config["reference_nodes"]
    tips = {}
    slow, quick = config["reference_steps"][case.name]
    for n, steps in ((coarse, quick), (fine, quick), (fine, slow)):
        progress(None, f"pyelastica-dynamics: {case.name} reference, midpoint "
                 f"{steps} steps a period, N = {n}")
        _, result = simulate(case, n, horizon, "midpoint", steps)
        tips[(n, steps)] = result.positions[:, -1]
    best = tips[(fine, quick)]
    space = (best - tips[(coarse, quick)]) / 3.0
    if case.tip_force:
        # A sudden release: the midpoint rule steps over the fast modes it excites, with an
        # error of first order from them; the time error is bounded by the difference to
        # half as many steps, not extrapolated.
        time_ = best - tips[(fine, slow)]
        tip = best + space
        method = (f"midpoint rule at {quick} steps a period, N = {coarse} and {fine} "
                  "Richardson-extrapolated in N (second order)")
        time_label = f"{quick} against {slow} steps a period"
    else:
        time_ = (best - tips[(fine, slow)]) / 3.0
        tip = best + space + time_
        method = (f"midpoint rule, N = {coarse} and {fine} and {slow} and {quick} steps a "
                  "period, Richardson-extrapolated in both (second order)")
        time_label = f"{quick} against {slow} steps a period, /3"
    times = np.asarray(result.times)
    modes = rodsim.modes(scene(case, fine), count=1)
    out: dict[str, Any] = {
        "method": method, "times": times.tolist(), "tip": tip.tolist(),
        "space_correction_over_L": float(np.max(np.linalg.norm(space, axis=1))
                                         / case.length),
        "time_correction_over_L": float(np.max(np.linalg.norm(time_, axis=1))
                                        / case.length),
        "time_correction_label": time_label,
        "euler_bernoulli_omega": case.omega,
        "modes_omega": float(2.0 * math.pi * modes.frequencies[0]),
    }
    out["modes_over_euler_bernoulli"] = out["modes_omega"] / case.omega - 1.0
    if case.end_velocity:
        out |= fitted(times, tip[:, 2], case)
        out["fitted_omega_over_modes"] = out["fitted_omega"] / out["modes_omega"] - 1.0
        out["euler_bernoulli_tip_distance_over_L"] = float(np.max(np.abs(
            tip[:, 2] - case.end_velocity / case.omega * np.sin(case.omega * times)))
            / case.length)
    return out


def fitted(times: np.ndarray, z: np.ndarray, case: Case) -> dict[str, float]:
    """A sin(ω t) fitted to the tip's z by least squares, against Euler–Bernoulli."""
    from scipy.optimize import least_squares

    amplitude = case.end_velocity / case.omega
    fit = least_squares(lambda p: p[0] * np.sin(p[1] * times) - z, [amplitude, case.omega],
                        x_scale=[amplitude, case.omega], xtol=1e-14, ftol=1e-14)
    return {"fitted_omega": float(fit.x[1]), "fitted_amplitude": float(fit.x[0]),
            "fitted_omega_over_euler_bernoulli": float(fit.x[1] / case.omega - 1.0),
            "fitted_amplitude_over_euler_bernoulli": float(fit.x[0] / amplitude - 1.0)}


def tip_error(tips: np.ndarray, ref: dict[str, Any], length: float) -> float:
    tips, target = np.asarray(tips, float), np.asarray(ref["tip"], float)
    if tips.shape != target.shape or not np.all(np.isfinite(tips)):
        return float("nan")
    return float(np.max(np.linalg.norm(tips - target, axis=1)) / length)


# -- PyElastica, in its own process -----------------------------------------------------------

def _environment() -> dict[str, str]:
    env = dict(os.environ)
    paths = [os.environ.get("RODSIM_PYELASTICA_PATH", ""), str(Path(__file__).parents[1]),
             env.get("PYTHONPATH", "")]
    env["PYTHONPATH"] = os.pathsep.join(p for p in paths if p)
    return env


def have_pyelastica() -> bool:
    """PyElastica imports in the worker's environment."""
    done = subprocess.run([sys.executable, "-c", "import elastica"], env=_environment(),
                          capture_output=True)
    return done.returncode == 0


def pyelastica_jobs(case: Case, horizon: float, times: list[float],
                    settings: tuple[tuple[int, float | None], ...], repeats: int
                    ) -> list[dict[str, Any]]:
    jobs = []
    for elements, number in settings:
        dt = pyelastica_dt(case, elements, number)
        job: dict[str, Any] = {
            "key": f"{case.name}:{elements}:{number}", "n_elem": elements,
            "courant": courant(case, elements, dt), "documented": number is None,
            "dt": dt, "t_end": horizon,
            "outputs": times, "repeats": repeats, "length": case.length,
            "radius": case.radius, "density": case.density,
            "youngs_modulus": case.youngs_modulus, "shear_modulus": case.shear_modulus}
        if case.tip_force:
            job |= {"tip_force": [0.0, -case.tip_force, 0.0],
                    "settle_dt": pyelastica_dt(case, elements, 0.9),
                    "settle_damping": 2.0 * case.omega, "settle_time": 18.0 / case.omega}
        else:
            job["velocity_z"] = (case.end_velocity * mode_shape(
                np.linspace(0.0, case.length, elements + 1), case.length)).tolist()
        jobs.append(job)
    return jobs


def run_pyelastica(jobs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    done = subprocess.run([sys.executable, "-m", "rodsim_bench.pyelastica_dynamics_worker"],
                          input=json.dumps(jobs), env=_environment(), capture_output=True,
                          text=True)
    if done.returncode != 0:
        raise RuntimeError(f"PyElastica's process failed: {done.stderr.strip()[-2000:]}")
    return json.loads(done.stdout)


# -- the comparison ---------------------------------------------------------------------------

def rodsim_rows(case: Case, horizon: float, ref: dict[str, Any],
                runs: tuple[tuple[str, int, float], ...], repeats: int, progress: Progress
                ) -> list[dict[str, Any]]:
    rows = []
    for integrator, nodes, setting in runs:
        progress(None, f"pyelastica-dynamics: {case.name}, rodsim {integrator} N = {nodes}, "
                 f"{setting:g}")
        cpu, result = [], None
        for _ in range(repeats):
            seconds, result = simulate(case, nodes, horizon, integrator, setting,
                                       strict=False)
            cpu.append(seconds)
            if not result.success:
                break
        assert result is not None
        if result.success and not np.allclose(result.times, ref["times"], rtol=0.0,
                                              atol=1e-9 * horizon):
            raise RuntimeError("rodsim's output times differ from the reference's")
        label = (f"{setting:g} steps a period" if integrator == "midpoint"
                 else f"rtol = atol = {setting:g}")
        rows.append({"code": "rodsim", "integrator": integrator, "nodes": nodes,
                     "setting": label, "steps": int(result.steps), "cpu_s": min(cpu),
                     "all_cpu_s": cpu, "success": bool(result.success),
                     "message": result.message,
                     "tip_error_over_L": tip_error(result.positions[:, -1], ref, case.length)
                     if result.success else math.nan})
    return rows


def pyelastica_rows(case: Case, results: list[dict[str, Any]], jobs: list[dict[str, Any]],
                    ref: dict[str, Any], rodsim: list[dict[str, Any]]) -> list[dict[str, Any]]:
    rows = []
    for job, result in zip(jobs, results, strict=True):
        error = tip_error(result["tips"], ref, case.length) if result["finite"] else math.nan
        row = {"code": "PyElastica", "nodes": job["n_elem"] + 1, "elements": job["n_elem"],
               "courant": job["courant"], "dt": job["dt"],
               "documented": job["documented"],
               "steps": result["steps"], "cpu_s": result["cpu_s"],
               "all_cpu_s": result["all_cpu_s"], "finite": result["finite"],
               "tip_error_over_L": error,
               "settle_cpu_s": result.get("settle_cpu_s"),
               "settle_final_speed": result.get("settle_final_speed")}
        better = [r for r in rodsim if r["tip_error_over_L"] <= error]
        if better:
            cheapest = min(better, key=lambda r: r["cpu_s"])
            row |= {"rodsim_match": f"{cheapest['integrator']}, N = {cheapest['nodes']}, "
                    f"{cheapest['setting']}", "rodsim_cpu_s": cheapest["cpu_s"],
                    "rodsim_tip_error_over_L": cheapest["tip_error_over_L"],
                    "cpu_ratio": result["cpu_s"] / cheapest["cpu_s"]}
        rows.append(row)
    return rows


def verdict(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The aim (≥ 100×) at PyElastica's documented settings and at its run most favourable
    to it (the smallest ratio)."""
    finite = [r for r in rows if r["finite"]]
    documented = [r for r in finite if r["documented"]]
    out: dict[str, Any] = {}
    for name, chosen in (("documented", documented), ("all", finite)):
        unmatched = [r for r in chosen if "cpu_ratio" not in r]
        ratios = [r["cpu_ratio"] for r in chosen if "cpu_ratio" in r]
        out[name] = {"smallest_ratio": min(ratios) if ratios else None,
                     "largest_ratio": max(ratios) if ratios else None,
                     "unmatched": len(unmatched),
                     "holds": bool(ratios) and not unmatched and min(ratios) >= 100.0}
    return out


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    if not have_pyelastica():
        progress(None, INSTALL_HINT)
        print(INSTALL_HINT, file=sys.stderr)
        return []
    config = SIZES[size]
    repeats = config["repeats"]
    progress(None, "pyelastica-dynamics: warm-up (rodsim's kernels)")
    for integrator, setting in (("midpoint", 10), ("cvode", 1e-3), ("ida", 1e-3)):
        for case in CASES:
            simulate(case, 6, case.period / 10, integrator, setting)
    cases: list[dict[str, Any]] = []
    paths: list[Path] = []
    for case in CASES:  # the report is written after each case
        horizon = config["fraction"] * (case.horizon or case.period)
        ref = reference(case, horizon, config, progress)
        jobs = pyelastica_jobs(case, horizon, ref["times"],
                               config["pyelastica"][case.name], repeats)
        progress(None, f"pyelastica-dynamics: {case.name}, PyElastica ({len(jobs)} runs)")
        results = run_pyelastica(jobs)
        rs = rodsim_rows(case, horizon, ref, config["rodsim"][case.name], repeats, progress)
        pe = pyelastica_rows(case, results, jobs, ref, rs)
        cases.append({"case": asdict(case) | {"period_s": case.period,
                                              "omega_rad_s": case.omega,
                                              "shear_modulus": case.shear_modulus,
                                              "K_P": case.penalty,
                                              "wave_speed": case.wave_speed},
                      "horizon_s": horizon, "reference": {k: v for k, v in ref.items()
                                                          if k not in ("times", "tip")},
                      "pyelastica": pe, "rodsim": rs, "verdict": verdict(pe),
                      "pyelastica_version": results[0]["pyelastica_version"]})
        report = {"benchmark": "pyelastica-dynamics", "size": size, "machine": machine(),
                  "repeats": repeats, "cases": cases}
        paths = write_report(report, markdown(report),
                             output_dir / f"pyelastica-dynamics-{size}")
    return paths


def _e(value: float | None) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{value:.2e}"


def _case_lines(entry: dict[str, Any]) -> list[str]:
    c, ref = entry["case"], entry["reference"]
    start = (f"released from a {c['tip_force']:g} N tip force along −y" if c["tip_force"]
             else f"started straight with the first mode's velocity (tip {c['end_velocity']:g}"
                  " m/s along z)")
    lines = [f"## {c['name']}: L = {c['length']:g} m, r = {c['radius']:g} m, "
             f"E = {c['youngs_modulus']:.3g} Pa, ρ = {c['density']:g}, G = "
             f"{c['shear_modulus']:.3g} Pa", "",
             f"{start}; {entry['horizon_s']:.4g} s ({entry['horizon_s'] / c['period_s']:.2f} "
             f"periods of {c['period_s']:.4g} s); K_P = α_c G A = {c['K_P']:.4g} N; tip at "
             f"{OUTPUTS_PER_PERIOD} outputs a period.", "",
             f"Reference: {ref['method']}; corrections {ref['space_correction_over_L']:.1e} L "
             f"(space) and {ref['time_correction_over_L']:.1e} L (time, "
             f"{ref['time_correction_label']}). First natural frequency: rodsim.modes "
             f"{ref['modes_over_euler_bernoulli']:+.2e} from Euler–Bernoulli (shear and "
             "rotary inertia)."]
    if "fitted_omega" in ref:
        lines[-1] += (f" A sin(ω t) fitted to the reference's tip: ω "
                      f"{ref['fitted_omega_over_euler_bernoulli']:+.2e} from Euler–Bernoulli "
                      f"and {ref['fitted_omega_over_modes']:+.2e} from rodsim.modes, A "
                      f"{ref['fitted_amplitude_over_euler_bernoulli']:+.2e} from V/ω; the "
                      f"Euler–Bernoulli tip is {ref['euler_bernoulli_tip_distance_over_L']:.2e}"
                      " L away at the end.")
    lines += ["", "| code | configuration | steps | tip error / L | CPU [s] | cheapest rodsim "
              "as accurate | its CPU [s] | CPU ratio |", "|---|---|--:|--:|--:|---|--:|--:|"]
    for r in entry["pyelastica"]:
        config = (f"N = {r['nodes']}, C = {r['courant']:.3g} (dt = {r['dt']:.3g} s)"
                  + (", the example's step" if r["documented"] else ""))
        error = _e(r["tip_error_over_L"]) if r["finite"] else "diverged"
        ratio = f"{r['cpu_ratio']:.1f}×" if "cpu_ratio" in r else "-"
        lines.append(f"| PyElastica | {config} | {r['steps']} | {error} | {r['cpu_s']:.3f} | "
                     f"{r.get('rodsim_match', 'none' if r['finite'] else '-')} | "
                     f"{r['rodsim_cpu_s']:.3f} | {ratio} |" if "cpu_ratio" in r else
                     f"| PyElastica | {config} | {r['steps']} | {error} | {r['cpu_s']:.3f} | "
                     f"{'none as accurate' if r['finite'] else '-'} | - | - |")
    for r in entry["rodsim"]:
        error = _e(r["tip_error_over_L"]) if r["success"] else f"failed: {r['message'][:60]}"
        lines.append(f"| rodsim | {r['integrator']}, N = {r['nodes']}, {r['setting']} | "
                     f"{r['steps']} | {error} | {r['cpu_s']:.3f} | | | |")
    v = entry["verdict"]
    lines += ["", "| PyElastica runs | smallest ratio | largest | without a match | ≥ 100×? |",
              "|---|--:|--:|--:|---|"]
    for name, label in (("documented", "the example's step"), ("all", "all")):
        w = v[name]
        small = "-" if w["smallest_ratio"] is None else f"{w['smallest_ratio']:.1f}×"
        large = "-" if w["largest_ratio"] is None else f"{w['largest_ratio']:.1f}×"
        lines.append(f"| {label} | {small} | {large} | {w['unmatched']} | "
                     f"{'yes' if w['holds'] else 'no'} |")
    return lines + [""]


def markdown(report: dict[str, Any]) -> str:
    m = report["machine"]
    version = report["cases"][0]["pyelastica_version"]
    lines = [f"# Physical time: PyElastica {version} against rodsim at equal tip accuracy "
             f"({report['size']})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, numpy "
             f"{m['numpy']}, commit {m['git_commit'][:10]}, {m['date']}. CPU "
             "(time.process_time), minimum of "
             f"{report['repeats']} runs: PyElastica's stepping (PositionVerlet, its own "
             "process, equilibrium settling not timed), rodsim's whole rodsim.simulate "
             "(static start included). Ratio: PyElastica's CPU over the "
             "cheapest rodsim run with a tip error no larger. PyElastica's step as a Courant "
             "number "
             "C = dt ω_max / 2, ω_max² = (2 √(E/ρ) / dl)² + α_c G A / (ρ I) (an element's "
             "stretch and its rotation against the shear spring); the example's dt = 0.05 dl "
             f"is C = {EXAMPLE_COURANT:.3f}.", ""]
    for entry in report["cases"]:
        lines += _case_lines(entry)
    return "\n".join(lines)
