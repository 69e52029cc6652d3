"""The one path of the commands that solve a scene and write what they found (``run``,
``track``, ``fit``, ``reach``): scene → output checked → solve (with progress) → print →
write. A command says only what differs (``SceneCommand``); ``execute`` is the
path, its order and its exits (2 for bad input before any work, 1 for a solver failure,
130 on Ctrl-C or SIGTERM, after writing what a command finished:
``rodsim.app.interrupted.Interrupted``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from rodsim.app.cli.common import (
    EXIT_OK,
    EXIT_SOLVER_FAILURE,
    UserError,
    check_integrator,
    load_scene_or_fail,
    output_path,
    warn,
)
from rodsim.app.interrupted import Interrupted

if TYPE_CHECKING:
    from rodsim.app.progress import ProgressPrinter
    from rodsim.core.scene import Scene

__all__ = ["SceneCommand", "execute", "check_outputs", "write_with_figure", "print_trust"]


class SceneCommand:
    """What one scene command does on the common path; a new instance per invocation (it
    may keep what it learns, e.g. ``fit``'s points, for its summary).

    ``kind`` names the default output (``runs/<scene>-<kind>.nc``); ``figure``: a PNG
    figure is written beside the archive; ``integrator_flag``: the command has
    ``--integrator`` (checked against the registry first); without it, the command solves
    with the scene's own ``solver.integrator`` if ``uses_scene_integrator`` (run), else with
    the registry's default (``rodsim.solvers.DEFAULT_INTEGRATOR``: track, fit and reach,
    which solve many warm-started equilibria)."""

    kind: ClassVar[str]
    figure: ClassVar[bool] = True
    integrator_flag: ClassVar[bool] = False
    uses_scene_integrator: ClassVar[bool] = False

    def __init__(self, args: argparse.Namespace) -> None:
        self.args = args

    def bad_input(self) -> tuple[type[Exception], ...]:
        """Exceptions of ``solve`` that are bad input (exit 2, their text the message);
        imported when called, so that ``--help`` imports no solver."""
        return ()

    def solver_failures(self) -> tuple[type[Exception], ...]:
        """Exceptions of ``solve`` that are a solver failure (exit 1)."""
        return ()

    def prepare(self, scene: Scene) -> None:
        """Checks of the command's own arguments, before any folder is made or work
        starts (raise ``UserError``)."""

    def output_name(self, scene: Scene, integrator: str) -> str:
        return f"{scene.name}-{self.kind}.nc"

    def solve(self, scene: Scene, integrator: str, progress: ProgressPrinter) -> Any:
        raise NotImplementedError

    def failure(self, result: Any) -> str | None:
        """The stderr line of a result that is a failure (exit 1, nothing written)."""
        return None

    def report(self, result: Any) -> None:
        """Print the summary before the outputs are written."""

    def dataset(self, result: Any) -> Any:
        return result.to_xarray()

    def write(self, result: Any, output: Path, stem: str) -> None:
        write_with_figure(self.dataset(result), output, stem)

    def verdict(self, result: Any) -> int:
        """The exit code once everything is written."""
        return EXIT_OK


def execute(command: SceneCommand) -> int:
    """The common path of a ``SceneCommand`` (module docstring)."""
    from rodsim.app.contact_report import failure_note
    from rodsim.app.progress import ProgressPrinter

    args = command.args
    flag = args.integrator if command.integrator_flag else None
    check_integrator(flag)
    if flag is None and not command.uses_scene_integrator:
        from rodsim.solvers import DEFAULT_INTEGRATOR

        flag = DEFAULT_INTEGRATOR
    scene = load_scene_or_fail(args.scene, args.set, flag)
    integrator = flag or scene.solver.integrator
    check_archivable(scene)
    command.prepare(scene)
    output = output_path(args.output, command.output_name(scene, integrator))
    stem = check_outputs(output, command.figure)
    bad_input, solver_failures = command.bad_input(), command.solver_failures()
    progress = ProgressPrinter()
    try:
        result = command.solve(scene, integrator, progress)
    except bad_input as exc:
        raise UserError(str(exc)) from None
    except solver_failures as exc:
        print(f"rodsim: solver failure: {exc}{failure_note(scene, str(exc))}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    except Interrupted as stop:  # Ctrl-C or SIGTERM: keep what is finished, then stop
        progress.close()
        print(f"rodsim: {stop}; writing the finished part, marked incomplete",
              file=sys.stderr)
        command.write(stop.partial, output, stem)
        raise
    finally:
        progress.close()
    message = command.failure(result)
    if message is not None:
        print(f"{message}{failure_note(scene, message)}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    command.report(result)
    command.write(result, output, stem)
    return command.verdict(result)


def check_archivable(scene: Scene) -> None:
    """A scene too large for its archive (its resolved JSON holds a vessel's csv points) is
    refused before any work: the archive would be refused when written, or when read."""
    from rodsim.io.archive_schema import ArchiveSchemaError, check_attribute_sizes

    try:
        check_attribute_sizes({"scene_json": scene.to_json(), "scene_toml": scene.source})
    except ArchiveSchemaError as exc:
        raise UserError(f"scene {scene.name}: too large for an archive ({exc}); use fewer "
                        "centerline points") from None


def check_outputs(output: Path, figure: bool = True) -> str:
    """Check a command's archive target (and its figure's folder) before any work: an
    unwritable output fails in a second, not after an hour. Returns the figure's stem (the
    archive's path without ``.nc``)."""
    from rodsim.io.output import OutputError, check_target

    stem = str(output.with_suffix("")) if output.suffix == ".nc" else str(output)
    try:
        check_target(output)
        if figure:
            from rodsim.app.figures import PlotError, check_output

            try:
                check_output(stem, ["png"])
            except PlotError as exc:
                raise UserError(f"-o {exc}") from None
    except OutputError as exc:
        raise UserError(f"-o {exc}") from None
    return stem


def write_with_figure(dataset: Any, output: Path, stem: str) -> None:
    """Write a command's archive (atomically) and its PNG figure."""
    from rodsim.app.figures import PlotError, plot_dataset
    from rodsim.io.archive import ArchiveError, write_dataset

    try:
        write_dataset(dataset, output, note=warn)
        figures = plot_dataset(dataset, stem, ["png"])
    except (ArchiveError, PlotError) as exc:
        raise UserError(str(exc)) from None
    print(f"archive     {output}")
    for figure in figures:
        print(f"figure      {figure}")


def print_trust(result: Any) -> None:
    """Print a result's penalty-error estimate and compression check, stored on it for its
    archive (rodsim/app/trust.py)."""
    from rodsim.app.contact_report import contact_warnings
    from rodsim.app.trust import assess, compression_text

    print(assess(result).text())
    if result.tendon_compression:
        print(compression_text(result.tendon_compression))
    for line in contact_warnings(result):
        print(line)
