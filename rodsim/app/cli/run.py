"""``rodsim run``: one scene to equilibrium, its summary and its archive."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from rodsim.app.cli.common import (
    EXIT_OK,
    EXIT_SOLVER_FAILURE,
    UserError,
    stability_text,
    warn,
)
from rodsim.app.cli.pipeline import SceneCommand, execute

__all__ = ["cmd_run", "print_run_summary"]


class Run(SceneCommand):
    """The archive is written without a figure, then the summary printed; the penalty-error
    estimate is made before the write (the archive stores it)."""

    figure = False
    integrator_flag = True
    uses_scene_integrator = True

    def output_name(self, scene: Any, integrator: str) -> str:
        return f"{scene.name}-{integrator}.nc"

    def bad_input(self) -> tuple[type[Exception], ...]:
        from rodsim.core.scene import SceneError

        return (SceneError,)  # too large for this machine (rodsim.core.memory)

    def solve(self, scene: Any, integrator: str, progress: Any) -> Any:
        from rodsim.app.api import solve

        if scene.solver.kernels == "auto":  # one solve in a fresh process: rodsim.core.kernel_tier
            scene = scene.with_values({"solver.kernels": "tiered"})
        return solve(scene, integrator, progress=progress)

    def failure(self, result: Any) -> str | None:
        return None if result.success else f"rodsim: solver failure: {result.message}"

    def report(self, result: Any) -> None:
        from rodsim.app.trust import assess

        self.estimate = assess(result)

    def write(self, result: Any, output: Path, stem: str) -> None:
        from rodsim.app.trust import compression_text
        from rodsim.io.archive import ArchiveError, write_content
        from rodsim.io.run_dataset import run_content

        content = run_content(result)
        if result.scene.solver.kernels == "tiered":
            content.attrs["kernels"] = _tier_text()
        try:  # without xarray: docs/benchmark-history.md, "Start-up"
            write_content(content, output, note=warn)
        except ArchiveError as exc:
            raise UserError(str(exc)) from None
        print_run_summary(result, output)
        print(self.estimate.text())
        if result.tendon_compression:
            print(compression_text(result.tendon_compression))
        from rodsim.app.contact_report import contact_warnings

        for line in contact_warnings(result):
            print(line)

    def verdict(self, result: Any) -> int:
        if self.args.require_stable and not result.stability.stable:
            kind = "neutral" if result.stability.neutral else "unstable"
            print(f"rodsim: the equilibrium is {kind} (--require-stable)", file=sys.stderr)
            return EXIT_SOLVER_FAILURE
        if self.args.require_physical and result.tendon_compression:
            print("rodsim: a tendon is in compression (--require-physical)", file=sys.stderr)
            return EXIT_SOLVER_FAILURE
        return EXIT_OK


def cmd_run(args: argparse.Namespace) -> int:
    return execute(Run(args))


def print_run_summary(result: Any, archive: Path | None) -> None:
    """The summary of a run (``rodsim run``, ``rodsim rerun``): tips, the scores against the
    analytic references (``rodsim.app.scoring.reference_lines``), residual, statistics,
    stability, archive."""
    from rodsim.app.scoring import reference_lines
    from rodsim.io.statistics import SUMMARY_STATS
    from rodsim.solvers.result import count_text

    scene = result.scene
    print(f"scene       {scene.name}: {scene.description}".rstrip(": "))
    print(f"integrator  {result.integrator}  ({result.message})")
    for name, shape in result.rods.items():
        tip = shape.tip
        print(f"tip of {name:<12s} x = {tip[0]: .6f} m  y = {tip[1]: .6f} m  z = {tip[2]: .6f} m")
    for line in reference_lines(scene, result.positions()):
        print(line)
    stats = result.stats
    requested = result.scene.solver.tolerance
    used = stats["effective_tolerance"]
    floor = (f": the round-off floor, above the requested {requested:.3g}"
             if used > requested * (1 + 1e-9) else "")
    print(f"residual    {result.residual:.3g} (tolerance {used:.3g}{floor})")
    if used > 1e3 * requested:
        print(f"note        the tolerance {requested:.3g} is below this scene's round-off floor "
              f"and was raised to {stats['effective_tolerance']:.3g}: the equilibrium is "
              "defined only that loosely (lower K_P or N for a tighter one)")
    print("statistics  " + ", ".join(
        f"{key} {count_text(stats[key])}" for key in SUMMARY_STATS if key in stats))
    print(f"wall time   {stats['wall_time']:.4f} s")
    for name, tension in result.tendon_tension.items():
        print(f"tension     {name} {tension:.6g} N (displacement control)")
    for name, (_, profile) in result.tension_profiles.items():
        print(f"tension     {name} {profile[0]:.6g} N past the entry, {profile[-1]:.6g} N at "
              "the termination (friction; history: pulled in from slack, monotonically)")
    if result.stability is not None:
        print(stability_text(result.stability))
    if scene.solver.kernels == "tiered":
        print(f"kernels     {_tier_text()}")
    if archive is not None:
        print(f"archive     {archive}")


def _tier_text() -> str:
    """Which evaluation path this process's ``tiered`` models took (rodsim.core.kernel_tier)."""
    from rodsim.core.kernel_tier import PROCESS_TIER

    return PROCESS_TIER.describe()
