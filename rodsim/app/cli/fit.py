"""``rodsim fit``: scene values fitted to a measured centerline (least squares)."""

from __future__ import annotations

import sys
from typing import Any

from rodsim.app.cli.common import EXIT_OK, EXIT_SOLVER_FAILURE, stability_text
from rodsim.app.cli.pipeline import SceneCommand, print_trust

__all__ = ["Fit"]


class Fit(SceneCommand):
    """Fit numeric scene values (--param, repeatable) to measured points of a rod's centerline
    by least squares on the analytic sensitivities; reports the fitted values with standard
    errors, writes the archive of the fitted scene (`rodsim rerun` re-solves it) and a
    figure of data and fit (docs/inverse.md)."""

    kind = "fit"
    integrator_flag = True

    def bad_input(self) -> tuple[type[Exception], ...]:
        from rodsim.app.inverse.fit import FitError
        from rodsim.core.scene import SceneError

        return (FitError, SceneError)

    def solver_failures(self) -> tuple[type[Exception], ...]:
        from rodsim.app.inverse.fit import EquilibriumFailure

        return (EquilibriumFailure,)

    def solve(self, scene: Any, integrator: str, progress: Any) -> Any:
        from rodsim.app.inverse.fit import fit, read_points

        self.scene = scene
        self.points = read_points(self.args.data)
        return fit(scene, self.points, self.args.param, rod=self.args.rod, progress=progress,
                   integrator=integrator)

    def report(self, result: Any) -> None:
        points = self.points
        print(f"scene       {self.scene.name}: {len(points.xyz)} points of rod {result.rod} "
              f"({'matched by s' if points.s is not None else 'matched to the nearest point'})")
        for key, initial, value, error in zip(result.keys, result.initial, result.values,
                                              result.errors, strict=True):
            print(f"fitted      {key.name} = {value:.6g} ± {error:.2g} {key.unit} "
                  f"(from {initial:.6g})")
        print(f"residual    RMS {result.residual_rms:.3g} m = "
              f"{result.residual_rms_relative:.3g} L over {result.degrees_of_freedom} degrees "
              "of freedom")
        print(f"cost        {result.evaluations} equilibria, {result.jacobians} Jacobians, "
              f"{result.wall_time:.3f} s ({result.message})")
        if result.result.stability is not None:
            print(stability_text(result.result.stability))
        print_trust(result.result)

    def verdict(self, result: Any) -> int:
        if result.undetermined:
            print(f"rodsim: fit undetermined: {result.undetermined_text}; archived, flagged "
                  "(attribute 'undetermined')", file=sys.stderr)
            return EXIT_SOLVER_FAILURE
        if not result.stable:
            print("rodsim: the fitted equilibrium is UNSTABLE (its stiffness is not positive "
                  "definite): the best fit is not a shape the rod keeps; archived, flagged "
                  "(attribute 'stable' = 0)", file=sys.stderr)
            return EXIT_SOLVER_FAILURE
        return EXIT_OK
