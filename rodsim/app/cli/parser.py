"""The ``rodsim`` argument parser: every command, its arguments and its handler. Building it
imports the handlers' modules only, which import nothing heavy at module level (``rodsim
--help`` needs neither numpy nor the solvers: tests/test_lean_process.py)."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any, NoReturn

from rodsim.app.cli.arguments import (
    add_scene_set_and_output,
    frame_type,
    positive_int,
    positive_seconds,
    target_type,
    tolerance_type,
)
from rodsim.app.cli.batch import cmd_batch
from rodsim.app.cli.bench import cmd_bench
from rodsim.app.cli.common import EXIT_BAD_INPUT
from rodsim.app.cli.compile import cmd_compile
from rodsim.app.cli.fit import Fit
from rodsim.app.cli.fit_series import cmd_fit
from rodsim.app.cli.listing import cmd_scenes, cmd_terms
from rodsim.app.cli.modes import Modes, cmd_modes
from rodsim.app.cli.plot import cmd_plot
from rodsim.app.cli.reach import Reach, cmd_reach
from rodsim.app.cli.rerun import cmd_rerun
from rodsim.app.cli.run import cmd_run
from rodsim.app.cli.simulate import Simulate, cmd_simulate
from rodsim.app.cli.study import cmd_study
from rodsim.app.cli.track import Track, cmd_track
from rodsim.version import __version__

__all__ = ["OneLineParser", "build_parser"]


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


def scene_keys_help() -> str:
    """Every scene key with unit and default, for ``--help`` epilogs."""
    from rodsim.core.rod.rod import ROD_PARAMETERS
    from rodsim.core.scene import SOLVER_PARAMETERS
    from rodsim.core.terms import registered_terms
    from rodsim.solvers import registered_integrators

    lines = ["scene keys for --set (any unambiguous suffix works, e.g. nodes=80, mass=0.1):",
             "  rods.<rod>:"]
    lines += [f"    {p.help()}" for p in ROD_PARAMETERS]
    for name, term in registered_terms().items():
        if term.scope == "support":  # a support kind's energy: its keys are the base's
            continue
        if term.scene_table:
            prefix = f"{term.scene_table}.<name>"
        else:
            where = "rods.<rod>" if term.scope == "rod" else "tendons.<tendon rod>"
            prefix = f"{where}.{term.key}" + ("" if term.key == name else f" ({name})")
        if term.parameters:
            lines.append(f"  {prefix}:  [{term.equation}]")
            lines += [f"    {p.help()}" for p in term.parameters]
    lines.append("  solver:")
    lines += [f"    {p.help()}" for p in SOLVER_PARAMETERS]
    for name, integrator in registered_integrators().items():
        lines.append(f"  solver.{name}:  [{integrator.summary}]")
        lines += [f"    {p.help()}" for p in integrator.parameters]
    return "\n".join(lines)


#: The SCENE argument's help of the commands that start from a scene's values.
STARTING_SCENE = "scene file or shipped scene name (its values are the starting point)"


def _scene_command(sub: Any, name: str, command: type, scene_help: str, help: str
                   ) -> argparse.ArgumentParser:
    """A command that solves a scene (track, fit, reach): its parser, described by the
    command class's docstring, with the SCENE argument first."""
    parser = sub.add_parser(name, help=help, description=command.__doc__)
    parser.add_argument("scene", help=scene_help)
    return parser


def _add_warm_integrator(parser: argparse.ArgumentParser) -> None:
    """``--integrator`` of the commands that solve many warm-started equilibria (track,
    fit, reach): any registered integrator, the registry's default without it."""
    parser.add_argument("--integrator", metavar="NAME",
                        help="the integrator of every equilibrium, any registered one "
                        "(listed by `rodsim run --help`; default: static, the fastest "
                        "from a warm start)")


def _finish_scene_command(parser: argparse.ArgumentParser, kind: str,
                          handler: Callable[[argparse.Namespace], int]) -> None:
    """``--set`` and ``-o`` last (after the command's own options), and the handler."""
    add_scene_set_and_output(parser, kind)
    parser.set_defaults(func=handler)


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="rodsim", description="Tendon-driven catheters as Cosserat rods, to equilibrium.")
    parser.add_argument("--version", action="version", version=f"rodsim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    formatter = argparse.RawDescriptionHelpFormatter

    run = sub.add_parser("run", help="simulate one scene to equilibrium and archive it",
                         formatter_class=formatter, epilog=scene_keys_help,  # type: ignore[arg-type]
                         description="Simulate a scene to equilibrium, print a summary and "
                         "write a netCDF archive. SCENE is a TOML file or a shipped scene "
                         "name (`rodsim scenes`); default: table1-50g (paper Table 1, 50 g).")
    run.add_argument("scene", nargs="?", help="scene file or shipped scene name")
    run.add_argument("--integrator", metavar="NAME",
                     help="a registered integrator, listed by `rodsim run --help` (default: "
                     "the scene's solver.integrator; unset: static, or ida with obstacles)")
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
    again.add_argument("--tolerance", type=tolerance_type, default=1e-9, metavar="FRACTION_OF_L",
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
    study.add_argument("--workers", type=positive_int, default=None,
                       help="local worker processes (default: all cores; 1 = in-process); "
                            "with --scheduler local, the LocalCluster's workers (default 2)")
    study.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on a dask.distributed scheduler (tcp://host:port), or "
                       "'local' for a LocalCluster")
    study.add_argument("--worker-timeout", type=positive_seconds, default=60.0,
                       metavar="SECONDS",
                       help="with --scheduler: fail when the scheduler has had no worker for "
                       "this long while points wait (default 60)")
    study.set_defaults(func=cmd_study)

    many = sub.add_parser("batch", help="the equilibria of many cases of one scene into one "
                          "archive", description="Solve SCENE once per row of a cases table "
                          "(a CSV whose header names numeric scene keys, as for --set) on "
                          "local processes or a dask cluster, one model shared; finished "
                          "cases are kept in OUT.parts/ so a killed batch resumes "
                          "(docs/batch.md).")
    many.add_argument("scene", help="scene file or shipped scene name")
    many.add_argument("--cases", required=True, metavar="CASES.csv",
                      help="CSV: a header of scene keys (KEY[i] for a vector component), "
                      "then one row of values per case")
    many.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                      help="override a scene value for every case (repeatable)")
    many.add_argument("--integrator", metavar="NAME",
                      help="a registered integrator (default: static)")
    many.add_argument("-o", "--output", help="archive path (default: runs/<scene>-batch.nc)")
    many.add_argument("--workers", type=positive_int, default=None,
                      help="local worker processes (default: all cores; 1 = in-process); "
                      "with --scheduler local, the LocalCluster's workers (default 2)")
    many.add_argument("--scheduler", metavar="ADDRESS",
                      help="run on a dask.distributed scheduler (tcp://host:port), or "
                      "'local' for a LocalCluster")
    many.add_argument("--chunk", type=positive_int, default=50, metavar="CASES",
                      help="cases per task and per file of OUT.parts/ (default 50)")
    many.add_argument("--warm", action="store_true",
                      help="start each case from a neighbouring case's equilibrium (fewer "
                      "Newton iterations; equal to the cold solves to their round-off, "
                      "docs/batch.md 'Warm starts')")
    many.add_argument("--penalty", action="store_true",
                      help="also estimate each case's penalty error, as rodsim run does (one "
                      "more warm solve per case: about 1.7x the batch's time on "
                      "tdcr-two-segment; docs/batch.md)")
    many.set_defaults(func=cmd_batch)

    follow = _scene_command(sub, "track", Track, "scene file or shipped scene name",
                            help="equilibria along an actuation path, each warm-started "
                            "from the last")
    follow.add_argument("--ramp", action="append", required=True,
                        metavar="KEY=START:STOP:COUNT",
                        help="ramp a numeric scene value (KEY as for --set; KEY[i] for a "
                        "vector component), e.g. --ramp tendon_actuation.force=0:4:101; "
                        "further :STOP:COUNT legs go on from the last stop (0:4:101:0:100: "
                        "up and back down)")
    _add_warm_integrator(follow)
    follow.add_argument("--allow-unstable", action="store_true",
                        help="go on past a step whose equilibrium is unstable (its "
                        "stiffness is not positive definite, e.g. a rod loaded past "
                        "buckling), flagged in the output and the archive; by default the "
                        "track stops there and exits 1 (the steps up to it archived)")
    _finish_scene_command(follow, "track", cmd_track)

    calibrate = _scene_command(sub, "fit", Fit, STARTING_SCENE,
                               help="fit scene values to a measured centerline, or to tips "
                               "measured along a ramp (least squares)")
    measured = calibrate.add_mutually_exclusive_group(required=True)
    measured.add_argument("--data", metavar="POINTS.csv",
                          help="CSV with header x,y,z [m] and optionally s (rest arc "
                          "length [m]); any number and spacing of points")
    measured.add_argument("--series", metavar="TIPS.csv",
                          help="CSV with header x,y,z [m], the tip measured at each value of "
                          "the --ramp (one row per value, in order): e.g. a tendon's "
                          "friction from a pull-release cycle")
    calibrate.add_argument("--ramp", action="append", default=[],
                           metavar="KEY=START:STOP:COUNT",
                           help="with --series: the ramp the tips were measured along, as "
                           "for `rodsim track` (legs up and back down: 0.5:3:6:0.5:5)")
    calibrate.add_argument("--param", action="append", required=True, metavar="KEY",
                           help="numeric scene value to fit (KEY as for --set), e.g. K_E")
    calibrate.add_argument("--rod", help="rod the points belong to (default: the first)")
    _add_warm_integrator(calibrate)
    _finish_scene_command(calibrate, "fit", cmd_fit)

    aim = _scene_command(sub, "reach", Reach, STARTING_SCENE, help="actuation values that put "
                         "the tip at a target (inverse kinematics)")
    aim.add_argument("--tip", required=True, type=target_type, metavar="X,Y,Z",
                     help="target of the tip [m]")
    aim.add_argument("--actuate", action="append", required=True, metavar="KEY",
                     help="numeric scene value to vary (repeatable), e.g. "
                     "tendon_py.tendon_actuation.force")
    aim.add_argument("--frame", type=frame_type, metavar="D1X,D1Y,D1Z,D3X,D3Y,D3Z",
                     help="also the tip's orientation: directors d1 and d3 of the last "
                     "segment (d3 the tangent); reached within --tolerance / L rad")
    aim.add_argument("--rod", help="rod whose tip is placed (default: the first)")
    aim.add_argument("--tolerance", type=tolerance_type, default=1e-6, metavar="METRES",
                     help="distance at which the target counts as reached (default 1e-6 m)")
    _add_warm_integrator(aim)
    _finish_scene_command(aim, "reach", cmd_reach)

    vibrate = _scene_command(sub, "modes", Modes, "scene file or shipped scene name",
                             help="natural frequencies and mode shapes about the equilibrium")
    vibrate.add_argument("--count", type=positive_int, default=6, metavar="K",
                         help="number of modes, lowest first (default 6)")
    _finish_scene_command(vibrate, "modes", cmd_modes)

    move = _scene_command(sub, "simulate", Simulate, "scene file or shipped scene name",
                          help="motion in physical time (inertia, damping, programs)")
    move.add_argument("--t-end", required=True, type=positive_seconds, metavar="T",
                      help="end time [s]; the run starts at t = 0, at rest")
    move.add_argument("--output-dt", type=positive_seconds, metavar="DT",
                      help="spacing of the stored times [s] (default: every step); "
                      "times between steps are interpolated and cost no step")
    move.add_argument("--step", type=positive_seconds, metavar="DT",
                      help="longest time step [s] (midpoint, paper default: 1/100 of the "
                      "lowest natural period at the start)")
    move.add_argument("--integrator", default="midpoint", metavar="NAME",
                      help="integrator of physical time: midpoint (default; fixed steps), "
                      "midpoint4 (fixed steps of order 4, five midpoint steps each), "
                      "paper (the paper's semi-implicit Euler, Eqs. 14-17, with the physical "
                      "masses: fixed steps, first order, numerically damped), ida (SUNDIALS "
                      "IDA: adaptive BDF under error control) or cvode (SUNDIALS CVODE, the "
                      "same on the explicit form: small rods)")
    move.add_argument("--rtol", type=float, metavar="R",
                      help="ida, cvode: relative tolerance (default 1e-5); midpoint: given, "
                      "its steps are chosen under error control (--step the longest)")
    move.add_argument("--atol", type=float, metavar="A",
                      help="ida, cvode: absolute tolerance, x the longest rod's length on "
                      "positions, radians on angles, x the lowest natural angular frequency on "
                      "their rates (default 1e-5; midpoint with --rtol: positions and "
                      "angles, default --rtol)")
    move.add_argument("--max-order", type=int, metavar="K",
                      help="ida, cvode: highest BDF order, 1 to 5 (default 2: orders 3-5 are not "
                      "A-stable and an undamped rod's modes sit on the imaginary axis)")
    move.add_argument("--initial", action="append", default=[], metavar="KEY=VALUE",
                      help="start from the equilibrium with this value (KEY as for --set; "
                      "repeatable): released at t = 0")
    move.add_argument("--event", action="append", default=[], metavar="contact|slack[:stop]",
                      help="record when a rod first touches an obstacle (contact) or a string "
                      "tendon's tension reaches zero (slack); ':stop' ends the run there "
                      "(repeatable; any integrator: SUNDIALS' root finding for ida and cvode, "
                      "each midpoint step checked and the time located within it)")
    move.add_argument("--initial-velocity", metavar="VX,VY,VZ",
                      help="start with every free node moving at this velocity [m/s] "
                      "(default: at rest)")
    move.add_argument("--program", action="append", default=[],
                      metavar="KEY=t0:v0,t1:v1,...|KEY=sin:A,F[,PHASE[,OFFSET]]",
                      help="a numeric value following a piecewise-linear table in time, or "
                      "the sinusoid OFFSET + A sin(2 pi F t + PHASE) (F in Hz, PHASE in rad, "
                      "OFFSET by default the scene's value); repeatable, replaces the scene "
                      "file's [program] entry for the same value; e.g. "
                      "tendon_actuation.force=0:0,0.1:2 or tip_load.force[1]=sin:0.1,5")
    _finish_scene_command(move, "simulate", cmd_simulate)

    plot = sub.add_parser("plot", help="draw an archive's figure (PNG and PDF)",
                          description="Draw the figure of an archive written by `rodsim "
                          "run`, `study`, `track`, `fit`, `reach`, `modes` or `simulate`, from "
                          "the archive "
                          "alone "
                          "(no solve): STEM.png and STEM.pdf, by default beside the archive "
                          "under its name.")
    plot.add_argument("archive", help="archive written by `rodsim run`, `study`, `track`, "
                      "`fit`, `reach`, `modes` or `simulate`")
    plot.add_argument("-o", "--output", metavar="STEM",
                      help="output path without extension (default: the archive's); "
                      "STEM.mp4 or STEM.gif writes that movie of a track or trajectory "
                      "alone (with figures too when --format is given)")
    plot.add_argument("--format", default=None,
                      help="comma-separated formats matplotlib writes: png, pdf, svg, …, "
                      "and html, the interactive 3D view of a run, track, fit, reach or trajectory "
                      "(needs plotly: pip install \"rodsim[view3d]\"; added by default "
                      "for a shape that leaves the x-y plane when plotly is installed) "
                      "(default png,pdf)")
    plot.add_argument("--colour", "--color", dest="colour", default=None,
                      choices=("curvature", "strain", "tension"),
                      help="colour the rods by their bending curvature [1/m] or axial "
                      "strain, or the tendons by their tension [N], with a colour bar: a "
                      "run's figure, a track's or trajectory's (every state on one scale), "
                      "their movie and the html view")
    plot.add_argument("--hide", default="", metavar="LAYERS",
                      help="comma-separated layers to leave out of the figure of a run, track "
                      "or trajectory, their movie and the html view: shape (the rods), "
                      "tendon, load, contact (the contact forces), obstacle")
    plot.add_argument("--show", default=None, metavar="LAYERS",
                      help="comma-separated layers to draw, the others left out (the axes, "
                      "titles, colour bar and a track's or trajectory's other panels are "
                      "always drawn): the same names and figures as --hide, which it does "
                      "not combine with")
    plot.add_argument("--cdn", action="store_true",
                      help="write the html view (adding html to the formats) with plotly's "
                      "JavaScript loaded from its CDN when the page opens: ~4.8 MB smaller "
                      "(the view alone), and it needs the network to open")
    plot.add_argument("--movie", action="store_true",
                      help="also write a movie of a track (one frame per step) or of a "
                      "trajectory (rodsim simulate: one frame per output time, at most 120): "
                      "STEM.mp4 when an ffmpeg is found (pip install \"rodsim[movie]\", or "
                      "ffmpeg on the PATH), else STEM.gif; a note says which")
    plot.add_argument("--movie-format", choices=("mp4", "gif"), default=None,
                      help="the movie's format (implies --movie); mp4 with no ffmpeg is "
                      "refused before anything is written, as is a format other than the "
                      "one -o STEM.mp4 or STEM.gif names")
    plot.set_defaults(func=cmd_plot)

    bench = sub.add_parser("bench", help="run a benchmark (work-precision, scaling, large-n, "
                           "stress, skip-work, kernels, paper-regime, pyelastica, "
                           "string-tendon, contact, force-from-shape, floor, iterations, "
                           "startup, tracking, workers, modes, friction, batch, dynamics, "
                           "step-cost, real-time, cvode-scaling, time-scaling, "
                           "pyelastica-dynamics)",
                           description="Time the integrators against their error, their cost "
                           "in N, or their stability over a parameter map; writes netCDF, "
                           "figures and a markdown table with the machine description. The "
                           "benchmarks live in the benchmarks/ folder of a source checkout "
                           "(benchmarks/rodsim_bench), not in the installed package: rodsim "
                           "finds the checkout it was imported or pip-installed from, or the "
                           "one the current folder is in.")
    bench.add_argument("benchmark", metavar="BENCHMARK",
                       help="work-precision, scaling, large-n, stress, skip-work, kernels, "
                       "paper-regime, string-tendon, contact, force-from-shape, floor, "
                       "iterations, startup, tracking, workers, modes, friction, batch, "
                       "dynamics, step-cost, real-time, cvode-scaling, time-scaling, hostile, "
                       "pyelastica or "
                       "pyelastica-dynamics (the last two need "
                       "'pip install pyelastica==1.0.0'; never a dependency)")
    bench.add_argument("--size", choices=("small", "medium", "full"), default="small",
                       help="small (the default): a smoke version in seconds to a minute; "
                       "full: the real benchmark (minutes to an hour, docs/benchmarks.md); "
                       "medium: between them, for the benchmarks that declare it (stress)")
    bench.add_argument("-o", "--output", "--output-dir", dest="output_dir", default=None,
                       metavar="DIR",
                       help="folder for the results (default: runs/bench of the current "
                       "folder)")
    bench.add_argument("--commit", action="store_true",
                       help="write into the checkout's committed benchmarks/results instead "
                       "(to update the published numbers)")
    bench.set_defaults(func=cmd_bench)

    compile_ = sub.add_parser(
        "compile", help="compile every kernel a scene can need into numba's disk cache now "
        "(optional, once after installing: later runs then load them)",
        description="Compile the compiled kernels ahead of time: solve every shipped scene, "
        "table1-50g with every integrator and small scenes with every term, obstacle, load, "
        "tendon and friction with solver.kernels = compiled, so that numba writes each "
        "kernel to its on-disk cache (beside the package, else numba's user cache, or "
        "NUMBA_CACHE_DIR). A later process loads them instead of compiling (seconds each). "
        "Prints a progress line and a summary (kernels, seconds).")
    compile_.add_argument("scenes", nargs="*", metavar="SCENE",
                          help="only these shipped scenes (or compile-* coverage scenes), "
                          "each with its own integrator; default: everything")
    compile_.set_defaults(func=cmd_compile)

    scenes = sub.add_parser("scenes", help="list the shipped scenes (paper Tables 1 and 3)")
    scenes.set_defaults(func=cmd_scenes)

    terms = sub.add_parser("terms", help="list the energy and coupling terms a scene can use")
    terms.set_defaults(func=cmd_terms)
    return parser
