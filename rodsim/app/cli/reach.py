"""``rodsim reach``: actuation values that put a rod's tip at a target (inverse
kinematics)."""

from __future__ import annotations

import argparse
from typing import Any

from rodsim.app.cli.pipeline import SceneCommand, execute, print_trust

__all__ = ["cmd_reach"]


class Reach(SceneCommand):
    """Find values of the --actuate keys (e.g. the tensions of several tendons) that put a
    rod's tip at --tip, by least squares on the analytic sensitivities within each value's
    allowed range (tensions >= 0). Exit 1 when the target is out of reach, with the closest
    tip found (docs/inverse.md)."""

    kind = "reach"
    integrator_flag = True

    def bad_input(self) -> tuple[type[Exception], ...]:
        from rodsim.core.scene import SceneError

        return (SceneError,)

    def solver_failures(self) -> tuple[type[Exception], ...]:
        from rodsim.app.inverse.continuation import EquilibriumFailure

        return (EquilibriumFailure,)

    def solve(self, scene: Any, integrator: str, progress: Any) -> Any:
        from rodsim.app.inverse.reach import reach

        self.scene = scene
        args = self.args
        return reach(scene, args.tip, args.actuate, rod=args.rod, tolerance=args.tolerance,
                     progress=progress, orientation=args.frame, integrator=integrator)

    def failure(self, result: Any) -> str | None:
        return None if result.success else f"rodsim: {result.message}"

    def report(self, result: Any) -> None:
        print(f"scene       {self.scene.name}: tip of {result.rod} to "
              f"({', '.join(f'{c:.6g}' for c in result.target)}) m")
        for key, initial, value in zip(result.keys, result.initial, result.values,
                                       strict=True):
            print(f"actuation   {key.name} = {value:.6g} {key.unit} (from {initial:.6g})")
        tip = result.tip
        print(f"tip         x = {tip[0]: .6f} m  y = {tip[1]: .6f} m  z = {tip[2]: .6f} m, "
              f"{result.distance:.3g} m from the target")
        if result.angle is not None:
            print(f"frame       {result.angle:.3g} rad from the orientation target")
        print(f"cost        {result.evaluations} equilibria, {result.jacobians} Jacobians, "
              f"{result.wall_time:.3f} s")
        print_trust(result.result)


def cmd_reach(args: argparse.Namespace) -> int:
    return execute(Reach(args))
