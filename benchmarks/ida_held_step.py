"""Where IDA's steps go on the released steel rod against N (docs/dynamics.md, "IDA", "Why
the steps jump at large N"): the scene, tolerances and order cap of ``rodsim bench
cvode-scaling`` (L 0.4 m, r 1.2 mm, E 207 GPa, ρ 8000, released from a 0.1 N tip force,
one period, rtol = atol = 1e-5, BDF order ≤ 2).

Per N: IDA's steps, residual and Jacobian evaluations (scikit-sundae's ``nfev``,
``njev``), the steps in each tenth of the period, the longest run of one step size held
unchanged, and — over 40 steps in the middle of that run, where BDF2's local error
estimate is proportional to the third backward difference ∇³y — the share of each group
of unknowns (positions, quaternions, velocities, body rates) in the sum of squares of
∇³y weighted by IDA's weights rtol |y| + atol. A second, identical run (bit for bit the
same steps) records y over those 40 steps. ``--rates F`` multiplies the body rates'
absolute tolerance by F; ``--tol`` sets rtol = atol. The accepted steps are read by
wrapping the run loop's ``Clock.accept`` (a diagnostic, not an interface).

    PYTHONPATH=. python benchmarks/ida_held_step.py 81 161 [--rates 3] [--tol 1e-5]

Prints a table; nothing is asserted.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import rodsim  # noqa: E402
from rodsim.solvers import sundials_clock  # noqa: E402
from rodsim.solvers.physical import ida_run  # noqa: E402
from rodsim_bench.dynamics import steel_period, steel_scene  # noqa: E402

WINDOW = 40


def _run(nodes: int, tol: float, rates: float, window: tuple[int, int] | None
         ) -> dict[str, Any]:
    """One IDA run; the accepted steps' times and counters, and y (natural order) over
    ``window`` (first and last step index)."""
    seen: dict[str, Any] = {"t": [], "y": [], "nfev": 0, "njev": 0}
    accept, tolerances = sundials_clock.Clock.accept, ida_run._tolerances

    def accepted(clock: Any, out: Any) -> None:
        seen["t"].append(float(out.t))
        seen["nfev"], seen["njev"] = out.nfev, out.njev
        if window is not None and window[0] <= len(seen["t"]) - 1 < window[1]:
            seen["y"].append(out.y[seen["dae"].place].copy())
        accept(clock, out)

    def weighted(dae: Any, options: Any) -> np.ndarray:
        atol = tolerances(dae, options)
        natural = atol[dae.place]
        natural[dae.angles.ravel()] *= rates
        seen["dae"], seen["atol"] = dae, natural
        return natural[dae.order]

    sundials_clock.Clock.accept = accepted  # type: ignore[method-assign]
    ida_run._tolerances = weighted
    try:
        period = steel_period()
        result = rodsim.simulate(steel_scene(nodes), period, integrator="ida", rtol=tol,
                                 atol=tol, max_order=2, output_dt=period / 20,
                                 initial={"tip_load.force": [0.0, -0.1, 0.0]})
    finally:
        sundials_clock.Clock.accept = accept  # type: ignore[method-assign]
        ida_run._tolerances = tolerances
    seen["steps"], seen["period"] = result.steps, period
    return seen


def _held(t: np.ndarray) -> tuple[int, int, float]:
    """(first step, length, step size) of the longest run of one step size (equal to 1e-9:
    a step taken as a difference of times carries their round-off)."""
    h = np.diff(np.concatenate([[0.0], t]))
    same = np.isclose(h[1:], h[:-1], rtol=1e-9, atol=0.0)
    starts = np.flatnonzero(np.concatenate([[True], ~same]))
    lengths = np.diff(np.concatenate([starts, [len(h)]]))
    k = int(np.argmax(lengths))
    return int(starts[k]), int(lengths[k]), float(h[starts[k]])


def _shares(seen: dict[str, Any], tol: float) -> dict[str, float]:
    dae, atol = seen["dae"], seen["atol"]
    y = np.array(seen["y"])
    third = y[3:] - 3.0 * y[2:-1] + 3.0 * y[1:-2] - y[:-3]
    e2 = (third / (tol * np.abs(y[3:]) + atol)) ** 2
    total = np.sum(e2, axis=1)
    c = dae.coordinates
    groups = {"positions": c.positions, "quaternions": c.quaternions.ravel(),
              "velocities": dae.velocities, "rates": dae.angles.ravel()}
    shares = {name: float(np.mean(np.sum(e2[:, index], axis=1) / total))
              for name, index in groups.items()}
    shares["weighted RMS"] = float(np.mean(np.sqrt(total / e2.shape[1])))
    return shares


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("nodes", type=int, nargs="+")
    parser.add_argument("--tol", type=float, default=1e-5)
    parser.add_argument("--rates", type=float, default=1.0)
    args = parser.parse_args()
    print("| N | steps | residuals | Jacobians | steps per tenth | held step [s] × steps "
          "(from t [s]) | ∇³y share: positions, quaternions, velocities, rates | "
          "weighted RMS |")
    print("|--:|--:|--:|--:|---|---|---|--:|")
    for nodes in args.nodes:
        first = _run(nodes, args.tol, args.rates, None)
        t = np.array(first["t"])
        start, length, h = _held(t)
        middle = start + max(0, length // 2 - WINDOW // 2)
        second = _run(nodes, args.tol, args.rates, (middle, middle + WINDOW))
        shares = _shares(second, args.tol)
        tenths = np.bincount(np.minimum((10 * t / first["period"]).astype(int), 9),
                             minlength=10)
        groups = ", ".join(f"{shares[k]:.4f}" for k in ("positions", "quaternions",
                                                         "velocities", "rates"))
        print(f"| {nodes} | {first['steps']} | {first['nfev']} | {first['njev']} | "
              f"{' '.join(str(int(n)) for n in tenths)} | {h:.4g} × {length} "
              f"(from {t[start]:.3g}) | {groups} | {shares['weighted RMS']:.3g} |")


if __name__ == "__main__":
    main()
