"""``rodsim simulate``: how a scene moves in physical time (docs/dynamics.md)."""

from __future__ import annotations

import argparse
import math
from typing import Any

from rodsim.app.cli.common import EXIT_OK, EXIT_SOLVER_FAILURE, UserError, scene_error_text
from rodsim.app.cli.pipeline import SceneCommand, execute

__all__ = ["Simulate", "cmd_simulate", "parse_program"]


def parse_program(text: str) -> tuple[str, Any]:
    """``KEY=t0:v0,t1:v1,...`` → (KEY, (times, values)) and
    ``KEY=sin:AMPLITUDE,FREQUENCY[,PHASE[,OFFSET]]`` → (KEY, the sinusoid's table: frequency
    in Hz, phase in rad, offset by default the scene's value); a one-line
    ``UserError`` for anything else."""
    flag = f"--program {text[:60]!r}"
    key, sep, table = text.partition("=")
    if not sep or not key.strip() or not table.strip():
        raise UserError(f"{flag}: expected KEY=t0:v0,t1:v1,... (times in s) or "
                        "KEY=sin:AMPLITUDE,FREQUENCY[,PHASE[,OFFSET]]")
    form, colon, rest = table.partition(":")
    if form.strip().lower() == "sin" and colon:
        parts = rest.split(",")
        numbers = []
        for part in parts:
            try:
                numbers.append(float(part))
            except ValueError:
                numbers.append(math.nan)
        if not 2 <= len(numbers) <= 4 or not all(math.isfinite(n) for n in numbers):
            raise UserError(f"{flag}: expected sin:AMPLITUDE,FREQUENCY[,PHASE[,OFFSET]] (two "
                            "to four finite numbers; frequency in Hz, phase in rad)")
        return key.strip(), dict(zip(("amplitude", "frequency", "phase", "offset"), numbers,
                                     strict=False))
    times, values = [], []
    for pair in table.split(","):
        t, colon, v = pair.partition(":")
        try:
            time, value = float(t), float(v)
        except ValueError:
            time = value = math.nan
        if not colon or not (math.isfinite(time) and math.isfinite(value)):
            raise UserError(f"{flag}: {pair.strip()[:40]!r} is not TIME:VALUE (two finite "
                            "numbers), nor is the value sin:AMPLITUDE,FREQUENCY[,PHASE[,OFFSET]]")
        times.append(time)
        values.append(value)
    return key.strip(), (times, values)


class Simulate(SceneCommand):
    """Integrate the scene in physical time from t = 0 to --t-end (the implicit midpoint
    rule, the paper's semi-implicit Euler with --integrator paper, or SUNDIALS IDA or CVODE
    with --integrator ida or cvode; the rods' inertia and damping;
    docs/dynamics.md). The run starts at rest, from the rest
    state or from the equilibrium with the --initial values (a release), with
    --initial-velocity a uniform velocity of every free node; --program makes a
    value follow a piecewise-linear table or a sinusoid in time (as the scene file's
    [program] table does; --program replaces its entry for the same value). Prints the
    progress in simulated time and a summary (tip at the end, energy balance, steps);
    writes the trajectory archive and a figure of the tip and the energies against time. A
    run that fails part-way writes what it computed, marked incomplete, and exits 1."""

    kind = "simulate"

    def bad_input(self) -> tuple[type[Exception], ...]:
        from rodsim.core.scene import SceneError

        return (SceneError,)

    def prepare(self, scene: Any) -> None:
        from rodsim.app.simulate import INTEGRATORS, check_programs, ida_options
        from rodsim.core.scene import SceneError

        args = self.args
        if args.integrator not in INTEGRATORS:
            raise UserError(f"--integrator {args.integrator[:40]!r}: allowed: "
                            + ", ".join(INTEGRATORS))
        try:
            ida_options(args.integrator, args.rtol, args.atol, args.max_order)
        except SceneError as exc:
            raise UserError("--" + str(exc).replace("_", "-", 1)) from None
        self.program = dict(parse_program(text) for text in args.program)
        self.velocity = None
        if args.initial_velocity is not None:
            from rodsim.app.initial_velocity import parse_velocity

            try:
                self.velocity = parse_velocity(args.initial_velocity)
            except ValueError as exc:
                raise UserError(str(exc)) from None
        try:  # the scene file's [program] first, then each --program
            check_programs(scene, {})
        except SceneError as exc:
            raise UserError(f"{scene.name}: {exc}") from None
        for key, table in self.program.items():
            try:
                check_programs(scene, {key: table})
            except SceneError as exc:
                text = str(exc)
                raise UserError(text if text.startswith("program")
                                else f"--program {key[:60]!r}: {text}") from None
        self.initial_scene = None
        if args.initial:
            from rodsim.app.api import load_scene

            try:
                self.initial_scene = load_scene(scene, args.initial)
            except SceneError as exc:
                raise UserError(scene_error_text(exc).replace("--set", "--initial", 1)
                                ) from None

    def solve(self, scene: Any, integrator: str, progress: Any) -> Any:
        from rodsim.app.api import solve
        from rodsim.app.initial_velocity import velocity_text
        from rodsim.app.interrupted import Interrupted
        from rodsim.app.simulate import simulate

        args = self.args
        t_end = args.t_end
        self.scene = scene
        initial = None
        if self.initial_scene is not None:
            initial = solve(self.initial_scene, "static")

        def report(t: float) -> None:
            progress(t / t_end, f"t = {t:.6g} s of {t_end:g} s")

        started = "equilibrium with " + ", ".join(args.initial) if args.initial else None
        if started:
            started += velocity_text(self.velocity)
        try:
            run = simulate(scene, t_end, output_dt=args.output_dt, integrator=args.integrator,
                           initial=initial, program=self.program, step=args.step,
                           progress=report, rtol=args.rtol, atol=args.atol,
                           max_order=args.max_order, initial_velocity=self.velocity,
                           events=args.event)
        except Interrupted as stop:  # written by the pipeline, marked incomplete
            if started:
                stop.partial.initial = started
            raise
        if started:
            run.initial = started
        return run

    def report(self, result: Any) -> None:
        from rodsim.app.simulate import FIXED_STEP

        name = next(iter(self.scene.rods))
        tip = result.positions[-1, self.scene.rods[name].nodes - 1]
        print(f"scene       {self.scene.name}: {result.integrator}, t = 0 to "
              f"{result.times[-1]:.6g} s of {result.t_end:g} s, {len(result.times)} outputs")
        print(f"tip         {name} at t = {result.times[-1]:.6g} s: "
              f"({tip[0]:.6g}, {tip[1]:.6g}, {tip[2]:.6g}) m")
        error = float(abs(result.energy_error).max())
        if math.isnan(error):
            print("energy      no balance (a non-conservative term: no potential energy)")
        else:
            scale = float(max(abs(result.kinetic_energy).max(),
                              abs(result.potential_energy - result.potential_energy[0]).max(),
                              abs(result.dissipated_energy).max(), abs(result.work).max()))
            relative = f" ({error / scale:.2e} of the largest energy change)" if scale else ""
            print(f"energy      balance error {error:.3e} J{relative}")
        if result.integrator not in FIXED_STEP:
            print(f"steps       {result.steps} (the longest {result.step_size:.4g} s), "
                  f"{result.iterations} residual evaluations")
        else:
            print(f"steps       {result.steps} of at most {result.step_size:.4g} s, "
                  f"{result.iterations} Newton iterations, {result.halvings} halved")
        for time, name in result.events:
            print(f"event       {name} at t = {time:.9g} s")
        if result.success and result.message.startswith("stopped by"):
            print(f"stopped     {result.message}")
        if not result.success:
            print(f"incomplete  {result.message}")

    def verdict(self, result: Any) -> int:
        return EXIT_OK if result.success else EXIT_SOLVER_FAILURE


def cmd_simulate(args: argparse.Namespace) -> int:
    return execute(Simulate(args))
