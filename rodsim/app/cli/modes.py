"""``rodsim modes``: natural frequencies and mode shapes of a scene about its equilibrium."""

from __future__ import annotations

import argparse
from typing import Any

from rodsim.app.cli.common import stability_text
from rodsim.app.cli.pipeline import SceneCommand, execute

__all__ = ["Modes", "cmd_modes"]


class Modes(SceneCommand):
    """Solve the scene's equilibrium (with static), then the lowest natural frequencies and
    mode shapes about it, K phi = omega^2 M phi with the physical masses (rho A per node,
    rho I and rho J per segment; docs/dynamics.md), and with the scene's damping the damped
    frequency and damping ratio of each mode's own damped root (matched by its shape).
    Prints the frequencies; writes the
    equilibrium's archive with a `mode` dimension and a figure of the first mode shapes."""

    kind = "modes"
    integrator_flag = False

    def bad_input(self) -> tuple[type[Exception], ...]:
        from rodsim.core.scene import SceneError
        from rodsim.core.vibration import ModesError

        return (SceneError, ModesError)

    def solve(self, scene: Any, integrator: str, progress: Any) -> Any:
        from rodsim.app.modes import modes

        self.scene = scene
        return modes(scene, self.args.count, integrator=integrator)

    def failure(self, result: Any) -> str | None:
        return None if result.success else f"rodsim: solver failure: {result.message}"

    def report(self, result: Any) -> None:
        import numpy as np

        equilibrium = result.result
        print(f"scene       {self.scene.name}: {len(result.frequencies)} modes about the "
              f"equilibrium ({equilibrium.integrator}, residual {equilibrium.residual:.2e})")
        if equilibrium.stability is not None:
            print(stability_text(equilibrium.stability))
        damped = bool(np.any(result.damping_ratios != 0.0))
        print("mode   frequency [Hz]   omega^2 [rad^2/s^2]   rotation share"
              + ("   damped [Hz]   damping ratio" if damped else ""))
        for k, (frequency, value, share) in enumerate(zip(
                result.frequencies, result.eigenvalues, result.rotational_share,
                strict=True)):
            shown = (f"{value.real:.6e}" if value.imag == 0.0
                     else f"{value.real:.4e}{value.imag:+.2e}j")
            root = result.matched_eigenvalues[k]  # the damped root of this mode (by MAC)
            extra = (f"   {root.imag / (2.0 * np.pi):>11.6g}   "
                     f"{result.matched_damping_ratios[k]:>13.4g}" if damped else "")
            print(f"{k + 1:>4}   {frequency:>14.6g}   {shown:>19}   {share:>14.3f}{extra}")
        if result.message != "ok":
            print(f"note        {result.message}")


def cmd_modes(args: argparse.Namespace) -> int:
    return execute(Modes(args))
