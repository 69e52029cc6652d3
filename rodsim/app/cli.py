"""Command line: ``rodsim run | rerun | track | fit | reach | study | plot | scenes | terms``
(and ``bench``).

Human-readable summaries go to stdout, errors to stderr. Exit codes: 0 success, 1 solver
failure, 2 bad input (scene, option, path or archive). User errors never show a traceback.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

from rodsim.app.threads import pin_threads
from rodsim.version import __version__

if TYPE_CHECKING:
    from rodsim.core.schema import SceneError
    from rodsim.core.stability import Stability

EXIT_OK, EXIT_SOLVER_FAILURE, EXIT_BAD_INPUT = 0, 1, 2

#: Folder (in the current folder) of every command's default output: a run's archive never
#: lands beside the sources of a checkout, and one ignore rule covers them (.gitignore).
DEFAULT_OUTPUT_FOLDER = Path("runs")


class UserError(Exception):
    """A problem with what the user asked for (exit code 2, one-line message)."""


def warn(message: str) -> None:
    """One ``rodsim: warning: …`` line on stderr (exit code unchanged)."""
    print(f"rodsim: warning: {message}", file=sys.stderr, flush=True)


def _check_integrator(name: str | None) -> None:
    """``--integrator NAME`` must name a registered integrator (the registry is the only list
    of names; ``rodsim run --help`` lists them)."""
    from rodsim.solvers import registered_integrators

    names = registered_integrators()
    if name is not None and name not in names:
        raise UserError(f"--integrator {name!r}: unknown integrator; registered: "
                        + ", ".join(names))


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are one line on stderr (exit 2), like every
    other bad input; ``--help`` shows the usage."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")

    def format_help(self) -> str:
        """The help text; an epilog given as a function is built here, when the help is
        shown (``rodsim run``'s list of scene keys imports the terms and integrators, which
        ``rodsim --help`` and every command do not need)."""
        if callable(self.epilog):
            self.epilog = self.epilog()
        return super().format_help()


def _scene_keys_help() -> str:
    """Every scene key with unit and default, for ``--help`` epilogs."""
    from rodsim.core.rod.rod import ROD_PARAMETERS
    from rodsim.core.scene import SOLVER_PARAMETERS
    from rodsim.core.terms import registered_terms
    from rodsim.solvers import registered_integrators

    lines = ["scene keys for --set (any unambiguous suffix works, e.g. nodes=80, mass=0.1):",
             "  rods.<rod>:"]
    lines += [f"    {p.help()}" for p in ROD_PARAMETERS]
    for name, term in registered_terms().items():
        where = "rods.<rod>" if term.scope == "rod" else "tendons.<tendon rod>"
        prefix = f"{where}.{name}"
        if term.parameters:
            lines.append(f"  {prefix}:  [{term.equation}]")
            lines += [f"    {p.help()}" for p in term.parameters]
    lines.append("  solver:")
    lines += [f"    {p.help()}" for p in SOLVER_PARAMETERS]
    for name, integrator in registered_integrators().items():
        lines.append(f"  solver.{name}:  [{integrator.summary}]")
        lines += [f"    {p.help()}" for p in integrator.parameters]
    return "\n".join(lines)


def _print_run_summary(result, archive: Path | None) -> None:
    from rodsim.core.analytic.reference import cantilever_reference
    from rodsim.solvers.result import count_text

    scene = result.scene
    print(f"scene       {scene.name}: {scene.description}".rstrip(": "))
    print(f"integrator  {result.integrator}  ({result.message})")
    for name, shape in result.rods.items():
        tip = shape.tip
        print(f"tip of {name:<12s} x = {tip[0]: .6f} m  y = {tip[1]: .6f} m  z = {tip[2]: .3g} m")
    try:
        reference = cantilever_reference(scene)
    except (ValueError, ArithmeticError) as exc:  # beyond the analytic models' reach
        print(f"load        analytic references n/a ({exc})")
        reference = None
    if reference is not None:
        positions = result.positions()
        print(f"load        α = F L²/(2EI) = {reference.alpha:.4g}  (F = {reference.force:.4g} N)")
        print(f"tip error   vs analytical model (Eqs. 21–23, corrected): "
              f"{100 * reference.tip_error(positions, 'paper'):.4f} % of L")
        extensible = (f"{100 * reference.tip_error(positions, 'extensible'):.4f} % of L"
                      if reference.extensible is not None else "n/a (tip force ≥ E_s A)")
        print(f"            vs exact elastica: "
              f"{100 * reference.tip_error(positions, 'exact'):.4f} % of L;  "
              f"vs extensible elastica (E_s A): {extensible}")
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
        f"{key} {count_text(stats[key])}" for key in
        ("steps", "newton_iters", "force_evals", "jacobian_evals", "linear_solves", "reinits",
         "tightenings") if key in stats))
    print(f"wall time   {stats['wall_time']:.4f} s")
    if result.stability is not None:
        print(stability_text(result.stability))
    if archive is not None:
        print(f"archive     {archive}")


#: The default output folder when this command created it (removed again if it stays
#: empty because the command ends in a bad-input error).
_created_output_folder: list[Path] = []


def _output_path(given: str | None, default: str) -> Path:
    """The ``-o`` path if given, else ``runs/<default>`` in the current folder (the folder
    created if missing). An empty ``-o`` and one naming a folder (a trailing ``/``) are
    refused: a name was meant, and neither the default nor a file named like the folder
    is what was asked for."""
    if given is not None:
        if not given.strip():
            raise UserError("-o '': an empty output path; give a file name (or leave -o out "
                            "for the default)")
        if given.endswith(("/", os.sep)):
            raise UserError(f"-o {given[:60]!r}: names a folder; give a file name in it "
                            f"(e.g. {str(Path(given) / default)[:80]!r})")
        return Path(given)
    try:
        if not DEFAULT_OUTPUT_FOLDER.exists():
            DEFAULT_OUTPUT_FOLDER.mkdir()
            _created_output_folder.append(DEFAULT_OUTPUT_FOLDER.absolute())
    except OSError as exc:
        raise UserError(f"cannot create the output folder {str(DEFAULT_OUTPUT_FOLDER)!r} "
                        f"({exc.strerror or exc}); give an archive path with -o") from None
    return DEFAULT_OUTPUT_FOLDER / default


def _remove_created_output_folder() -> None:
    """Remove the default output folder this command created, if it is still empty."""
    import contextlib

    while _created_output_folder:
        with contextlib.suppress(OSError):
            _created_output_folder.pop().rmdir()  # only an empty folder is removed


def scene_error_text(exc: SceneError) -> str:
    """A :class:`~rodsim.core.schema.SceneError` in the CLI's words: an override that could
    not be read names the ``--set`` it came from; other errors (a value out of range, a
    scene file) read the same as in Python."""
    from rodsim.core.schema import shown

    if exc.assignment is None:
        return str(exc)
    flag = f"--set {shown(exc.assignment, bare=True)}"
    if exc.reason == "unknown key":
        closest = f"; closest: {', '.join(exc.allowed)}" if exc.allowed else ""
        return (f"{flag}: unknown key {shown(exc.key, bare=True)} (`rodsim run --help` "
                f"lists the keys){closest}")
    if exc.reason == "ambiguous key":
        return (f"{flag}: {exc.key} is ambiguous, could be {', '.join(exc.allowed)} (give "
                "more of the dotted key)")
    if exc.reason == "expected key=value":
        return f"{flag}: expected KEY=VALUE"
    return f"{flag}: {exc.reason}"


def _load_scene_or_fail(scene: str | None, overrides: Sequence[str], integrator: str | None):
    from rodsim.app.api import load_scene
    from rodsim.core.scene import SceneError

    try:
        return load_scene(scene, overrides, f"solver.{integrator}" if integrator else "")
    except SceneError as exc:
        raise UserError(scene_error_text(exc)) from None


def cmd_run(args: argparse.Namespace) -> int:
    _check_integrator(args.integrator)
    from rodsim.app.api import solve
    from rodsim.app.progress import ProgressPrinter
    from rodsim.app.trust import assess, compression_text
    from rodsim.core.scene import SceneError
    from rodsim.io.archive import ArchiveError, write_dataset
    from rodsim.io.output import OutputError, check_target
    from rodsim.io.run_dataset import run_dataset

    scene = _load_scene_or_fail(args.scene, args.set, args.integrator)
    integrator = args.integrator or scene.solver.integrator
    output = _output_path(args.output, f"{scene.name}-{integrator}.nc")
    try:  # before the solve: an unwritable output fails in a second, not after an hour
        check_target(output)
    except OutputError as exc:
        raise UserError(f"-o {exc}") from None
    progress = ProgressPrinter()
    try:
        result = solve(scene, integrator, progress=progress)
    except SceneError as exc:  # too large for this machine (rodsim.core.memory)
        raise UserError(str(exc)) from None
    finally:
        progress.close()
    if not result.success:
        print(f"rodsim: solver failure: {result.message}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    estimate = assess(result)
    try:
        write_dataset(run_dataset(result), output, note=warn)
    except ArchiveError as exc:
        raise UserError(str(exc)) from None
    _print_run_summary(result, output)
    print(estimate.text())
    if result.tendon_compression:
        print(compression_text(result.tendon_compression))
    if args.require_stable and not result.stability.stable:
        print("rodsim: the equilibrium is unstable (--require-stable)", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    if args.require_physical and result.tendon_compression:
        print("rodsim: a tendon is in compression (--require-physical)", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    return EXIT_OK


def stability_text(stability: Stability) -> str:
    """The summary line of a :class:`~rodsim.core.stability.Stability` verdict."""
    if stability.stable:
        return "stability   stable (the stiffness K = -dF/dx is positive definite)"
    return (f"warning     UNSTABLE equilibrium: the stiffness K = -dF/dx is not positive "
            f"definite (smallest eigenvalue {stability.min_eigenvalue:.3g}); a small "
            "perturbation leaves it (e.g. a compressed rod past its buckling load)")


def cmd_rerun(args: argparse.Namespace) -> int:
    from rodsim.app.api import rerun
    from rodsim.app.study import StudyError
    from rodsim.core.scene import SceneError
    from rodsim.io.archive import ArchiveError, read_dataset

    try:
        dataset = read_dataset(args.archive)
        if "study" in dataset.attrs:
            return _rerun_study(dataset, args)
        if args.point:
            raise UserError("--point applies to study archives only")
        if dataset.attrs.get("kind") == "track":
            return _rerun_track(dataset, args)
        result, difference = rerun(dataset)
    except (ArchiveError, SceneError, StudyError) as exc:
        raise UserError(f"{args.archive}: {exc}") from None
    if not result.success:
        print(f"rodsim: solver failure on rerun: {result.message}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    _print_run_summary(result, None)
    length = max(shape.s[-1] for shape in result.rods.values())
    return _rerun_verdict("positions", difference, length, args.tolerance)


def _rerun_verdict(what: str, difference: float, length: float, tolerance: float) -> int:
    """Print the largest difference from the archive; exit 1 above ``tolerance`` × L."""
    print(f"rerun       largest difference from the stored {what}: {difference:.3g} m "
          f"({difference / length:.3g} L)")
    if difference > tolerance * length:
        print(f"rodsim: rerun differs from the archive by more than {tolerance:g} L",
              file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    return EXIT_OK


def _rerun_track(dataset, args: argparse.Namespace) -> int:
    from rodsim.app.inverse.track import rerun_track

    again, difference = rerun_track(dataset)
    if not again.success:
        print(f"rodsim: solver failure on rerun: {again.message}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    print(f"track       {again.scene.name}: re-ran {again.steps} steps")
    length = max(rod.length for rod in again.model.rods.values())
    return _rerun_verdict("centerlines", difference, length, args.tolerance)


def _check_outputs(output: Path) -> str:
    """Check an inverse command's archive target and its figure's folder before any work;
    returns the figure's stem (the archive's path without ``.nc``)."""
    from rodsim.app.plotting import PlotError, check_output
    from rodsim.io.output import OutputError, check_target

    stem = str(output.with_suffix("")) if output.suffix == ".nc" else str(output)
    try:
        check_target(output)
        check_output(stem, ["png"])
    except (OutputError, PlotError) as exc:
        raise UserError(f"-o {exc}") from None
    return stem


def _write_with_figure(dataset, output: Path, stem: str) -> None:
    """Write an inverse command's archive (atomically) and its PNG figure."""
    from rodsim.app.plotting import PlotError, plot_dataset
    from rodsim.io.archive import ArchiveError, write_dataset

    try:
        write_dataset(dataset, output, note=warn)
        figures = plot_dataset(dataset, stem, ["png"])
    except (ArchiveError, PlotError) as exc:
        raise UserError(str(exc)) from None
    print(f"archive     {output}")
    for figure in figures:
        print(f"figure      {figure}")


def cmd_track(args: argparse.Namespace) -> int:
    _check_integrator(args.integrator)
    from rodsim.app.inverse.track import parse_ramp, track
    from rodsim.app.progress import ProgressPrinter
    from rodsim.core.scene import SceneError
    from rodsim.solvers import DEFAULT_INTEGRATOR

    integrator = args.integrator or DEFAULT_INTEGRATOR
    scene = _load_scene_or_fail(args.scene, args.set, integrator)
    try:  # the ramps before any folder is made or any work starts
        ramps = dict(parse_ramp(text) for text in args.ramp)
    except SceneError as exc:
        raise UserError(str(exc)) from None
    if len(ramps) != len(args.ramp):
        raise UserError("--ramp names the same key twice")
    output = _output_path(args.output, f"{scene.name}-track.nc")
    stem = _check_outputs(output)
    progress = ProgressPrinter()
    try:
        result = track(scene, ramps, integrator, progress=progress,
                       allow_unstable=args.allow_unstable)
    except SceneError as exc:
        raise UserError(str(exc)) from None
    finally:
        progress.close()
    if not result.success and result.unstable_step is None:
        print(f"rodsim: solver failure: {result.message}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    times = result.times
    warm = sum(times[1:]) / max(len(times) - 1, 1)
    last = result.steps - 1
    print(f"scene       {scene.name}: {result.steps} steps of "
          + ", ".join(f"{k.name} {result.values[0, i]:g} → {result.values[last, i]:g} {k.unit}"
                      for i, k in enumerate(result.keys)))
    print(f"integrator  {integrator}")
    tip = result.tips()[-1]
    print(f"last tip    x = {tip[0]: .6f} m  y = {tip[1]: .6f} m  z = {tip[2]: .3g} m")
    speed = f" ({1.0 / warm:.0f} steps/s)" if warm > 0 else ""
    print(f"wall time   {sum(times):.4f} s: first step (cold) {times[0]:.4f} s, warm steps "
          f"{1e3 * warm:.3f} ms each{speed}, {int(sum(result.halvings))} halvings")
    unstable = result.unstable_steps
    if unstable:
        print(f"stability   UNSTABLE at {len(unstable)} of {result.steps} steps (first: step "
              f"{unstable[0]}, smallest stiffness eigenvalue "
              f"{result.min_eigenvalues[unstable[0]]:.3g}); flagged in the archive")
    else:
        print("stability   stable at every step (the stiffness K = -dF/dx is positive "
              "definite)")
    _trust_of_last_step(result)
    _write_with_figure(result.to_xarray(), output, stem)
    if not result.success:  # stopped at an unstable step: archived, and a failure
        print(f"rodsim: {result.message}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    if unstable:
        warn(f"{len(unstable)} step(s) are unstable equilibria (first: step {unstable[0]}); "
             "kept because of --allow-unstable, flagged in the archive (variable 'stable')")
    return EXIT_OK


def _trust_of_last_step(track) -> None:
    """Print the last step's penalty-error estimate and compression check, and keep them on
    ``track`` for its archive (rodsim/app/trust.py)."""
    from rodsim.app.trust import assess, compression_text, last_step_result

    last = last_step_result(track)
    if last is None:
        if track.steps:
            track.penalty_error = float("nan")
            print("penalty     error estimate unavailable: the last step did not re-solve "
                  "with the static integrator")
        return
    estimate = assess(last)
    track.penalty_error = last.penalty_error
    track.tendon_compression = last.tendon_compression
    print(estimate.text().replace("penalty     ", "penalty     last step: ", 1))
    if last.tendon_compression:
        print(compression_text(last.tendon_compression))


def _trust(result) -> None:
    """Print a result's penalty-error estimate and compression check, stored on it for its
    archive (rodsim/app/trust.py)."""
    from rodsim.app.trust import assess, compression_text

    print(assess(result).text())
    if result.tendon_compression:
        print(compression_text(result.tendon_compression))


def cmd_fit(args: argparse.Namespace) -> int:
    from rodsim.app.inverse.fit import EquilibriumFailure, FitError, fit, read_points
    from rodsim.app.progress import ProgressPrinter
    from rodsim.core.scene import SceneError
    from rodsim.solvers import DEFAULT_INTEGRATOR

    scene = _load_scene_or_fail(args.scene, args.set, DEFAULT_INTEGRATOR)
    output = _output_path(args.output, f"{scene.name}-fit.nc")
    stem = _check_outputs(output)
    try:
        points = read_points(args.data)
        progress = ProgressPrinter()
        try:
            result = fit(scene, points, args.param, rod=args.rod, progress=progress)
        finally:
            progress.close()
    except (FitError, SceneError) as exc:
        raise UserError(str(exc)) from None
    except EquilibriumFailure as exc:
        print(f"rodsim: solver failure: {exc}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    print(f"scene       {scene.name}: {len(points.xyz)} points of rod {result.rod} "
          f"({'matched by s' if points.s is not None else 'matched to the nearest point'})")
    for key, initial, value, error in zip(result.keys, result.initial, result.values,
                                          result.errors, strict=True):
        print(f"fitted      {key.name} = {value:.6g} ± {error:.2g} {key.unit} "
              f"(from {initial:.6g})")
    print(f"residual    RMS {result.residual_rms:.3g} m = {result.residual_rms_relative:.3g} L "
          f"over {result.degrees_of_freedom} degrees of freedom")
    print(f"cost        {result.evaluations} equilibria, {result.jacobians} Jacobians, "
          f"{result.wall_time:.3f} s ({result.message})")
    if result.result.stability is not None:
        print(stability_text(result.result.stability))
    _trust(result.result)
    _write_with_figure(result.to_xarray(), output, stem)
    if not result.stable:
        print("rodsim: the fitted equilibrium is UNSTABLE (its stiffness is not positive "
              "definite): the best fit is not a shape the rod keeps; archived, flagged "
              "(attribute 'stable' = 0)", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    return EXIT_OK


def _target(text: str) -> list[float]:
    """argparse type of ``reach --tip``: three finite numbers X,Y,Z [m]."""
    parts = text.split(",")
    try:
        values = [float(part) for part in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X,Y,Z in metres, got {text[:40]!r}"
                                         ) from None
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"expected three finite numbers X,Y,Z, got "
                                         f"{text[:40]!r}")
    return values


def _frame(text: str) -> list[list[float]]:
    """argparse type of ``reach --frame``: the tip directors d1 and d3 (six finite numbers);
    d2 = d3 × d1. Whether they are orthonormal is checked by ``reach`` (exit 2)."""
    parts = text.split(",")
    try:
        values = [float(part) for part in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected D1X,D1Y,D1Z,D3X,D3Y,D3Z, got "
                                         f"{text[:40]!r}") from None
    if len(values) != 6 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"expected six finite numbers D1X,D1Y,D1Z,D3X,D3Y,"
                                         f"D3Z, got {text[:40]!r}")
    d1, d3 = values[:3], values[3:]
    d2 = [d3[1] * d1[2] - d3[2] * d1[1], d3[2] * d1[0] - d3[0] * d1[2],
          d3[0] * d1[1] - d3[1] * d1[0]]
    return [d1, d2, d3]


def cmd_reach(args: argparse.Namespace) -> int:
    from rodsim.app.inverse.continuation import EquilibriumFailure
    from rodsim.app.inverse.reach import reach
    from rodsim.app.progress import ProgressPrinter
    from rodsim.core.scene import SceneError
    from rodsim.solvers import DEFAULT_INTEGRATOR

    scene = _load_scene_or_fail(args.scene, args.set, DEFAULT_INTEGRATOR)
    output = _output_path(args.output, f"{scene.name}-reach.nc")
    stem = _check_outputs(output)
    progress = ProgressPrinter()
    try:
        result = reach(scene, args.tip, args.actuate, rod=args.rod, tolerance=args.tolerance,
                       progress=progress, orientation=args.frame)
    except SceneError as exc:
        raise UserError(str(exc)) from None
    except EquilibriumFailure as exc:
        print(f"rodsim: solver failure: {exc}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    finally:
        progress.close()
    if not result.success:
        print(f"rodsim: {result.message}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    print(f"scene       {scene.name}: tip of {result.rod} to "
          f"({', '.join(f'{c:.6g}' for c in result.target)}) m")
    for key, initial, value in zip(result.keys, result.initial, result.values, strict=True):
        print(f"actuation   {key.name} = {value:.6g} {key.unit} (from {initial:.6g})")
    tip = result.tip
    print(f"tip         x = {tip[0]: .6f} m  y = {tip[1]: .6f} m  z = {tip[2]: .6f} m, "
          f"{result.distance:.3g} m from the target")
    if result.angle is not None:
        print(f"frame       {result.angle:.3g} rad from the orientation target")
    print(f"cost        {result.evaluations} equilibria, {result.jacobians} Jacobians, "
          f"{result.wall_time:.3f} s")
    _trust(result.result)
    _write_with_figure(result.to_xarray(), output, stem)
    return EXIT_OK


def _rerun_study(dataset, args: argparse.Namespace) -> int:
    from rodsim.app.study import STATUS, rerun_study

    select: dict[str, str] = {}
    for item in args.point:
        key, sep, value = item.partition("=")
        if not sep:
            raise UserError(f"--point {item!r}: expected DIM=VALUE")
        key, value = key.strip(), value.strip()
        if key in select:
            raise UserError(f"--point {key}=… given twice ({select[key]} and {value}): a "
                            "point has one value per swept parameter")
        select[key] = value
    records, difference = rerun_study(dataset, select)
    failed = sum(r["status"] != STATUS["ok"] for r in records)
    length = float(json.loads(dataset.attrs["scene_json"])["rods"][
        str(dataset["rod"].values[0])]["length"])
    print(f"study       {dataset.attrs['study']} ({dataset.attrs['size']}): re-ran "
          f"{len(records)} point(s), {failed} failed")
    return _rerun_verdict("centerlines", difference, length, args.tolerance)


def _tolerance(text: str) -> float:
    """argparse type of ``rerun --tolerance``: a finite number of at least 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text[:40]!r}") from None
    if not math.isfinite(value) or value < 0.0:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text[:40]!r}")
    return value


def _positive_seconds(text: str) -> float:
    """argparse type of ``--worker-timeout``: a finite number of seconds > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text[:40]!r}") from None
    if not 0.0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text[:40]!r}")
    return value


def _positive_int(text: str) -> int:
    """argparse type of ``--workers``: a whole number of at least 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _study_status(name: str, done: int, failed: int, total: int, elapsed: float,
                  resumed: int) -> str:
    """A study's progress line. The ETA comes from the points run in this session only
    (``done - resumed``): points kept from an interrupted run took no time here."""
    remaining = total - done
    ran = done - resumed
    eta = f", ETA {elapsed / ran * remaining:.0f} s" if ran > 0 and remaining else ""
    kept = f" ({resumed} kept from an earlier run)" if resumed else ""
    return f"{name}: {done}/{total} done{kept}, {failed} failed, {remaining} remaining{eta}"


def _interrupt(signum: int, frame: object) -> None:
    """SIGTERM handler of ``rodsim study``: stop as Ctrl-C does."""
    raise KeyboardInterrupt


def cmd_study(args: argparse.Namespace) -> int:
    import signal
    import threading

    from rodsim.app.progress import ProgressPrinter
    from rodsim.app.study import StudyError, available_studies, load_study
    from rodsim.app.study_runner import parts_folder, run_study
    from rodsim.io.archive import ArchiveError

    if args.name is None:
        for name, study in available_studies().items():
            print(f"{name:<12s} {study.title}")
        return EXIT_OK
    printer = ProgressPrinter(delay=0.0)
    resumed: list[int] = []  # points recorded before this session (the first call's count)

    def progress(done: int, failed: int, total: int, elapsed: float) -> None:
        if not resumed:
            resumed.append(done)
        printer(done / total if total else 1.0,
                _study_status(args.name, done, failed, total, elapsed, resumed[0]))

    def log(message: str) -> None:
        printer.close()  # end an in-place progress line first
        print(f"rodsim: {message}", file=sys.stderr, flush=True)

    # SIGTERM stops a study as Ctrl-C does: workers ended, finished points kept.
    previous = (signal.signal(signal.SIGTERM, _interrupt)
                if threading.current_thread() is threading.main_thread() else None)
    interrupted = False
    output = ""
    try:
        study = load_study(args.name)
        output = str(_output_path(args.output, f"{args.name}-{args.size}.nc"))
        dataset = run_study(study, args.size, output, workers=args.workers,
                            scheduler=args.scheduler, progress=progress, log=log,
                            worker_timeout=args.worker_timeout)
    except (StudyError, ArchiveError) as exc:
        raise UserError(str(exc)) from None
    except KeyboardInterrupt:
        interrupted = True
        raise
    finally:
        printer.close()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if interrupted and output and parts_folder(output).is_dir():
            print(f"rodsim: study stopped; its finished points are kept in "
                  f"{parts_folder(output)}: run the same command again to resume",
                  file=sys.stderr)
    failed = int(dataset.attrs["failed_points"])
    print(f"study       {study.name} ({args.size}): {dataset.attrs['points']} points, "
          f"{failed} failed")
    unstable = int((dataset["stable"] == 0).sum()) if "stable" in dataset else 0
    if unstable:
        print(f"rodsim: warning: {unstable} point(s) of the study are UNSTABLE equilibria "
              "(the archive's 'stable' variable says which)", file=sys.stderr)
    print(f"archive     {output}")
    return EXIT_SOLVER_FAILURE if failed else EXIT_OK


def cmd_plot(args: argparse.Namespace) -> int:
    from rodsim.app import view3d
    from rodsim.app.plotting import PlotError, check_output, plot_dataset, three_dimensional
    from rodsim.io.archive import ArchiveError, read_dataset

    stem = args.output or str(Path(args.archive).with_suffix(""))
    requested = (args.format or "png,pdf").split(",")
    try:
        formats = check_output(stem, requested) if args.output else None
        dataset = read_dataset(args.archive)
        formats = formats or requested
        if args.format is None and three_dimensional(dataset) and view3d.available():
            formats = [*formats, "html"]  # a 3D shape: the interactive view too
        paths = plot_dataset(dataset, stem, formats)
    except (ArchiveError, PlotError) as exc:
        raise UserError(str(exc)) from None
    for path in paths:
        print(f"figure      {path}")
    return EXIT_OK


def cmd_bench(args: argparse.Namespace) -> int:
    import importlib

    from rodsim.app.bench_locator import BenchmarksMissing, load_benchmarks, results_folder
    from rodsim.app.progress import ProgressPrinter
    from rodsim.io.output import OutputError, probe_folder

    try:
        package = load_benchmarks()
    except BenchmarksMissing as exc:
        raise UserError(str(exc)) from None
    if args.benchmark not in package.BENCHMARKS:
        raise UserError(f"no benchmark {args.benchmark!r}; the benchmarks are "
                        + ", ".join(package.BENCHMARKS))
    module = importlib.import_module(f"{package.__name__}.{args.benchmark.replace('-', '_')}")
    if args.output_dir is not None and args.commit:
        raise UserError("give either -o/--output or --commit, not both")
    output = results_folder(args.output_dir, args.commit)
    if output is None:
        raise UserError("--commit: no benchmarks/results folder of a source checkout to write "
                        "the benchmark's results to; give the output folder with -o/--output")
    if args.output_dir is None and not args.commit:
        try:
            output.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UserError(f"cannot create the output folder {str(output)!r} "
                            f"({exc.strerror or exc}); give one with -o") from None
    try:  # before the benchmark runs, not after
        probe_folder(output, what=f"-o {output}")
    except OutputError as exc:
        raise UserError(str(exc)) from None
    printer = ProgressPrinter(delay=0.0)
    try:
        paths = module.run(args.size, output, printer)
    finally:
        printer.close()
    for path in paths:
        print(f"wrote       {path}")
    return EXIT_OK


def cmd_scenes(args: argparse.Namespace) -> int:
    from rodsim.core.scene import Scene, scene_paths

    for name, path in scene_paths().items():
        print(f"{name:<24s} {Scene.load(path).description}")
    return EXIT_OK


def cmd_terms(args: argparse.Namespace) -> int:
    from rodsim.core.terms import registered_terms

    for name, term in registered_terms().items():
        where = "rods.<rod>" if term.scope == "rod" else "tendons.<tendon rod>"
        print(f"{name:<20s} {term.equation}  [{where}.terms]")
        for parameter in term.parameters:
            print(f"    {parameter.help()}")
    return EXIT_OK


def _add_scene_set_and_output(parser: argparse.ArgumentParser, kind: str) -> None:
    """``--set`` and ``-o`` of the commands that start from a scene and write an archive
    with its figure beside it (track, fit, reach)."""
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a scene value first (repeatable)")
    parser.add_argument("-o", "--output", help=f"archive path (default: "
                        f"runs/<scene>-{kind}.nc); the figure goes beside it (.png)")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="rodsim", description="Tendon-driven catheters as Cosserat rods, to equilibrium.")
    parser.add_argument("--version", action="version", version=f"rodsim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    formatter = argparse.RawDescriptionHelpFormatter

    run = sub.add_parser("run", help="simulate one scene to equilibrium and archive it",
                         formatter_class=formatter, epilog=_scene_keys_help,  # type: ignore[arg-type]
                         description="Simulate a scene to equilibrium, print a summary and "
                         "write a netCDF archive. SCENE is a TOML file or a shipped scene "
                         "name (`rodsim scenes`); default: table1-50g (paper Table 1, 50 g).")
    run.add_argument("scene", nargs="?", help="scene file or shipped scene name")
    run.add_argument("--integrator", metavar="NAME",
                     help="a registered integrator, listed by `rodsim run --help` (default: "
                     "the scene's solver.integrator, cvode)")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene value (repeatable), e.g. --set nodes=80")
    run.add_argument("-o", "--output",
                     help="archive path (default: runs/<scene>-<integrator>.nc)")
    run.add_argument("--require-stable", action="store_true",
                     help="exit 1 when the equilibrium found is unstable (its stiffness is "
                     "not positive definite; the archive is still written)")
    run.add_argument("--require-physical", action="store_true",
                     help="exit 1 when a rod tendon carries compression (a tendon cannot "
                     "push; the archive is still written)")
    run.set_defaults(func=cmd_run)

    again = sub.add_parser("rerun", help="re-run an archive and compare with what it stores",
                           description="Re-run the scene and integrator stored in ARCHIVE "
                           "and report the largest difference from the stored positions.")
    again.add_argument("archive", help="netCDF archive written by `rodsim run` or `study`")
    again.add_argument("--point", action="append", default=[], metavar="DIM=VALUE",
                       help="study archives: re-run only the points with this swept value "
                       "(repeatable); default: every point")
    again.add_argument("--tolerance", type=_tolerance, default=1e-9, metavar="FRACTION_OF_L",
                       help="exit 1 if the positions differ by more than this × L "
                       "(default 1e-9)")
    again.set_defaults(func=cmd_rerun)

    study = sub.add_parser("study", help="run a study (the paper's figures) into one archive",
                           description="Run a shipped study (studies/*.py) over its grid on "
                           "local processes or a dask cluster; finished points are kept in "
                           "OUT.parts/ so a killed or interrupted (Ctrl-C, SIGTERM) study "
                           "resumes. Without NAME: list them.")
    study.add_argument("name", nargs="?", help="study name (fig6, fig7a, …, convergence)")
    study.add_argument("-o", "--output", help="archive path (default: runs/<name>-<size>.nc)")
    study.add_argument("--size", choices=("small", "full"), default="full",
                       help="grid size: small (smoke test) or full (default)")
    study.add_argument("--workers", type=_positive_int, default=None,
                       help="local worker processes (default: all cores; 1 = in-process)")
    study.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on a dask.distributed scheduler (tcp://host:port), or "
                       "'local' for a LocalCluster")
    study.add_argument("--worker-timeout", type=_positive_seconds, default=60.0,
                       metavar="SECONDS",
                       help="with --scheduler: fail when the scheduler has had no worker for "
                       "this long while points wait (default 60)")
    study.set_defaults(func=cmd_study)

    follow = sub.add_parser(
        "track", help="equilibria along an actuation path, each warm-started from the last",
        description="Solve a sequence of equilibria while scene values ramp together "
        "(--ramp, repeatable: every ramp needs the same COUNT); each step starts from the "
        "previous equilibrium, a failing step is retried with halved increments. Writes "
        "one archive with a `step` dimension and a figure (docs/inverse.md).")
    follow.add_argument("scene", help="scene file or shipped scene name")
    follow.add_argument("--ramp", action="append", required=True,
                        metavar="KEY=START:STOP:COUNT",
                        help="ramp a numeric scene value (KEY as for --set; KEY[i] for a "
                        "vector component), e.g. --ramp tendon_actuation.force=0:4:101")
    follow.add_argument("--integrator", metavar="NAME",
                        help="a registered integrator, listed by `rodsim run --help` "
                        "(default: static)")
    follow.add_argument("--allow-unstable", action="store_true",
                        help="go on past a step whose equilibrium is unstable (its "
                        "stiffness is not positive definite, e.g. a rod loaded past "
                        "buckling), flagged in the output and the archive; by default the "
                        "track stops there and exits 1 (the steps up to it archived)")
    _add_scene_set_and_output(follow, "track")
    follow.set_defaults(func=cmd_track)

    calibrate = sub.add_parser(
        "fit", help="fit scene values to a measured centerline (least squares)",
        description="Fit numeric scene values (--param, repeatable) to measured points of "
        "a rod's centerline by least squares on the analytic sensitivities; reports the "
        "fitted values with standard errors, writes the archive of the fitted scene (`rodsim "
        "rerun` re-solves it) and a figure of data and fit (docs/inverse.md).")
    calibrate.add_argument("scene", help="scene file or shipped scene name (its values are "
                           "the starting point)")
    calibrate.add_argument("--data", required=True, metavar="POINTS.csv",
                           help="CSV with header x,y,z [m] and optionally s (rest arc "
                           "length [m]); any number and spacing of points")
    calibrate.add_argument("--param", action="append", required=True, metavar="KEY",
                           help="numeric scene value to fit (KEY as for --set), e.g. K_E")
    calibrate.add_argument("--rod", help="rod the points belong to (default: the first)")
    _add_scene_set_and_output(calibrate, "fit")
    calibrate.set_defaults(func=cmd_fit)

    aim = sub.add_parser(
        "reach", help="actuation values that put the tip at a target (inverse kinematics)",
        description="Find values of the --actuate keys (e.g. the tensions of several "
        "tendons) that put a rod's tip at --tip, by least squares on the analytic "
        "sensitivities within each value's allowed range (tensions >= 0). Exit 1 when the "
        "target is out of reach, with the closest tip found (docs/inverse.md).")
    aim.add_argument("scene", help="scene file or shipped scene name (its values are the "
                     "starting point)")
    aim.add_argument("--tip", required=True, type=_target, metavar="X,Y,Z",
                     help="target of the tip [m]")
    aim.add_argument("--actuate", action="append", required=True, metavar="KEY",
                     help="numeric scene value to vary (repeatable), e.g. "
                     "tendon_py.tendon_actuation.force")
    aim.add_argument("--frame", type=_frame, metavar="D1X,D1Y,D1Z,D3X,D3Y,D3Z",
                     help="also the tip's orientation: directors d1 and d3 of the last "
                     "segment (d3 the tangent); reached within --tolerance / L rad")
    aim.add_argument("--rod", help="rod whose tip is placed (default: the first)")
    aim.add_argument("--tolerance", type=_tolerance, default=1e-6, metavar="METRES",
                     help="distance at which the target counts as reached (default 1e-6 m)")
    _add_scene_set_and_output(aim, "reach")
    aim.set_defaults(func=cmd_reach)

    plot = sub.add_parser("plot", help="draw an archive's figure (PNG and PDF)",
                          description="Draw the figure of an archive written by `rodsim "
                          "run`, `study`, `track`, `fit` or `reach`, from the archive alone "
                          "(no solve): STEM.png and STEM.pdf, by default beside the archive "
                          "under its name.")
    plot.add_argument("archive", help="archive written by `rodsim run` or `rodsim study`")
    plot.add_argument("-o", "--output", metavar="STEM",
                      help="output path without extension (default: the archive's)")
    plot.add_argument("--format", default=None,
                      help="comma-separated formats matplotlib writes: png, pdf, svg, …, "
                      "and html, the interactive 3D view of a run, track, fit or reach "
                      "(needs plotly: pip install \"rodsim[view3d]\"; added by default "
                      "for a shape that leaves the x-y plane when plotly is installed) "
                      "(default png,pdf)")
    plot.set_defaults(func=cmd_plot)

    bench = sub.add_parser("bench", help="run a benchmark (work-precision, scaling, large-n, "
                           "stress, skip-work, kernels, paper-regime, pyelastica, "
                           "string-tendon, contact, startup, tracking, workers)",
                           description="Time the integrators against their error, their cost "
                           "in N, or their stability over a parameter map; writes netCDF, "
                           "figures and a markdown table with the machine description. The "
                           "benchmarks live in the benchmarks/ folder of a source checkout "
                           "(benchmarks/rodsim_bench), not in the installed package: rodsim "
                           "finds the checkout it was imported or pip-installed from, or the "
                           "one the current folder is in.")
    bench.add_argument("benchmark", metavar="BENCHMARK",
                       help="work-precision, scaling, large-n, stress, skip-work, kernels, "
                       "paper-regime, string-tendon, contact, startup, tracking, workers or "
                       "pyelastica (the last needs 'pip install pyelastica==1.0.0'; never a "
                       "dependency)")
    bench.add_argument("--size", choices=("small", "full"), default="small",
                       help="small (the default): a smoke version in seconds to a minute; "
                       "full: the real benchmark (minutes to an hour, docs/benchmarks.md)")
    bench.add_argument("-o", "--output", "--output-dir", dest="output_dir", default=None,
                       metavar="DIR",
                       help="folder for the results (default: runs/bench of the current "
                       "folder)")
    bench.add_argument("--commit", action="store_true",
                       help="write into the checkout's committed benchmarks/results instead "
                       "(to update the published numbers)")
    bench.set_defaults(func=cmd_bench)

    scenes = sub.add_parser("scenes", help="list the shipped scenes (paper Tables 1 and 3)")
    scenes.set_defaults(func=cmd_scenes)

    terms = sub.add_parser("terms", help="list the energy and coupling terms a scene can use")
    terms.set_defaults(func=cmd_terms)
    return parser


def main(argv: Sequence[str] | None = None, *, process: bool = False) -> int:
    """The ``rodsim`` command. It pins BLAS threads (:mod:`rodsim.app.threads`) and, as it
    only writes figures to files, selects matplotlib's file backend unless ``MPLBACKEND`` is
    set — before anything imports numpy or matplotlib.

    ``process``: this call is the whole process (:func:`entry`, the installed command and
    ``python -m rodsim``): a command of :data:`~rodsim.app.lean.LEAN_COMMANDS` then hides
    dask from xarray, and one of :data:`~rodsim.app.lean.EARLY_EXIT_COMMANDS` ends the
    process at once when it returns normally (:mod:`rodsim.app.lean`)."""
    pin_threads()
    os.environ.setdefault("MPLBACKEND", "Agg")
    parser = build_parser()
    args = parser.parse_args(argv)
    command: Callable[[argparse.Namespace], int] = args.func
    from rodsim.app.lean import EARLY_EXIT_COMMANDS, LEAN_COMMANDS, fast_exit, hide_dask
    from rodsim.io.provenance import invocation

    if process and args.command in LEAN_COMMANDS:
        hide_dask()
    words = list(sys.argv[1:] if argv is None else argv)
    _created_output_folder.clear()
    try:
        with invocation(shlex.join(["rodsim", *words])):  # the archives' history line
            code = command(args)
        if process and args.command in EARLY_EXIT_COMMANDS:
            fast_exit(code)
        return code
    except UserError as exc:
        _remove_created_output_folder()  # exit 2 leaves nothing behind, an empty runs/ too
        print(f"rodsim: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except MemoryError:  # beyond the estimate (rodsim.core.memory): still one line
        _remove_created_output_folder()
        print("rodsim: error: out of memory (the process's limit or the machine's); lower "
              "rods.<rod>.nodes, or raise the limit (ulimit -v)", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:  # output piped into a closed reader (e.g. `| head`)
        sys.stderr.close()
        return EXIT_OK
    except KeyboardInterrupt:
        print("rodsim: interrupted", file=sys.stderr)
        return 130


def entry() -> NoReturn:
    """The installed ``rodsim`` command and ``python -m rodsim``: :func:`main` as the whole
    process."""
    sys.exit(main(process=True))


if __name__ == "__main__":
    entry()
