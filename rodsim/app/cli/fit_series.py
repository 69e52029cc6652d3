"""``rodsim fit --series``: scene values (a tendon's friction coefficient μ) fitted to tip
positions measured along a ramp, up and back down (``rodsim.fit_series``; docs/tendon.md,
"Friction"); and ``cmd_fit``, which runs ``rodsim fit`` as a fit to a centerline
(``--data``, ``rodsim.app.cli.fit.Fit``) or to a series (``--series``)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from rodsim.app.cli.common import EXIT_OK, EXIT_SOLVER_FAILURE, UserError
from rodsim.app.cli.fit import Fit
from rodsim.app.cli.pipeline import execute, write_with_figure
from rodsim.app.cli.track import parsed_ramps

__all__ = ["FitSeries", "cmd_fit", "read_series"]


def read_series(path: str | Path) -> Any:
    """The measured tips (steps, 3) [m] of a CSV file with header ``x,y,z``, one row per
    ramp value in the ramp's order (``rodsim.fit``'s reader and its refusals; FitError)."""
    from rodsim.app.inverse.fit import FitError
    from rodsim.app.inverse.measured_points import read_points

    points = read_points(path)
    if points.s is not None:
        raise FitError(f"series {str(path)!r}: a column s; expected x,y,z only, one row per "
                       "ramp value (the tip measured at each)")
    return points.xyz


class FitSeries(Fit):
    """Fit numeric scene values (--param, repeatable) so that the track of the ramps
    (--ramp, as for `rodsim track`) puts the tip at the measured positions (--series, one
    row per ramp value): the friction coefficient of a tendon from a pull–release cycle.
    Reports the fitted values with standard errors; writes the track at the fitted values
    (kind track, with the measured tips and the fit in its attributes) and its figure. Bad
    input and solver failures as `rodsim fit`'s."""

    kind = "fit-series"

    def prepare(self, scene: Any) -> None:
        if not self.args.ramp:
            raise UserError("--series needs the ramps the series was measured along "
                            "(--ramp KEY=START:STOP:COUNT[:STOP:COUNT...])")
        self.ramps = parsed_ramps(self.args.ramp)

    def solve(self, scene: Any, integrator: str, progress: Any) -> Any:
        from rodsim.app.inverse.series_fit import fit_series

        self.scene = scene
        self.measured = read_series(self.args.series)
        return fit_series(scene, self.ramps, self.measured, self.args.param, rod=self.args.rod,
                          integrator=integrator, progress=progress)

    def report(self, result: Any) -> None:
        steps = len(self.measured)
        print(f"scene       {self.scene.name}: {steps} tips measured along "
              + ", ".join(self.ramps))
        for key, value in result.values.items():
            print(f"fitted      {key} = {value:.6g} ± {result.standard_errors[key]:.2g}")
        length = max(rod.length for rod in self.scene.rods.values())
        print(f"residual    RMS {result.rms:.3g} m = {result.rms / length:.3g} L per tip "
              "coordinate")
        print(f"cost        {result.tracks} tracks of {steps} steps ({result.evaluations} "
              "misfit evaluations and their finite differences)")

    def dataset(self, result: Any) -> Any:
        dataset = result.track.to_xarray()
        dataset["measured_tip"] = (("step", "axis"), self.measured,
                                   {"units": "m", "long_name": "tip position measured at the "
                                    "step (the series the fit matched)"})
        dataset.attrs.update({
            "fitted_values": json.dumps(result.values),
            "fitted_standard_errors": json.dumps(result.standard_errors),
            "fit_residual_rms": result.rms,
        })
        return dataset

    def write(self, result: Any, output: Path, stem: str) -> None:
        write_with_figure(self.dataset(result), output, stem)

    def verdict(self, result: Any) -> int:
        if not result.track.success:
            print(f"rodsim: the track at the fitted values did not finish: "
                  f"{result.track.message}; archived, marked incomplete", file=sys.stderr)
            return EXIT_SOLVER_FAILURE
        return EXIT_OK


def cmd_fit(args: argparse.Namespace) -> int:
    if args.series is not None:
        return execute(FitSeries(args))
    if args.ramp:
        raise UserError("--ramp goes with --series (tips measured along a ramp); a "
                        "centerline (--data) is one equilibrium")
    return execute(Fit(args))
